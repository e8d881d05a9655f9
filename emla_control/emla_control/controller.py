"""The adaptive inverse-system controller: model parameters, a guard on new estimates, the per-sample law.

The law itself (inverse system, state feedback, observer, voltage limit) is `inverse.control_step`; this
class holds its coefficients and state, and decides which identified parameters it takes. It has no
integrator, and the observer is driven by the jerk the *limited* voltage gives, so saturation at the
supply voltage winds nothing up.
"""
import collections
import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from emla_core.parameters import PARAMETER_NAMES, ActuatorParameters

from . import inverse

# 300 Hz: a +50 % step of R or m left uncorrected costs 40-100 um of tracking on the 4 mm stroke (the paper's
# visibly slower, overshooting response), while the identifier's residual errors (~0.1 %) cost less than the
# sensor noise does (~0.4 um rms); higher bandwidths amplify that noise into the voltage.
DEFAULT_BANDWIDTH = 300.0  # Hz
DEFAULT_DAMPING = 1.0
DEFAULT_OBSERVER_BANDWIDTH = 1000.0  # Hz
PREDICTION_STEP = 1e-4  # s: the largest RK4 step of step_ahead's prediction (a quarter of L/R of Table 1)
# Guard on identified parameters: the identifier's start-up transient (samples), and the largest factor by
# which R, L, Km or m may move in one update (a drift or even a +50 % step arrives over many updates).
DEFAULT_MIN_SAMPLES = 1000  # 0.1 s at 10 kHz
DEFAULT_MAX_JUMP = 2.0
_POSITIVE = ('resistance', 'inductance', 'emf_constant', 'mass')
EFFECTS = {'coulomb_force': inverse.FC, 'spring_stiffness': inverse.KS, 'spring_center': inverse.XC}
ADAPTED_EFFECTS = ('coulomb_force', 'spring_stiffness')  # what an online identifier estimates (online_effects.py)


