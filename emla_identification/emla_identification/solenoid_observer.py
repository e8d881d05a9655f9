"""Sensorless position of a solenoid from its coil's voltage and current (docs/physics.md §9.2).

Once L(x) = L0 + a / (g0 - x) and the mechanics are identified on a bench with a position sensor
(emla_identification.solenoid), the coil's current locates the armature: I = psi / L(x) (with the iron's terms
of the physics layer when the model has them), psi the flux linkage. An extended Kalman filter carries the state
(psi, x, v, R, dR/dt):

- psi over each held-voltage interval from the coil's equation, dpsi/dt = u - R I: the voltage exactly, the
  measured current by the trapezoid corrected for the jump of dI/dt where the voltage steps,
      psi_k = psi_k-1 + u_k-1 Ts - R (Ts (I_k-1 + I_k) / 2 + Ts^2 (u_k-1 - u_k-2) / (12 l(x_k-1)))
  with the current's noise as the process noise (with eddy currents I itself jumps there by
  G (u_k-1 - u_k-2) / (1 + R G), half of it in the trapezoid, and dI/dt's jump is over (1 + R G)^2);
- x and v by the identified mechanics (physics.solenoid.armature_step: the co-energy force at the measured
  current (the circuit's, I (1 + R G) - G u, with eddy currents), the spring, damping, friction, inelastic
  stops), with a white force noise `force_noise` for what they miss; an armature on a stop stays there while the
  net force presses it on;
- R with its rate a random walk (`drift`): a coil that warms is followed without lag. An error dR makes psi drift
  by dR I per second, so R must be known to about 0.01 % over a 10 ms flight: the rests on the stops, where x is
  known, measure it.

Each sample's current is the measurement, I = psi / L(x) (with the eddy currents' G dpsi/dt when the model has
them) with the current's noise: where the armature rests it
corrects psi and R, in flight psi and x together, the mechanics weighing how far the noisy current may move x
(at the open stop, where L(x) is flattest, one sample's noise is about 25 um). Offline (`smooth`), a
Rauch-Tung-Striebel smoother takes the state back over each flight, which then sees where it ended; it does not
run across a landing or a rest, where the filter's state is reset. `held` flags the samples in flight whose
current alone would leave the position noisier than `tolerance`: the mechanics carried them.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from emla_core.errors import InputError
from emla_core.physics.solenoid import (
    SOLENOID_EFFECTS,
    SOLENOID_PARAMETER_NAMES,
    SolenoidParameters,
    armature_step,
    circuit_current,
    coil_current,
)

from .solenoid import SolenoidResult
from .solenoid_online import ResistanceEstimate

DRIFT = 0.1           # 1/s^1.5: the random walk of R's rate, relative: its standard deviation after one second
START = 0.05          # R's relative standard deviation at the start (the bench's R, the coil perhaps warmer)
STEPS = 10            # RK4 steps of the mechanics per sample (physics.solenoid.armature_step)
TOLERANCE = 0.2       # of the stroke: the position noise from the current alone past which a sample is `held`
FORCE_NOISE = 1e-3    # 1/sqrt(Hz): the white force the mechanics miss, relative to the spring's k x_max + F0
PINNED = 1e-12        # m^2 and (m/s)^2: the variance left in x and v where the armature is put on a stop


@dataclass
class PositionEstimate:
    """The observer's output per sample: `position` (m) and its one-sigma `position_std` (m, the filter's or
    smoother's), `flux_linkage` (V s), `resistance` (ohm, as tracked) and its `resistance_std`, and `held` (True
    in flight where the current alone could not locate the armature and the mechanics carried it)."""

    position: np.ndarray
    position_std: np.ndarray
    flux_linkage: np.ndarray
    resistance: np.ndarray
    resistance_std: np.ndarray
    held: np.ndarray

    def write_csv(self, time: ArrayLike, path: Path | str) -> None:
        """Write the estimate as CSV: a header `t,position_estimate,position_std,resistance_estimate,held` and one
        row per sample (s, m, m, ohm, 1 where held), each number in the shortest form that reads back to the same
        float."""
        with open(path, 'w', encoding='ascii', newline='') as f:
            f.write('t,position_estimate,position_std,resistance_estimate,held\n')
            for row in zip(np.asarray(time, dtype=float).tolist(), self.position.tolist(),
                           self.position_std.tolist(), self.resistance.tolist(), self.held.astype(int).tolist(),
                           strict=True):
                f.write(','.join(map(repr, row)) + '\n')


def observer_model(fit: SolenoidResult | Mapping) -> tuple[SolenoidParameters, float]:
    """(SolenoidParameters, the current's noise in A) of an identification: a SolenoidResult or its JSON
    (`emla identify --actuator solenoid --json`), with the effects it fitted (SOLENOID_EFFECTS, their settings);
    the noise is the electrical fit's RMS residual over R.

    Raises
    ------
    InputError
        A JSON without the solenoid's parameters, stroke or electrical fit, or with impossible values.
    """
    data = fit.to_dict() if isinstance(fit, SolenoidResult) else fit
    try:
        if data.get('model') != 'solenoid':
            raise KeyError('model')
        values = {name: float(data['parameters'][name]) for name in SOLENOID_PARAMETER_NAMES}
        for names, settings in SOLENOID_EFFECTS.values():   # the effects fitted with it, as the model file's
            values.update({field: max(float(data['parameters'][name]), 0.0) for name, field in names.items()
                           if name in data['parameters']})
            values.update({name: float(data.get('settings', {})[name]) for name in settings
                           if name in data.get('settings', {})})
        stroke = {name: float(data['stroke'][name]) for name in ('stroke_min', 'stroke_max')}
        noise = float(data['fit']['electrical']['rms']) / values['resistance']
        return SolenoidParameters(**values, **stroke), noise
    except (KeyError, TypeError, AttributeError) as exc:
        raise InputError(f'not a solenoid identification (`emla identify --actuator solenoid --json`): no {exc}') \
            from None
    except (ValueError, ZeroDivisionError) as exc:
        raise InputError(f'the solenoid identification holds impossible values: {exc}') from None


def observe_position(params: SolenoidParameters, sample_period: float, voltage: ArrayLike, current: ArrayLike, *,
                     current_noise: float, tolerance: float = TOLERANCE, drift: float = DRIFT,
                     force_noise: float = FORCE_NOISE, smooth: bool = True) -> PositionEstimate:
    """Estimate the armature's position at every sample from the coil's voltage and current alone.

    Parameters
    ----------
    params : SolenoidParameters
        The identified solenoid (R at the record's start, the inductance curve, the mechanics, the end stops).
    sample_period : float
        Ts (s).
    voltage, current : array_like
        The voltage held over each sample interval (V) and the current sampled at its start (A).
    current_noise : float
        The current's noise standard deviation (A), > 0: the measurement's noise.
    tolerance : float, optional
        The position noise from the current alone past which a sample in flight is flagged `held`, as a fraction
        of the stroke.
    drift : float, optional
        The random walk of R's rate (relative, after 1 s): how fast R is let follow a warming coil.
    force_noise : float, optional
        The white force the identified mechanics miss (1/sqrt(Hz), relative to the spring's k x_max + F0): larger
        trusts the current more and the mechanics less.
    smooth : bool, optional
        Smooth the state back over each flight (offline: a flight then sees where it ended); False for the causal
        filter alone (online).

    Returns
    -------
    PositionEstimate

    Raises
    ------
    InputError
        Arrays of different lengths, fewer than 2 samples, non-finite values or a non-positive sample period or
        noise.
    """
    u, i = (np.asarray(values, dtype=float) for values in (voltage, current))
    if u.ndim != 1 or u.shape != i.shape or u.size < 2:
        raise InputError(f'the observer needs voltage and current of one length, at least 2 samples; got '
                         f'{u.shape} and {i.shape}')
    for name, values in (('voltage', u), ('current', i)):
        if not np.all(np.isfinite(values)):
            raise InputError(f'non-finite {name} at sample {int(np.argmax(~np.isfinite(values)))}')
    observer = PositionObserver(params, sample_period, current_noise=current_noise, drift=drift,
                                force_noise=force_noise,
                                tolerance=tolerance * (params.stroke_max - params.stroke_min))
    n = u.size
    state, cov, ahead, ahead_cov, transition = (np.empty((n, 5)), np.empty((n, 5, 5)), np.empty((n, 5)),
                                                np.empty((n, 5, 5)), np.empty((n, 5, 5)))
    reset, held = np.zeros(n, bool), np.zeros(n, bool)
    for k in range(n):
        ahead[k], ahead_cov[k], transition[k], reset[k], _, held[k] = observer.step(u[k], i[k])
        state[k], cov[k] = observer.state, observer.cov
    if smooth:
        state, cov = _smoothed(state, cov, (ahead, ahead_cov, transition), reset)
    position = np.clip(state[:, 1], params.stroke_min, params.stroke_max)
    return PositionEstimate(position=position, position_std=np.sqrt(np.maximum(cov[:, 1, 1], 0.0)),
                            flux_linkage=state[:, 0].copy(), resistance=state[:, 3].copy(),
                            resistance_std=np.sqrt(np.maximum(cov[:, 3, 3], 0.0)), held=held)


class PositionObserver(ResistanceEstimate):
    """The causal observer, sample by sample (online: the identifier node with `position_observer`): the extended
    Kalman filter on (psi, x, v, R, dR/dt) of the module doc, from rest on the open stop.

    Parameters
    ----------
    params : SolenoidParameters
        The identified solenoid (R at the start, the inductance curve, the mechanics and the end stops).
    sample_period : float
        Ts (s), > 0.
    current_noise : float
        The current's noise standard deviation (A), > 0.
    tolerance : float, optional
        The position noise from the current alone past which a sample in flight is `held` (m; default TOLERANCE
        of the stroke).
    drift : float, optional
        The random walk of R's rate (relative, after 1 s).
    force_noise : float, optional
        The white force the mechanics miss (1/sqrt(Hz), relative to k x_max + F0).

    Examples
    --------
    >>> observer = PositionObserver(params, 2e-4, current_noise=0.005)      # doctest: +SKIP
    >>> position, held = observer.update(voltage, current)                 # doctest: +SKIP
    >>> observer.resistance                                                 # doctest: +SKIP
    """

    def __init__(self, params: SolenoidParameters, sample_period: float, *, current_noise: float,
                 tolerance: float | None = None, drift: float = DRIFT, force_noise: float = FORCE_NOISE) -> None:
        if not (sample_period > 0 and current_noise > 0):
            raise InputError(f'the observer needs a positive sample period and current noise, got '
                             f'{sample_period!r} and {current_noise!r}')
        stroke = params.stroke_max - params.stroke_min
        self.params, self.sample_period, self.current_noise = params, float(sample_period), float(current_noise)
        self.tolerance = TOLERANCE * stroke if tolerance is None else tolerance
        self.drift = drift
        force = force_noise * (params.spring_stiffness * params.stroke_max + params.spring_preload)
        self._acceleration_density = (force / params.mass) ** 2    # (m/s^2)^2 / Hz
        self._kernel = params.kernel_vector()
        self.state = self.cov = None   # (psi, x, v, R, dR/dt) and its covariance, from the first sample on
        self.samples = 0
        self._previous = None   # (u_k-1, u_k-2, I_k-1) of the last sample
        self._stop = 0          # the stop the armature rests on (0 open, 1 closed) or None in flight

    def gap(self) -> None:
        """Samples were lost (the identifier node's call): no flux is integrated over the gap; the next sample
        starts the flux and the position afresh, anywhere on the stroke, from its current (R and its rate are
        kept)."""
        self._previous = None

    def update(self, voltage: ArrayLike, current: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Take a frame of consecutive samples (the voltage held from each sample to the next, the current at
        each): (the position at each sample (m), held flags). InputError for arrays of different lengths or
        non-finite values."""
        u, i = (np.asarray(v, dtype=float).reshape(-1) for v in (voltage, current))
        if u.shape != i.shape or not (np.all(np.isfinite(u)) and np.all(np.isfinite(i))):
            raise InputError(f'the observer takes finite voltage and current of one length (a gap() between '
                             f'runs of them), got {u.size} and {i.size} samples')
        position, held = np.empty(u.size), np.zeros(u.size, bool)
        for k in range(u.size):
            *_, position[k], held[k] = self.step(u[k], i[k])
        return position, held

    def step(self, voltage, current):
        """One sample: (the predicted state, its covariance, the transition, whether the state's x and v were reset
        (put on a stop), the position, held)."""
        p, noise = self.params, self.current_noise
        transition = np.eye(5)
        before = self._previous[0] if self._previous else voltage   # the voltage held up to this sample
        if self.state is None or self._previous is None:
            reset = self._start(self._circuit(current, before))
        else:
            transition, reset = self._predict(current)
        ahead, ahead_cov = self.state.copy(), self.cov.copy()
        # the measurement I = h(psi, x): the circuit's current at the flux linkage and position, and the eddy
        # currents' G dpsi/dt with the voltage of the interval ending here
        psi, x = self.state[0], self.state[1]
        inductance, slope = p.inductance(x), p.inductance_slope(x)
        scale = 1.0 / (1.0 + self.state[3] * p.eddy_conductance)
        predicted = coil_current(psi / inductance + p.saturation_coefficient * psi ** 3 - p.remanence_current,
                                 before, self.state[3], p.eddy_conductance)
        h = scale * np.array([1.0 / inductance + 3.0 * p.saturation_coefficient * psi * psi,
                              -psi * slope / inductance ** 2, 0.0, -p.eddy_conductance * predicted, 0.0])
        gain = self.cov @ h / (h @ self.cov @ h + noise * noise)
        self.state = self.state + gain * (current - predicted)
        self.cov = self.cov - np.outer(gain, h @ self.cov)
        if self._stop is None and not p.stroke_min <= self.state[1] <= p.stroke_max:
            self._land(self._circuit(current, before))
            reset = True
        self._previous = (voltage, self._previous[0] if self._previous else voltage, current)
        self.samples += 1
        position = min(max(float(self.state[1]), p.stroke_min), p.stroke_max)
        held = self._stop is None and _spread(p, position, current, noise) > self.tolerance
        return ahead, ahead_cov, transition, reset, position, held

    def _start(self, current):
        """The first sample (at rest on the open stop) or the first after a gap (anywhere on the stroke, its flux
        from the circuit's `current`): the state before the measurement. Returns True (x and v reset)."""
        p, noise = self.params, self.current_noise
        low, high = p.stroke_min, p.stroke_max
        if self.state is None:
            self.state = np.array([p.flux_linkage(low, current), low, 0.0, p.resistance, 0.0])
            self.cov = np.diag([(p.inductance(low) * noise) ** 2, PINNED, PINNED, (START * p.resistance) ** 2,
                                (self.drift * p.resistance) ** 2])
            self._stop = 0
            return True
        middle = 0.5 * (low + high)
        spread = (p.flux_linkage(high, current) - p.flux_linkage(low, current)) ** 2 / 12
        self.state = np.array([p.flux_linkage(middle, current), middle, 0.0, self.state[3], self.state[4]])
        self.cov[:3, :] = self.cov[:, :3] = 0.0
        self.cov[0, 0], self.cov[1, 1] = spread + (p.inductance(middle) * noise) ** 2, (high - low) ** 2 / 12
        self.cov[2, 2] = self._acceleration_density * 0.01   # the velocity's variance: 10 ms of the force noise
        self._stop = None
        return True

    def _predict(self, current):
        """The state over the interval from the last sample: (the transition, whether x and v were reset)."""
        p, ts, noise = self.params, self.sample_period, self.current_noise
        u1, u2, i1 = self._previous
        psi, x, v, resistance, rate = self.state
        incremental = 1.0 / (1.0 / p.inductance(x) + 3.0 * p.saturation_coefficient * psi * psi)
        eddy = 1.0 + resistance * p.eddy_conductance   # with eddy currents the current also jumps where u steps
        q = 0.5 * ts * (i1 + current + p.eddy_conductance * (u1 - u2) / eddy) \
            + ts * ts / 12 * (u1 - u2) / (incremental * eddy ** 2)
        x, v, mechanics, stop = armature_step(x, v, self._circuit(i1, u2), self._circuit(current, u1), ts, STEPS,
                                              self._kernel)
        self._stop = None if stop < 0 else stop
        self.state = np.array([psi + u1 * ts - resistance * q, x, v, resistance + rate * ts, rate])
        transition = np.eye(5)
        transition[0, 3], transition[3, 4] = -q, ts
        transition[1:3, 1:3] = mechanics
        noise_cov = np.zeros((5, 5))
        noise_cov[0, 0] = (resistance * noise * ts) ** 2 / 2
        noise_cov[4, 4] = (self.drift * p.resistance) ** 2 * ts
        if self._stop is None:   # the force noise as a white acceleration over the interval
            g = self._acceleration_density
            noise_cov[1:3, 1:3] = g * np.array([[ts ** 3 / 3, ts ** 2 / 2], [ts ** 2 / 2, ts]])
        self.cov = transition @ self.cov @ transition.T + noise_cov
        if self._stop is not None:
            self._pin()
            return transition, True
        return transition, False

    def _land(self, circuit):
        """The measurement put the armature in flight beyond a stop: on the stop, at rest (x and v reset); resting
        there if the net force at the circuit's current presses it on."""
        p = self.params
        stop = 0 if self.state[1] < p.stroke_min else 1
        self.state[1], self.state[2] = (p.stroke_min, p.stroke_max)[stop], 0.0
        if armature_step(self.state[1], 0.0, circuit, circuit, self.sample_period, 1, self._kernel)[3] == stop:
            self._stop = stop
        self._pin()

    def _circuit(self, current, before):
        """The circuit's current M_c of a sampled coil current, `before` the voltage held up to the sample, at the
        R tracked (the current itself without eddy currents)."""
        return circuit_current(current, before, self.resistance, self.params.eddy_conductance)

    def _pin(self):
        """x and v known: their rows and columns of the covariance cleared to PINNED."""
        self.cov[1:3, :] = self.cov[:, 1:3] = 0.0
        self.cov[1, 1] = self.cov[2, 2] = PINNED

    @property
    def resistance(self) -> float:
        """R as tracked now (ohm; the identified one before the first sample)."""
        return float(self.params.resistance if self.state is None else self.state[3])

    @property
    def std(self) -> float:
        """Its one-sigma (ohm)."""
        return float(START * self.params.resistance if self.cov is None else math.sqrt(max(self.cov[3, 3], 0.0)))


def _smoothed(state, cov, predicted, reset):
    """The Rauch-Tung-Striebel smoother's states and covariances from the filter's, back over each run of samples
    between resets (a landing or a rest resets x and v, which the linear transition does not carry across)."""
    ahead, ahead_cov, transition = predicted
    state, cov = state.copy(), cov.copy()
    for k in range(len(state) - 2, -1, -1):
        if reset[k + 1]:
            continue
        gain = np.linalg.solve(ahead_cov[k + 1], transition[k + 1] @ cov[k]).T
        state[k] = state[k] + gain @ (state[k + 1] - ahead[k + 1])
        cov[k] = cov[k] + gain @ (cov[k + 1] - ahead_cov[k + 1]) @ gain.T
    return state, cov


def _spread(p, x, current, noise):
    """The position's standard deviation at x from the current's noise alone: through I = psi / L(x) at the flux,
    (g0 - x)^2 L(x) noise / (a |I|) (infinite without current)."""
    if current == 0.0:
        return math.inf
    return (p.gap - x) ** 2 * p.inductance(x) * noise / (p.gap_coefficient * abs(current))
