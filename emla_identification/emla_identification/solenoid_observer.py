"""Sensorless position of a solenoid from its coil's voltage and current (docs/physics.md §9.2).

Once L(x) = L0 + a / (g0 - x) is identified on a bench with a position sensor (emla_identification.solenoid), the
flux linkage gives the position: psi = L(x) I, so x = g0 - a / (psi / I - L0), within the stroke. The flux
linkage comes from the coil's equation dpsi/dt = u - R I over each held-voltage interval (the voltage exactly, the
current by the trapezoid corrected for the jump of dI/dt where the voltage steps, (u_k - u_k-1) / L(x)):

    psi_k = psi_k-1 + u_k-1 Ts - R (Ts (I_k-1 + I_k) / 2 + Ts^2 (u_k-1 - u_k-2) / (12 L(x_k-1)))

An error dR makes psi drift by dR I per second (0.1 % of R leaves an armature floating 10 ms some 10 um off), so
R is tracked by a Kalman filter on (psi, R, dR/dt), the rate a random walk (a coil warming follows without lag).
Its measurements are the end stops: where the armature rests on one, psi = L(stop) I. It rests on a stop when
the identified static force balance presses it on (the spring at the open stop, the coil's I^2 L'(x)/2 at the
closed) and the inverted position lies beyond the stop or within three standard deviations of the current's
noise of it; arriving on a stop it was not on also needs the position within MARGIN of the stroke (an armature
in flight at a small current is not put on the stop early). Offline (`smooth`), a Rauch-Tung-Striebel smoother
takes the flux and R back over the record, so that a flight between two rests is corrected from both ends.
Where the current is too small to invert (the position's noise from the current's and the flux's above
`tolerance`), the identified mechanics carry the last position and velocity on and the sample is flagged
`held`; where the spring wins along the whole stroke, the position does not rise.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from emla_core.errors import InputError
from emla_core.physics.solenoid import SOLENOID_PARAMETER_NAMES, SolenoidParameters

from .solenoid import SolenoidResult
from .solenoid_online import ResistanceEstimate

DRIFT = 0.01        # 1/s^1.5: the random walk of R's rate, relative: its standard deviation after one second
START = 0.05        # R's relative standard deviation at the start (the bench's R, the coil perhaps warmer)
COAST = 10          # semi-implicit Euler steps per sample of the mechanics where the position is not inverted
MARGIN = 0.1        # of the stroke: how near a stop the inverted position must come to count as on it
TOLERANCE = 0.2     # of the stroke: the largest position noise (current and flux) an inverted sample may take


@dataclass
class PositionEstimate:
    """The observer's output per sample: `position` (m), `flux_linkage` (V s), `resistance` (ohm, as tracked) and
    `held` (True where the current was too small to invert and the mechanics carried the position on)."""

    position: np.ndarray
    flux_linkage: np.ndarray
    resistance: np.ndarray
    held: np.ndarray

    def write_csv(self, time: ArrayLike, path: Path | str) -> None:
        """Write the estimate as CSV: a header `t,position_estimate,resistance_estimate,held` and one row per
        sample (s, m, ohm, 1 where held), each number in the shortest form that reads back to the same float."""
        with open(path, 'w', encoding='ascii', newline='') as f:
            f.write('t,position_estimate,resistance_estimate,held\n')
            for row in zip(np.asarray(time, dtype=float).tolist(), self.position.tolist(), self.resistance.tolist(),
                           self.held.astype(int).tolist(), strict=True):
                f.write(','.join(map(repr, row)) + '\n')


def observer_model(fit: SolenoidResult | Mapping) -> tuple[SolenoidParameters, float]:
    """(SolenoidParameters, the current's noise in A) of an identification: a SolenoidResult or its JSON
    (`emla identify --actuator solenoid --json`); the noise is the electrical fit's RMS residual over R.

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
                     smooth: bool = True) -> PositionEstimate:
    """Estimate the armature's position at every sample from the coil's voltage and current alone.

    Parameters
    ----------
    params : SolenoidParameters
        The identified solenoid (R at the record's start, L0, a, g0 and the end stops are used).
    sample_period : float
        Ts (s).
    voltage, current : array_like
        The voltage held over each sample interval (V) and the current sampled at its start (A).
    current_noise : float
        The current's noise standard deviation (A), > 0: the stop measurement's noise and the inversion's gate.
    tolerance : float, optional
        The largest position noise an inverted sample may take, as a fraction of the stroke.
    drift : float, optional
        The random walk of R's rate (relative, after 1 s): how fast R is let follow a warming coil.
    smooth : bool, optional
        Smooth the flux and R back over the record (offline: each free flight between stops then sees the rest
        at its end); False for the causal filter alone (online).

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
    return _observe(params, sample_period, u, i, current_noise, tolerance * (params.stroke_max - params.stroke_min),
                    drift, smooth)


def _observe(p, ts, u, i, noise, tolerance, drift, smooth):
    """The filter over the record, then (`smooth`) the smoother back over it and the positions from its flux."""
    state, cov, predicted, resting, x, held = _filter(PositionObserver(p, ts, current_noise=noise, drift=drift,
                                                                       tolerance=tolerance), u, i)
    if smooth:
        state, cov = _smoothed(state, cov, predicted)
        last, velocity = p.stroke_min, 0.0
        for k in range(u.size):
            stop = resting[k] if resting[k] >= 0 else None
            raw = _inverted(p, state[k, 0], i[k])
            x[k], velocity, held[k] = _place(p, raw, cov[k, 0, 0], i[k], stop, last, velocity, ts, noise, tolerance)
            last = x[k]
    return PositionEstimate(position=x, flux_linkage=state[:, 0].copy(), resistance=state[:, 1].copy(), held=held)


def _filter(observer, u, i):
    """The observer over the record: (filtered states (n, 3), their covariances (n, 3, 3), (predicted states,
    their covariances, transitions) for the smoother, the stop each sample rests on (-1: none), positions, held
    flags)."""
    n = u.size
    states, covs = np.empty((n, 3)), np.empty((n, 3, 3))
    predicted = (np.empty((n, 3)), np.empty((n, 3, 3)), np.empty((n, 3, 3)))
    resting, x, held = np.full(n, -1), np.empty(n), np.zeros(n, bool)
    for k in range(n):
        predicted[0][k], predicted[1][k], predicted[2][k], stop, x[k], held[k] = observer.step(u[k], i[k])
        states[k], covs[k] = observer.state, observer.cov
        resting[k] = -1 if stop is None else stop
    return states, covs, predicted, resting, x, held


class PositionObserver(ResistanceEstimate):
    """The causal observer, sample by sample (online: the identifier node with `position_observer`): the Kalman
    filter on (psi, R, dR/dt) with the stops as measurements of the module doc, from rest on the open stop.

    Parameters
    ----------
    params : SolenoidParameters
        The identified solenoid (R at the start, L0, a, g0, the mechanics and the end stops).
    sample_period : float
        Ts (s), > 0.
    current_noise : float
        The current's noise standard deviation (A), > 0.
    tolerance : float, optional
        The largest position noise an inverted sample may take (m; default TOLERANCE of the stroke).
    drift : float, optional
        The random walk of R's rate (relative, after 1 s).

    Examples
    --------
    >>> observer = PositionObserver(params, 2e-4, current_noise=0.005)      # doctest: +SKIP
    >>> position, held = observer.update(voltage, current)                 # doctest: +SKIP
    >>> observer.resistance                                                 # doctest: +SKIP
    """

    def __init__(self, params: SolenoidParameters, sample_period: float, *, current_noise: float,
                 tolerance: float | None = None, drift: float = DRIFT) -> None:
        if not (sample_period > 0 and current_noise > 0):
            raise InputError(f'the observer needs a positive sample period and current noise, got '
                             f'{sample_period!r} and {current_noise!r}')
        stroke = params.stroke_max - params.stroke_min
        self.params, self.sample_period, self.current_noise = params, float(sample_period), float(current_noise)
        self.tolerance = TOLERANCE * stroke if tolerance is None else tolerance
        self.margin = MARGIN * stroke
        self.drift = drift
        self.state = self.cov = None   # (psi, R, dR/dt) and its covariance, from the first sample on
        self.samples = 0
        self._previous = None   # (u_k-1, u_k-2, I_k-1) of the last sample
        self.last, self.velocity, self.resting_on = params.stroke_min, 0.0, 0   # at rest on the open stop

    def gap(self) -> None:
        """Samples were lost (the identifier node's call): no flux is integrated over the gap; the next sample
        takes it from the last position, with the whole stroke's uncertainty, until a stop anchors it again (R
        and its rate are kept)."""
        self._previous, self.velocity, self.resting_on = None, 0.0, None

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
        """One sample: (the predicted state, its covariance, the transition, the stop it rests on or None, the
        position, held)."""
        p, ts, noise = self.params, self.sample_period, self.current_noise
        low, high = p.stroke_min, p.stroke_max
        f = np.eye(3)
        if self.state is None:   # the first sample: at rest on the open stop
            self.state = np.array([p.inductance(low) * current, p.resistance, 0.0])
            self.cov = np.diag([(p.inductance(low) * noise) ** 2, (START * p.resistance) ** 2,
                                (self.drift * p.resistance) ** 2])
        elif self._previous is None:   # after a gap: the flux afresh, its uncertainty the whole stroke's
            self.state = np.array([p.inductance(self.last) * current, self.state[1], self.state[2]])
            self.cov[0, :] = self.cov[:, 0] = 0.0
            self.cov[0, 0] = ((p.inductance(high) - p.inductance(low)) * current) ** 2 \
                + (p.inductance(low) * noise) ** 2
        else:   # the flux over the held interval: the trapezoid of I, corrected for the jump of dI/dt at t_k-1
            u1, u2, i1 = self._previous
            q = 0.5 * ts * (i1 + current) + ts * ts / 12 * (u1 - u2) / p.inductance(self.last)
            state, cov = self.state, self.cov
            self.state = np.array([state[0] + u1 * ts - state[1] * q, state[1] + state[2] * ts, state[2]])
            f = np.array([[1.0, -q, 0.0], [0.0, 1.0, ts], [0.0, 0.0, 1.0]])
            self.cov = f @ cov @ f.T + np.diag([(self.state[1] * noise * ts) ** 2 / 2, 0.0,
                                                 (self.drift * p.resistance) ** 2 * ts])
        ahead, ahead_cov = self.state, self.cov
        raw = _inverted(p, self.state[0], current)
        stop = _pressed(p, raw, current, self.margin, noise, self.resting_on)
        if stop is not None:   # on a stop psi = L(stop) I, measured with the current's noise
            inductance = p.inductance((low, high)[stop])
            gain = self.cov[:, 0] / (self.cov[0, 0] + (inductance * noise) ** 2)
            self.state = self.state + gain * (inductance * current - self.state[0])
            self.cov = self.cov - np.outer(gain, self.cov[0])
        position, self.velocity, held = _place(p, raw, self.cov[0, 0], current, stop, self.last, self.velocity, ts,
                                               noise, self.tolerance)
        self.last = position
        self.resting_on = stop if stop is not None else 0 if position <= low else 1 if position >= high else None
        self._previous = (voltage, self._previous[0] if self._previous else voltage, current)
        self.samples += 1
        return ahead, ahead_cov, f, stop, position, held

    @property
    def resistance(self) -> float:
        """R as tracked now (ohm; the identified one before the first sample)."""
        return float(self.params.resistance if self.state is None else self.state[1])

    @property
    def std(self) -> float:
        """Its one-sigma (ohm)."""
        return float(START * self.params.resistance if self.cov is None else math.sqrt(max(self.cov[1, 1], 0.0)))


def _smoothed(state, cov, predicted):
    """The Rauch-Tung-Striebel smoother's states and covariances from the filter's."""
    ahead, ahead_cov, transition = predicted
    state, cov = state.copy(), cov.copy()
    for k in range(len(state) - 2, -1, -1):
        gain = cov[k] @ transition[k + 1].T @ np.linalg.inv(ahead_cov[k + 1])
        state[k] = state[k] + gain @ (state[k + 1] - ahead[k + 1])
        cov[k] = cov[k] + gain @ (cov[k + 1] - ahead_cov[k + 1]) @ gain.T
    return state, cov


def _place(p, raw, flux_variance, current, stop, last, velocity, ts, noise, tolerance):
    """(position, velocity, held) at one sample: the stop it rests on; else the inverted position `raw` within the
    stroke, unless the current and the flux's variance leave it noisier than `tolerance` (m) at the open stop (where
    L(x) is flattest) or there is no current: then the identified mechanics carried on from the last position and
    velocity (held)."""
    if stop is not None:
        return (p.stroke_min, p.stroke_max)[stop], 0.0, False
    if raw is None or _spread(p, p.stroke_min, current, noise, flux_variance) > tolerance:
        return *_coast(p, last, velocity, current, ts), True
    position = min(max(raw, p.stroke_min), p.stroke_max)
    if all(p.coil_force(x, current) < p.load(x) for x in (p.stroke_min, p.stroke_max)):
        position = min(position, last)   # the spring wins all along the stroke (the net force is convex in x)
    return position, (position - last) / ts, False


def _inverted(p, psi, current):
    """x from psi = L(x) I (-inf for psi / I <= L0, beyond any gap), None for no current."""
    if current == 0.0:
        return None
    excess = psi / current - p.leakage_inductance
    return p.gap - p.gap_coefficient / excess if excess > 0 else -math.inf


def _pressed(p, raw, current, margin, noise, resting):
    """The stop (0 open, 1 closed) the armature rests on, or None: the static force balance pressing it on (the
    spring at the open stop, the coil at the closed) and the inverted position `raw` beyond it or within what
    the current's noise may make of it there (three standard deviations); for a stop it did not rest on at the
    last sample (`resting`), within `margin` too (an armature in flight at a small current is not put on a stop
    before it comes near)."""
    if raw is None:
        return None
    for index, stop, side in ((0, p.stroke_min, 1.0), (1, p.stroke_max, -1.0)):
        near = 3.0 * _spread(p, stop, current, noise)
        if side * (p.coil_force(stop, current) - p.load(stop)) <= 0.0 and \
                side * (raw - stop) <= (near if index == resting else min(near, margin)):
            return index
    return None


def _spread(p, x, current, noise, flux_variance=0.0):
    """The position's standard deviation at x from the current's noise and the flux linkage's variance: through
    x = g0 - a / (psi / I - L0), (g0 - x)^2 / (a |I|) sqrt((L(x) noise)^2 + flux_variance)."""
    return (p.gap - x) ** 2 * math.sqrt((p.inductance(x) * noise) ** 2 + flux_variance) / (p.gap_coefficient
                                                                                           * abs(current))



def _coast(p, x, v, current, ts):
    """(x, v) after Ts of the identified mechanics m dv/dt = I^2 L'(x) / 2 - B v - F0 - k x at the current I, from
    (x, v), in COAST semi-implicit Euler steps, the stops inelastic."""
    h = ts / COAST
    for _ in range(COAST):
        v += h * (p.coil_force(x, current) - p.damping * v - p.load(x)) / p.mass
        x += h * v
        if not p.stroke_min < x < p.stroke_max:
            x, v = min(max(x, p.stroke_min), p.stroke_max), 0.0
    return x, v