class InverseSystemController:
    """Adaptive inverse-system position controller of an EMLA (SI units; bandwidth in Hz).

    params: the initial model (ActuatorParameters). Call `step` once per control interval of
    `control_period` s with the sampled current and position and the reference (s, s', s'', s''') at the
    interval's midpoint (`midpoint_times`); it returns the voltage to hold over the interval, within
    +-supply_voltage. `update_parameters` offers it new identified parameters.

    effects: the model's Coulomb friction and spring, {'coulomb_force': N, 'spring_stiffness': N/m (either
    sign), 'spring_center': m}, compensated by the law (inverse.py); none by default. adapt_effects: take the
    coulomb_force and spring_stiffness of accepted estimates too (an online identifier's, whose load force is
    the total at x = 0: the spring's centre is then 0).
    """

    def __init__(self, params: ActuatorParameters, *, bandwidth: float = DEFAULT_BANDWIDTH,
                 damping: float = DEFAULT_DAMPING, control_period: float = 1e-4, supply_voltage: float = 24.0,
                 observer_bandwidth: float = DEFAULT_OBSERVER_BANDWIDTH, min_samples: int = DEFAULT_MIN_SAMPLES,
                 max_jump: float = DEFAULT_MAX_JUMP, effects: Mapping[str, float] | None = None,
                 adapt_effects: bool = False) -> None:
        if not (math.isfinite(control_period) and control_period > 0.0):
            raise ValueError(f'control_period must be positive, got {control_period!r}')
        if not (math.isfinite(supply_voltage) and supply_voltage > 0.0):
            raise ValueError(f'supply_voltage must be positive, got {supply_voltage!r}')
        if not max_jump > 1.0:
            raise ValueError(f'max_jump must exceed 1, got {max_jump!r}')
        self.control_period = float(control_period)
        self.supply_voltage = float(supply_voltage)
        self.bandwidth, self.damping = float(bandwidth), float(damping)
        self.min_samples, self.max_jump = min_samples, float(max_jump)
        self.adapt_effects = bool(adapt_effects)
        self._c = np.empty(inverse.N_COEFFICIENTS)
        self._c[[inverse.K0, inverse.K1, inverse.K2]] = inverse.feedback_gains(bandwidth, damping)
        self._c[[inverse.L1, inverse.L2]] = inverse.observer_gains(observer_bandwidth, control_period)
        self._c[inverse.TS] = self.control_period
        self._c[inverse.SUPPLY] = self.supply_voltage
        self.set_effects(effects or {})
        self._set_parameters(params.physical())
        self._z = np.zeros(2)
        self._held = 0.0  # step_ahead: the voltage over the coming interval
        self._prediction_steps = math.ceil(self.control_period / PREDICTION_STEP - 1e-9)
        self.accepted = 0
        self.rejections: collections.Counter[str] = collections.Counter()  # reason -> count

    def set_effects(self, effects: Mapping[str, float]) -> None:
        """Compensate the model's effects {'coulomb_force', 'spring_stiffness', 'spring_center'} (missing: 0)."""
        unknown = sorted(set(effects) - set(EFFECTS))
        if unknown:
            raise ValueError(f'unknown effect parameter(s) {unknown}; known: {sorted(EFFECTS)}')
        if effects.get('coulomb_force', 0.0) < 0.0:
            raise ValueError(f'coulomb_force must be >= 0, got {effects["coulomb_force"]!r}')
        for name, slot in EFFECTS.items():
            self._c[slot] = float(effects.get(name, 0.0))

    @property
    def effects(self) -> dict[str, float]:
        """The effects the law compensates now, {'coulomb_force', 'spring_stiffness', 'spring_center'}."""
        return {name: float(self._c[slot]) for name, slot in EFFECTS.items()}

    @property
    def parameters(self) -> ActuatorParameters:
        """The model the law uses now, as ActuatorParameters."""
        return ActuatorParameters(**self._params, supply_voltage=self.supply_voltage)

    @property
    def rejected(self) -> int:
        return sum(self.rejections.values())

    def reset(self, position: float = 0.0) -> None:
        """Start the observer at rest at `position` (and step_ahead with 0 V held)."""
        self._z[:] = (position, 0.0)
        self._held = 0.0

    def midpoint_times(self, times: ArrayLike) -> np.ndarray:
        """Where to evaluate the reference for control intervals starting at `times`."""
        return np.asarray(times, dtype=float) + 0.5 * self.control_period

    def step(self, current: float, position: float, reference: Sequence[float]) -> float:
        """The voltage for the coming interval; reference = (s, s', s'', s''') at its midpoint."""
        r0, r1, r2, r3 = reference
        return inverse.control_step(self._z, self._c, r0, r1, r2, r3, current, position)

    def start_ahead(self, current: float, position: float, reference: Sequence[float]) -> float:
        """Start a run of step_ahead at its first sample: reset there, and return the voltage for the interval
        that sample starts, the law's without delay (as if computed before the run); step_ahead then goes on
        from the same sample. reference = (s, s', s'', s''') at that interval's midpoint."""
        self.reset(position)
        r0, r1, r2, r3 = reference
        self._held = inverse.law_voltage(self._z, self._c, r0, r1, r2, r3, current, position)
        return self._held

    def step_ahead(self, current: float, position: float, reference: Sequence[float]) -> float:
        """The voltage for the interval after the coming one, from the sample at the coming one's start: one
        control period of computational delay, as a controller has that computes while the plant runs. The
        coming interval's voltage is the one step_ahead returned last (0 V after reset); the state at its end
        is predicted from the model (RK4 in steps of at most PREDICTION_STEP), so the delay costs little
        tracking. reference = (s, s', s'', s''') at the midpoint of the interval after the coming one."""
        r0, r1, r2, r3 = reference
        self._held = inverse.delayed_control_step(self._z, self._c, r0, r1, r2, r3, current, position, self._held,
                                                  self._prediction_steps)
        return self._held

    def update_parameters(self, estimate: Mapping[str, float], samples: int | None = None) -> bool:
        """Take identified parameters (a mapping with some of PARAMETER_NAMES) unless implausible.

        Rejected, keeping the previous ones: fewer than `min_samples` behind the estimate, non-finite values,
        non-positive R, L, Km or m, negative B, a load force beyond the stall force Km U / R, or R, L, Km or
        m moving by more than a factor `max_jump` from the values held. Returns whether it was taken. With
        adapt_effects, its coulomb_force (negative: 0) and spring_stiffness are taken with it.
        """
        reason = self._implausible(estimate, samples)
        if reason:
            self.rejections[reason] += 1
            return False
        self._set_parameters({**self._params, **{k: float(estimate[k]) for k in PARAMETER_NAMES if k in estimate}})
        adapted = {k: float(estimate[k]) for k in ADAPTED_EFFECTS if k in estimate} if self.adapt_effects else {}
        if adapted:
            effects = {**self.effects, **adapted, 'spring_center': 0.0}
            self.set_effects(dict(effects, coulomb_force=max(effects['coulomb_force'], 0.0)))
        self.accepted += 1
        return True

    def _implausible(self, estimate, samples):
        if samples is not None and samples < self.min_samples:
            return 'start-up'
        new = {k: estimate[k] for k in PARAMETER_NAMES if k in estimate}
        if not new:
            return 'no parameters'
        checked = list(new.values()) + [estimate[k] for k in ADAPTED_EFFECTS if self.adapt_effects and k in estimate]
        if not all(isinstance(v, (int, float, np.floating)) and math.isfinite(v) for v in checked):
            return 'non-finite'
        if any(new.get(k, 1.0) <= 0.0 for k in _POSITIVE) or new.get('damping', 0.0) < 0.0:
            return 'non-physical'
        merged = {**self._params, **new}
        if abs(merged['load_force']) > merged['emf_constant'] * self.supply_voltage / merged['resistance']:
            return 'load beyond stall force'
        if any(not 1.0 / self.max_jump <= new[k] / self._params[k] <= self.max_jump for k in _POSITIVE if k in new):
            return 'jump'
        return None

    def _set_parameters(self, physical):
        self._params = dict(physical)
        for name, slot in zip(PARAMETER_NAMES, (inverse.R, inverse.L, inverse.KM, inverse.M, inverse.B, inverse.FL)):
            self._c[slot] = self._params[name]
