"""Position control of a solenoid (a proportional valve) by its inverse model: a force that goes with I^2
(docs/physics.md §9.3).

The co-energy force F = I^2 L'(x) / 2 only pulls (towards +x, closing the gap); the spring F0 + k x returns the
armature. Read backwards, the model gives, per control interval:

    a*   = s'' + k2 (s' - v) + k1 (s - x) + k0 integral (s - x)   the acceleration the motion needs, with state
                                                                  feedback (poles (p + w)(p^2 + 2 zeta w p + w^2))
    F*   = m a* + B v + F0 + k x                                  the force that gives it
    I*   = sqrt(2 max(F*, 0) / L'(x))                             the current that makes it (never negative:
                                                                  below zero force the spring does the work)
    u    = R I + (psi* - psi) / tau + (psi*_next - psi*) / Ts     a flux loop: psi = L(x) I from the measured
                                                                  current, psi* = L(x) I*, time constant tau

so in the flux loop psi follows psi* with the lag tau when R is the coil's: with a resistance R' it settles
tau (R' - R) I away from it, a force error of about 2 tau (R' - R) / L(x) (12 % of the force per +30 % of R for
the valve of issue 24 at tau = 0.5 ms), which the feedback then has to fight. The adaptive controller takes R from
an online estimate (emla_identification.solenoid_online) instead. The state (x, v) comes from an observer on the
measured position driven by the model's acceleration with the measured current; the integral stops while the
voltage is limited (no wind-up).
"""
import math
from collections.abc import Sequence

import numpy as np

from emla_core.physics.solenoid import SolenoidParameters

DEFAULT_BANDWIDTH = 80.0           # Hz, of the position loop
DEFAULT_DAMPING = 1.0
DEFAULT_FLUX_TIME = 5e-4           # s, tau of the flux loop
DEFAULT_OBSERVER_BANDWIDTH = 800.0  # Hz
MAX_JUMP = 2.0                     # the largest factor R may move by in one update


class SolenoidController:
    """Inverse-model position controller of a solenoid (SI units; bandwidths in Hz).

    Call `step` once per control interval with the measured current and position and the reference
    (s, s', s'', s''') at the interval's midpoint (`midpoint_times`); it returns the voltage to hold, within
    +-supply_voltage. `update_resistance` offers it a new estimate of R.

    Parameters
    ----------
    params : SolenoidParameters
        The controller's model (and its initial R).
    control_period : float
        Ts (s).
    bandwidth, damping : float
        The position loop's poles.
    flux_time : float
        tau of the flux loop (s).
    observer_bandwidth : float
        Of the position-velocity observer.
    """

    def __init__(self, params: SolenoidParameters, *, control_period: float = 1e-4,
                 bandwidth: float = DEFAULT_BANDWIDTH, damping: float = DEFAULT_DAMPING,
                 flux_time: float = DEFAULT_FLUX_TIME, observer_bandwidth: float = DEFAULT_OBSERVER_BANDWIDTH) -> None:
        for name, value in (('control_period', control_period), ('bandwidth', bandwidth),
                            ('flux_time', flux_time), ('observer_bandwidth', observer_bandwidth)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f'{name} must be positive, got {value!r}')
        self.params = params
        self.control_period = float(control_period)
        self.flux_time = float(flux_time)
        w = 2.0 * math.pi * bandwidth
        self._gains = ((2.0 * damping + 1.0) * w, (2.0 * damping + 1.0) * w * w, w ** 3)   # k2, k1, k0
        pole = math.exp(-2.0 * math.pi * observer_bandwidth * self.control_period)   # a double pole
        self._observer = (1.0 - pole * pole, (1.0 - pole) ** 2)
        self.accepted = self.rejected = 0
        self.reset(params.stroke_min)

    def reset(self, position: float) -> None:
        """Start at rest at `position` (m)."""
        self._x, self._v, self._integral, self._flux_command = float(position), 0.0, 0.0, None
        self._voltage = 0.0   # the latest voltage returned

    def midpoint_times(self, t: np.ndarray) -> np.ndarray:
        """The times the reference is wanted at for intervals starting at t: their midpoints."""
        return np.asarray(t, dtype=float) + 0.5 * self.control_period

    @property
    def resistance(self) -> float:
        return self.params.resistance

    def update_resistance(self, value: float) -> bool:
        """Take an estimate of R (ohm) unless it is not a finite positive number or moves R by more than
        MAX_JUMP times at once; whether it was taken."""
        if not (math.isfinite(value) and self.params.resistance / MAX_JUMP < value < self.params.resistance * MAX_JUMP):
            self.rejected += 1
            return False
        self.params = self.params.replace(resistance=float(value))
        self.accepted += 1
        return True

    def step(self, current: float, position: float, reference: Sequence[float]) -> float:
        """The voltage (V) to hold over the next interval, from the measured current (A), position (m) and the
        reference (s, s', s'', s''') at its midpoint."""
        x, v = self._observe(current, position)
        return self._law(current, x, v, reference)

    def step_ahead(self, current: float, position: float, reference: Sequence[float]) -> float:
        """The voltage (V) to hold over the interval after the next, from the current and position measured now
        and the reference at that interval's midpoint: one interval of computational delay, as a graph of
        processes has it. The law acts on the state it predicts for that interval's start: the position and
        velocity from the observer, the current from the flux that the voltage held meanwhile (the last one
        returned) makes."""
        p, ts = self.params, self.control_period
        x, _ = self._observe(current, position)
        flux = float(p.inductance(x)) * current + ts * (self._voltage - p.resistance * current)
        return self._law(flux / float(p.inductance(self._x)), self._x, self._v, reference)

    def _law(self, current, x, v, reference):
        """The voltage from the state (I, x, v) at an interval's start and the reference at its midpoint."""
        p, ts = self.params, self.control_period
        half = 0.5 * ts   # the law acts over the interval: its state at the midpoint
        xm, vm = x + half * v, v
        s, ds, dds = reference[0], reference[1], reference[2]
        k2, k1, k0 = self._gains
        error = s - xm
        acceleration = dds + k2 * (ds - vm) + k1 * error + k0 * self._integral
        force = p.mass * acceleration + p.damping * vm + p.load(xm)
        slope = float(p.inductance_slope(xm))
        command = math.sqrt(2.0 * max(force, 0.0) / slope)
        inductance = float(p.inductance(xm))
        flux, flux_command = inductance * current, inductance * command
        previous = flux_command if self._flux_command is None else self._flux_command
        u = p.resistance * current + (flux_command - flux) / self.flux_time + (flux_command - previous) / ts
        self._flux_command = flux_command
        limited = min(max(u, -p.supply_voltage), p.supply_voltage)
        if limited == u:   # the integral stops while the voltage is limited
            self._integral += error * ts
        self._voltage = limited
        return limited

    def _observe(self, current, position):
        """(x, v) after correcting the prediction with the measured position; the next prediction made."""
        p, ts = self.params, self.control_period
        gain_x, gain_v = self._observer
        error = position - self._x
        x, v = self._x + gain_x * error, self._v + gain_v * error / ts
        acceleration = (p.coil_force(x, current) - p.damping * v - p.load(x)) / p.mass
        self._x, self._v = x + ts * v + 0.5 * ts * ts * acceleration, v + ts * acceleration
        return x, v
