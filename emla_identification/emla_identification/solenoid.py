"""Offline identification of a solenoid (docs/physics.md §9.1): R, L0, a, g0 and m, B, k, F0 from the coil's
voltage, current and position, fitted to both of its equations together, each with a one-sigma, and the fit check
of each equation.

Electrical, output error. Along a path x(t) of the armature between the samples and with the held voltage, the
flux linkage obeys dpsi/dt = u - R psi / L(x) exactly; integrated over each sample interval (RK4 in sub-steps of
at most SUBSTEP, from psi = L(x_0) I_0) it predicts the current I_k = psi_k / L(x_k). The current's noise is then
the output's noise alone (also where a current loop feeds it back into the voltage), and what happens between the
samples is integrated, not approximated: no discretisation or errors-in-variables bias at any L/R against the
sample period. The start comes from the flux-form equation
    psi_k - psi_k-1 = u_k-1 Ts - R (trapezoid of I),   psi = L0 I + a I / (g0 - x)
over a grid of g0 (linear in R, L0, a for a fixed g0), by instrumental variables (`_start`).

The path between the samples matters at 1 kHz, where the armature crosses its stroke in four samples and stops
dead: the first pass takes a cubic spline through each run of samples off the stops (`_spline_nodes`), the later
passes the path the identified model gives between each pair of measured positions (`_paths`: the solenoid's own
equations with its end stops, started at the velocity that reaches the next measured position), PASSES passes in
all; each fits only the samples whose predicted current its path's possible error spoils by less than RELIABLE
of the current's noise (`_reliable`; that noise from the current's residual where the armature stands still).

Mechanical, equation error on the rows over which the armature keeps off the stops (`free_rows`). The second
difference of position at a stride of W samples is the triangle-weighted mean of the acceleration over
[t_k-W, t_k+W] (exactly), so with the same weighting of every force:
    (x_k+W - 2 x_k + x_k-W) / (W Ts)^2 = (F_k - B v_k - k xbar_k - F0) / m
F_k: the weighted mean of I^2 L'(x) / 2 along the path, from the electrical model's current between the samples
(Simpson's rule on the sub-steps; it carries no current noise), v_k and xbar_k the weighted mean velocity and
position along the path. The noisy second difference is the regression's output. W is the one of STRIDES whose
fit gives m, B, k the least variance (`_stride`): 1 for an armature that slams between its stops, longer for one
held slowly between them at a high rate, whose second difference the position's quantisation swamps.

Together. An armature held between its stops shows the current L(x) over a short span of gaps only, which does not
separate L0, a and g0 (the information matrix of the current alone is singular); the force balance holds the
force's shape in x, a psi^2 / (2 (L0 (g0 - x) + a)^2), and so separates them. So both equations are fitted at
once (`_electrical` with a `_Balance`: the force balance's coefficients the least-squares ones at each electrical
vector), each residual weighted by the inverse of its noise (`_weights`), from the best of a few g0 at the same
L(x) (`_gap_start`). The position's noise enters the force balance's regressors too, through the path; its bias
is taken off by one Gauss-Newton step (`_Joint.corrected`).

Uncertainties: a sandwich over both equations (`_Joint.covariance`): the current's residual over ELECTRICAL_LAGS
samples, white position noise through the force balance's rows (`_NoiseMap`: the second difference, the mean
velocity and position, and the force through its stiffness, at once and through the coil's lag), its level the
fit check's, raised to what the low band holds where a quantisation error that is not white gathers there. A
direction the data do not see leaves the parameters in it an infinite one-sigma: unresolved.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import CubicSpline
from scipy.optimize import least_squares, minimize_scalar

from emla_core.data import as_recording
from emla_core.errors import InputError
from emla_core.physics.solenoid import (
    KERNEL_SLOTS,
    SOLENOID_EFFECTS,
    SOLENOID_PARAMETER_NAMES,
    SolenoidParameters,
    circuit_current,
    coil_current,
    flux,
    inductance,
    inductance_slope,
    solenoid_step,
)
from emla_core.recording import Recording

from .fit_check import equation_fit
from .greybox import UNRESOLVED
from .noise_floor import low_band, noise_variances

ELECTRICAL = SOLENOID_PARAMETER_NAMES[:4]   # resistance, leakage_inductance, gap_coefficient, gap
# The electrical vector the fit works on: those, then the effects in the flux linkage (zero unless fitted).
ELECTRICAL_FIELDS = ELECTRICAL + ('saturation_coefficient', 'remanence_current', 'eddy_conductance')
MECHANICAL = SOLENOID_PARAMETER_NAMES[4:]   # mass, damping, spring_stiffness, spring_preload
SUBSTEP = 2e-5        # s: the longest RK4 sub-step of the flux linkage (an even number of them per sample)
SETTLE = 10           # coil time constants at the start of the record left out of the current's fit
ELECTRICAL_LAGS = 2   # samples of autocorrelation the current residual's sandwich estimator takes in
REALISATIONS = 8      # of white position noise, for the force balance's noise floor
MIN_FREE_ROWS = 50    # force-balance rows with the armature free, below which the mechanics are not identified
GAP_GRID = 40         # values of g0 (geometric, from just above the stroke to 20 strokes) for the start
STOP_STEPS = 3        # position steps (the quantisation) within which the armature's path counts as on a stop
STOP_SHARE = 0.01     # of the stroke: the least clearance from a stop of a force-balance row's path
RELIABLE = 0.1        # of the current's noise: the largest error a sample's predicted current may take from the path
RELIABLE_SHARE = 0.25  # of the samples: the least share whose predicted current is fitted (the most reliable)
HINT_SAMPLES = 10000  # samples a moving coil's misfit record is tried as a solenoid on (a second at 10 kHz: ~2 s)
PASSES = 3            # electrical and mechanical fits in turn (the first on a spline path between the samples)
GAP_STARTS = np.geomspace(0.1, 5.0, 8)   # strokes above the greatest position: g0 of the joint fit's starts
SINGULAR = 1e-12      # of the largest eigenvalue of the scaled information matrix: a direction the data do not see
_SATURATION, _REMANENCE = (KERNEL_SLOTS.index(name) for name in ELECTRICAL_FIELDS[4:6])
STRIDES = (1, 2, 4, 8, 16, 32)   # samples: the force balance's second differences tried (_stride)
STRIDE_ROWS = 0.3     # of the first stride's force-balance rows: the least share a longer stride keeps
# The cubic through x_j-1 .. x_j+2 over [t_j, t_j+1] (s from 0 to 1): its mean, and its mean of s times it
CUBIC_MEAN = np.array([-1.0, 13.0, 13.0, -1.0]) / 24.0
CUBIC_MOMENT = np.array([-7.0 / 3.0, 22.0, 43.0, -8.0 / 3.0]) / 120.0
FRICTION_SPEEDS = np.concatenate(([0.0], np.geomspace(1e-3, 0.3, 12)))   # v_s tried, times the path's peak speed


@dataclass
class SolenoidResult:
    """The identified solenoid: `parameters` and `std` ({name: value}, SI), `covariance` (their order), `samples`,
    `sample_period`, `fit` ({equation: fit_check.EquationFit}), `free_rows` (force-balance rows used) and `stroke`
    (the record's least and greatest positions, taken as the end stops, m)."""

    parameters: dict
    std: dict
    covariance: np.ndarray
    samples: int
    sample_period: float
    free_rows: int
    stroke: tuple
    fit: dict = field(repr=False, default_factory=dict)
    model: str = 'solenoid'
    settings: dict = field(default_factory=dict)   # fixed per fit: the friction's v_s (m/s) when it has one

    def unresolved(self) -> list:
        """The parameters whose one-sigma exceeds UNRESOLVED of their value."""
        return [name for name, value in self.parameters.items()
                if name != 'spring_preload' and not self.std[name] < UNRESOLVED * abs(value)]

    def warnings(self) -> list:
        """One line for each equation that does not fit and for each unresolved parameter."""
        lines = [line for line in (f.warning() for f in self.fit.values()) if line]
        lines += [f'the data do not resolve the {name}: {self.parameters[name]:.4g} +- {self.std[name]:.2g}'
                  for name in self.unresolved()]
        return lines

    def to_dict(self) -> dict:
        """The `emla identify --actuator solenoid` JSON object."""
        return {'model': self.model, 'samples': self.samples, 'sample_period': self.sample_period,
                'parameters': dict(self.parameters), 'std': dict(self.std), 'settings': dict(self.settings),
                'free_rows': self.free_rows,
                'stroke': {'stroke_min': self.stroke[0], 'stroke_max': self.stroke[1]},
                'fit': {name: f.to_dict() for name, f in self.fit.items()}, 'unresolved': self.unresolved()}

    def solenoid(self) -> SolenoidParameters:
        """The identified solenoid as SolenoidParameters (with the effects fitted), its end stops the record's
        (`stroke`)."""
        return self.model_file().solenoid()

    def model_file(self, data: str = '', command: str = ''):
        """The identified solenoid as a model file's Model (emla_core.model_file; `actuator: solenoid`): the
        parameters with their one-sigmas, the end stops the record's, and the effects fitted (SOLENOID_EFFECTS:
        a friction, the iron's saturation) with theirs."""
        from emla_core.model_file import Model, ModelEffect, provenance
        parameters = {name: (self.parameters[name], self.std[name]) for name in SOLENOID_PARAMETER_NAMES}
        parameters.update(stroke_min=(self.stroke[0], None), stroke_max=(self.stroke[1], None))
        effects = [ModelEffect(effect, effect, {name: (max(self.parameters[name], 0.0), self.std[name])
                                                for name in names},
                               {name: self.settings[name] for name in settings if name in self.settings})
                   for effect, (names, settings) in SOLENOID_EFFECTS.items()
                   if all(name in self.parameters for name in names)]
        return Model(self.sample_period, parameters, effects, provenance(data, command) if data else {},
                     actuator='solenoid')


def identify_solenoid(data: Recording | Path | str | None = None, *, sample_period: float | None = None,
                      voltage: ArrayLike | None = None, current: ArrayLike | None = None,
                      position: ArrayLike | None = None, friction: bool = False, saturation: bool = False,
                      remanence: bool = False, eddy: bool = False) -> SolenoidResult:
    """Identify a solenoid's R, L0, a, g0, m, B, k, F0 from a whole record of its voltage, current and position.

    Parameters
    ----------
    data : Recording, str or Path, optional
        The record, or a CSV file or bag to load; leave it out to pass the arrays.
    sample_period : float, optional
        Ts in s of the arrays.
    voltage, current, position : array_like, optional
        The coil voltage held over each sample interval (V), the current (A) and the armature position (m, +x
        closes the gap) at the interval's start.
    friction : bool, optional
        Add a friction of the armature to the force balance, Fc tanh(v / v_s) (`coulomb_force` Fc in N after F0,
        and `friction_speed` v_s in m/s among the settings: 0 is the dry Fc sign(v)), v along the armature's path
        between the samples and triangle-weighted like the other forces, v_s the best of FRICTION_SPEEDS times the
        path's peak speed (the solenoid discrepancy's candidate, solenoid_discrepancy.py).
    saturation : bool, optional
        Add the iron's saturation to the flux linkage, I = psi / L(x) + c psi^3 (`saturation_coefficient` c in
        A/Wb^3, >= 0, after g0; the force then M^2 L'(x) / 2 with M = psi / L(x)): the solenoid discrepancy's
        electrical candidate.
    remanence : bool, optional
        Add the iron's residual magnetism, I = psi / L(x) (+ c psi^3) - I_r (`remanence_current` I_r in A, >= 0;
        it enters the back-EMF and the force through M = psi / L(x) = I + I_r without saturation).
    eddy : bool, optional
        Add the iron's eddy currents, I = psi / L(x) (+ c psi^3 - I_r) + G dpsi/dt (`eddy_conductance` G in S,
        >= 0; the current sampled just before the voltage steps, so with the voltage of the interval ending there).

    Returns
    -------
    SolenoidResult
        Parameters and one-sigmas in SI units (ohm, H, H m, m, kg, N s/m, N/m, N), the fit of each equation.

    Raises
    ------
    InputError
        Missing or non-finite signals, a record too short or a motion that never leaves the stops, or data the
        model gives no estimate for; the message names the source.

    Examples
    --------
    >>> from emla_sim.solenoid import record
    >>> recording, _ = record(duration=1.0, sample_period=5e-4)
    >>> result = identify_solenoid(recording)
    >>> round(result.parameters['resistance'], 1), round(result.parameters['spring_stiffness'], -2)
    (6.0, 3000.0)
    """
    recording = as_recording(data, sample_period=sample_period, voltage=voltage, current=current, position=position)
    source = recording.source or 'recording'
    recording.require('voltage', 'current', 'position')
    u, i, x = (np.asarray(recording.signals[name], dtype=float) for name in ('voltage', 'current', 'position'))
    for name, values in (('voltage', u), ('current', i), ('position', x)):
        bad = ~np.isfinite(values)
        if bad.any():
            raise InputError(f'{source}: non-finite {name} at sample {int(np.argmax(bad))}')
    ts = recording.sample_period
    if len(u) < 4 * MIN_FREE_ROWS:
        raise InputError(f'{source}: {len(u)} samples are too few for the solenoid model')
    if not np.ptp(x) > 0:
        raise InputError(f'{source}: the position never changes: the solenoid\'s inductance curve and mechanics '
                         f'need the armature to move')
    try:
        with np.errstate(all='ignore'):   # a fit far off overflows on the way: its outcome is judged, not warned of
            return _identify(u, i, x, ts, source, friction, saturation, remanence, eddy)
    except (ValueError, ArithmeticError) as exc:   # (numpy's LinAlgError is a ValueError) data the model cannot take
        raise InputError(f'{source}: the solenoid model cannot be fitted to these data ({exc})') from None


def solenoid_hint(recording: Recording) -> str | None:
    """For a record the moving coil does not fit: a warning line that the solenoid model fits it (both of its
    equations within their noise floors, on its first HINT_SAMPLES samples) and how to ask for it; None when it
    does not (or cannot be fitted)."""
    first = {name: np.asarray(values)[:HINT_SAMPLES] for name, values in recording.signals.items()
             if name in ('voltage', 'current', 'position')}
    try:
        with np.errstate(all='ignore'):
            result = identify_solenoid(sample_period=recording.sample_period, voltage=first.get('voltage'),
                                       current=first.get('current'), position=first.get('position'))
    except (InputError, ValueError, ArithmeticError):   # (numpy's LinAlgError is a ValueError) no solenoid either
        return None
    if result.warnings():
        return None
    p = result.parameters
    return (f'a solenoid fits these data (voltage and force balance within their noise floors; L = '
            f'{1e3 * p["leakage_inductance"]:.3g} mH + {1e6 * p["gap_coefficient"]:.3g} uH m / '
            f'({1e3 * p["gap"]:.3g} mm - x), force I^2 L\'(x)/2): identify it with --actuator solenoid')


def _identify(u, i, x, ts, source, friction=False, saturation=False, remanence=False, eddy=False):
    substeps = 2 * max(1, math.ceil(ts / SUBSTEP / 2))
    stopped = on_stop(x)
    # ELECTRICAL_FIELDS, the effects from zero
    electrical = _start(u, i, x, ts, source, _spline_nodes(x, stopped, substeps), substeps)
    free = np.array([True] * 4 + [saturation, remanence, eddy])      # which of them are fitted
    mechanical, speed = None, None   # the first pass: the armature's path a spline through the samples
    for _ in range(PASSES):
        nodes, error = _nodes(u, i, x, stopped, electrical, mechanical, speed, ts, substeps)
        keep = np.ones(len(u), bool)
        settled = _settling(electrical, x, ts, len(u))
        keep[:settled] = False
        if mechanical is None:   # the current's equation alone, on every sample: the start and the current's noise
            electrical = _electrical(u, i, nodes, electrical, free, ts, substeps, keep, x, source)
        noise = _current_noise(i - _simulated(u, i, nodes, electrical, ts, substeps)[0], x, keep)
        keep &= _reliable(i, x, error, electrical, ts, noise)
        if mechanical is None:
            electrical = _electrical(u, i, nodes, electrical, free, ts, substeps, keep, x, source)
        rows = free_rows(x, stopped, nodes, first=settled)
        if rows.size < MIN_FREE_ROWS:
            raise InputError(f'{source}: the armature is free on {rows.size} force-balance rows only (at least '
                             f'{MIN_FREE_ROWS} needed): the mechanics need it to move between its stops')
        balance = _stride(u, i, x, stopped, nodes, electrical, ts, substeps, keep, settled)
        speeds = FRICTION_SPEEDS * np.max(np.abs(np.diff(nodes, axis=1))) * 2 * substeps / ts if friction else ()
        magnetizing = _simulated(u, i, nodes, electrical, ts, substeps)[1]
        theta, speed, residual = _mechanics(balance, magnetizing, electrical, speeds)
        balance.friction = None if speed is None else balance.friction_column(speed)
        weights = _weights(i, x, ts, noise, balance, theta, residual, magnetizing, electrical)
        if mechanical is None:
            electrical = _gap_start(u, i, x, nodes, electrical, ts, substeps, keep, balance, weights)
        electrical = _electrical(u, i, nodes, electrical, free, ts, substeps, keep, x, source, balance, weights)
        magnetizing = _simulated(u, i, nodes, electrical, ts, substeps)[1]
        theta, speed, residual = _mechanics(balance, magnetizing, electrical, speeds)
        balance.friction = None if speed is None else balance.friction_column(speed)
        mechanical = _mechanical_values(theta)
    names = (tuple(str(name) for name in np.array(ELECTRICAL_FIELDS)[free]) + MECHANICAL
             + (('coulomb_force',) if friction else ()))
    joint = _Joint(u, i, x, nodes, electrical, free, theta, balance, speed, ts, substeps, keep, weights ** 2)
    fit, noise, white = joint.fit()
    covariance = joint.covariance(noise)
    if np.isfinite(white):   # the least-squares point's fit check and uncertainty, its bias taken off
        electrical, theta = joint.corrected(white)
    mechanical = _mechanical_values(theta)
    values = np.concatenate((electrical[free], mechanical))
    if not np.all(np.isfinite(values)) or np.isnan(covariance).any() or not np.all(np.diag(covariance) >= 0):
        raise InputError(f'{source}: the solenoid model gives no finite estimate from these data')
    std = np.sqrt(np.diag(covariance))
    return SolenoidResult(parameters=dict(zip(names, map(float, values))),
                          std=dict(zip(names, map(float, std))), covariance=covariance,
                          samples=len(u), sample_period=ts, free_rows=int(balance.rows.size),
                          stroke=(float(x.min()), float(x.max())), fit=fit,
                          settings={} if speed is None else {'friction_speed': float(speed)})


def _rms(values):
    return float(np.sqrt(np.mean(values * values)))


def _scales(u, i, x, start):
    """The ELECTRICAL_FIELDS' scales: the start's magnitudes; the effects by the largest current: c by it over the
    cube of the largest flux linkage without them (c psi^3 a share of I), I_r by it, G by it over the largest
    voltage."""
    peak = np.max(np.abs(i))
    scale = np.abs(start)
    scale[4:] = np.maximum(scale[4:], (peak / np.max(np.abs(inductance(x, *start[1:4]) * i)) ** 3, peak,
                                       peak / max(np.max(np.abs(u)), 1e-12)))
    return scale


def _weights(i, x, ts, noise, balance, theta, residual, magnetizing, electrical):
    """The joint fit's weights: the inverse of the noise each equation's residual would hold, the current's
    `noise` (at least 1e-6 of its RMS) and the position noise the force balance's high band holds (fit_check's
    level) through its rows' stencils (at least 1e-6 of its output's RMS), so that an estimate far off, whose
    misfit swamps one equation, does not weigh that equation down."""
    noise_map = _NoiseMap(theta, balance, ts, balance.stiffness(magnetizing, electrical), electrical, x)
    unit = noise_map.through(_white(x.size))
    level = noise_variances({'mechanical': (residual, {'position': unit})}, ts)['position']
    mechanical = max(np.sqrt(level * np.mean(unit ** 2)), 1e-6 * _rms(balance.acceleration))
    return np.array([1.0 / max(noise, 1e-6 * _rms(i)), 1.0 / mechanical])


def _gap_start(u, i, x, nodes, electrical, ts, substeps, keep, balance, weights):
    """The joint fit's start: of the electrical vector and the same L(x) at the record's least and greatest
    positions with g0 at GAP_STARTS strokes above the greatest, the one whose joint residual (_joint_residual) is
    least. The current alone may leave g0 anywhere along a valley (an armature held between its stops), where the
    force balance's residual has more than one minimum."""
    low, high = x.min(), x.max()
    l_low, l_high = (inductance(position, *electrical[1:4]) for position in (low, high))
    best, cost = electrical, _cost(_joint_residual(u, i, nodes, electrical, ts, substeps, keep, balance, weights))
    for g0 in high + (high - low) * GAP_STARTS:
        a = (l_high - l_low) / (1.0 / (g0 - high) - 1.0 / (g0 - low))
        candidate = electrical.copy()
        candidate[1:4] = l_low - a / (g0 - low), a, g0
        if a > 0 and candidate[1] >= 0:
            trial = _cost(_joint_residual(u, i, nodes, candidate, ts, substeps, keep, balance, weights))
            if trial < cost:
                best, cost = candidate, trial
    return best


def _cost(residual):
    return float(residual @ residual) if np.all(np.isfinite(residual)) else np.inf


def _joint_residual(u, i, nodes, values, ts, substeps, keep, balance=None, weights=(1.0, 1.0)):
    """The current's residual at the samples `keep` of the electrical vector `values`, the armature moved along
    `nodes`; with `balance`, the force balance's residual after it at its least-squares coefficients, each times
    its weight."""
    current, magnetizing = _simulated(u, i, nodes, values, ts, substeps)
    misfit = (i - current)[keep]
    if balance is None:
        return misfit
    phi = balance.regressors(magnetizing, values)
    theta = np.linalg.lstsq(phi, balance.acceleration, rcond=None)[0]
    return np.concatenate((weights[0] * misfit, weights[1] * (balance.acceleration - phi @ theta)))


def _electrical(u, i, nodes, start, free, ts, substeps, keep, x, source, balance=None, weights=(1.0, 1.0)):
    """The ELECTRICAL_FIELDS vector with the `free` ones fitted from `start`, the armature moved along `nodes`: the
    output-error fit of the current at the samples `keep`; with `balance` (_Balance) the force balance's equation
    error joins it, its mechanical parameters the least-squares ones at each electrical vector (variable
    projection), the two residuals times `weights` (each equation's inverse spread). The current alone sees L(x)
    only over the gaps the armature visits: held between its stops it cannot tell L0, a and g0 apart, while the
    force balance holds the force's shape a I^2 / (2 (g0 - x)^2) and so g0."""
    scales = _scales(u, i, x, start)
    scale = scales[free]
    low = np.array([1e-6 * scales[0], 0.0, 1e-6 * scales[2], (x.max() - x.min()) * 1e-3 + x.max(), 0.0, 0.0,
                    0.0])[free] / scale

    def full(q):
        values = start.copy()
        values[free] = q * scale
        return values

    def residual(q):
        return _joint_residual(u, i, nodes, full(q), ts, substeps, keep, balance, weights)
    try:
        solution = least_squares(residual, np.maximum(start[free] / scale, low), bounds=(low, np.inf),
                                 x_scale='jac', xtol=1e-12, ftol=1e-12)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise InputError(f'{source}: the solenoid model cannot be fitted to these data ({exc})') from None
    return full(solution.x)


def _settling(electrical, x, ts, n):
    """Samples at the start that remember the initial flux linkage: SETTLE coil time constants (at most n / 4)."""
    r, l0, a, g0 = electrical[:4]
    return min(n // 4, int(SETTLE * (l0 + a / (g0 - x.min())) * (1 + r * electrical[6]) / r / ts))


def _spline_error(x, stopped):
    """The spline path's possible error per interval (m): 5/384 of the fourth difference of position about it;
    on an interval in which the armature meets or leaves a stop, the whole step."""
    quartic = np.abs(np.diff(x, 4))
    spline = np.zeros(len(x) - 1)
    spline[1:1 + quartic.size] = quartic
    spline[2:2 + quartic.size] = np.maximum(spline[2:2 + quartic.size], quartic)
    error = 5.0 / 384.0 * spline
    meets = stopped[:-1] != stopped[1:]
    error[meets] = np.abs(np.diff(x))[meets]
    return error


def _current_noise(residual, x, keep):
    """The current's noise (A): the robust spread (1.4826 times the median absolute value) of the current's
    output-error residual at the samples `keep` where the armature stands still (its position the same as at both
    neighbours: on a stop or held anywhere, so that no path between the samples spoils the prediction), or at all
    those samples when fewer than MIN_FREE_ROWS stand still (a record in motion throughout)."""
    still = keep.copy()
    still[1:-1] &= (x[1:-1] == x[:-2]) & (x[1:-1] == x[2:])
    still[[0, -1]] = False
    chosen = still if still.sum() >= MIN_FREE_ROWS else keep
    return 1.4826 * float(np.median(np.abs(residual[chosen]))) if chosen.any() else 0.0


def _reliable(i, x, error, electrical, ts, noise):
    """The samples whose predicted current the path's possible error per interval (`error`, m) does not spoil:
    the current error it would cause, R I L'(x) dx Ts / L(x)^2, carried forward with the coil's decay
    exp(-R Ts / (L(x) (1 + R G))), below RELIABLE of the current's `noise` (at least 1e-6 of the current's RMS); or,
    where fewer pass (a current without noise, an armature never at rest), the RELIABLE_SHARE of the samples with
    the least."""
    r, l0, a, g0 = electrical[:4]
    inductances = inductance(x[:-1], l0, a, g0)
    kick = r * np.abs(i[:-1]) * inductance_slope(x[:-1], a, g0) * error * ts / inductances ** 2
    carried = _carried(kick, np.exp(-r * ts / (inductances * (1.0 + r * electrical[6]))))
    bound = max(RELIABLE * max(noise, 1e-6 * np.sqrt(np.mean(i * i))), np.quantile(carried, RELIABLE_SHARE))
    return np.concatenate(([False], carried <= bound))


@numba.njit(cache=True)
def _carried(kick, decay):
    """y_k = decay_k-1 y_k-1 + kick_k-1 (y_0 = 0), returned for k = 1 .. n: a first-order filter whose pole
    varies from sample to sample."""
    out = np.empty(kick.size)
    y = 0.0
    for k in range(kick.size):
        y = decay[k] * y + kick[k]
        out[k] = y
    return out


def on_stop(x):
    """Which samples lie on an end stop: within half a position step (the smallest change in the record) of the
    least or the greatest position."""
    steps = np.diff(np.unique(x))
    tolerance = 0.5 * steps.min() if steps.size else 0.0
    return (x <= x.min() + tolerance) | (x >= x.max() - tolerance)


def _spline_nodes(x, stopped, substeps):
    """Positions at the half sub-steps of each interval, (n - 1, 2 substeps + 1), for the first pass: a cubic
    spline through each run of samples off the stops, extended over the intervals in which the run meets a stop
    and kept within the stroke (a spline through the kink at a stop would overshoot and ring); linear between
    samples on stops."""
    n = len(x)
    fractions = np.arange(2 * substeps + 1) / (2 * substeps)
    nodes = x[:-1, None] + np.diff(x)[:, None] * fractions[None, :]
    free = np.flatnonzero(~stopped)
    for run in np.split(free, np.flatnonzero(np.diff(free) > 1) + 1) if free.size else []:
        intervals = np.arange(max(run[0] - 1, 0), min(run[-1] + 1, n - 1))
        times = intervals[:, None] + fractions[None, :]
        path = (CubicSpline(run, x[run])(times) if run.size >= 4
                else np.polyval(np.polyfit(run, x[run], run.size - 1), times))
        nodes[intervals] = np.clip(path, x.min(), x.max())
    return nodes


@numba.njit(cache=True)
def _circuit_at(psi, x, l0, a, g0, c, remanence):
    """M_c = psi / L(x) + c psi^3 - I_r: the coil's current without eddy currents."""
    return psi / inductance(x, l0, a, g0) + c * psi * psi * psi - remanence


@numba.njit(cache=True)
def _driven(u, i0, nodes, r, l0, a, g0, c, remanence, eddy, ts, substeps):
    """(The current at the samples, (n,); the magnetizing current psi / L(x) at the sub-step boundaries of each
    interval, (n - 1, substeps + 1)), the armature moved along `nodes` (positions at the half sub-steps): RK4 of
    dpsi/dt = u - R I(psi, x(t)), I = M_c + G dpsi/dt with M_c = psi / L(x) + c psi^3 - I_r, so dpsi/dt =
    (u - R M_c) / (1 + R G); the current at a sample with the voltage of the interval ending there (the first's
    with its own)."""
    n = nodes.shape[0]
    current = np.empty(n + 1)
    magnetizing = np.empty((n, substeps + 1))
    h = ts / substeps
    scale = 1.0 / (1.0 + r * eddy)
    psi = flux(circuit_current(i0, u[0], r, eddy) + remanence, inductance(nodes[0, 0], l0, a, g0), c)
    for k in range(n):
        magnetizing[k, 0] = psi / inductance(nodes[k, 0], l0, a, g0)
        circuit = magnetizing[k, 0] + c * psi * psi * psi - remanence
        current[k] = coil_current(circuit, u[max(k - 1, 0)], r, eddy)
        for s in range(substeps):
            x0, xm, x1 = nodes[k, 2 * s], nodes[k, 2 * s + 1], nodes[k, 2 * s + 2]
            k1 = (u[k] - r * _circuit_at(psi, x0, l0, a, g0, c, remanence)) * scale
            k2 = (u[k] - r * _circuit_at(psi + 0.5 * h * k1, xm, l0, a, g0, c, remanence)) * scale
            k3 = (u[k] - r * _circuit_at(psi + 0.5 * h * k2, xm, l0, a, g0, c, remanence)) * scale
            k4 = (u[k] - r * _circuit_at(psi + h * k3, x1, l0, a, g0, c, remanence)) * scale
            psi += h / 6.0 * (k1 + 2.0 * (k2 + k3) + k4)
            magnetizing[k, s + 1] = psi / inductance(x1, l0, a, g0)
    circuit = magnetizing[n - 1, substeps] + c * psi * psi * psi - remanence
    current[n] = coil_current(circuit, u[n - 1], r, eddy)
    return current, magnetizing


@numba.njit(cache=True)
def _interval(i, x, v, u, p, h, substeps, current, position):
    """Integrate one interval from (I, x, v) by `substeps` sub-steps with the stops, writing the current and
    position at the sub-step boundaries; (I, x, v) at its end."""
    current[0], position[0] = i, x
    for s in range(substeps):
        i, x, v = solenoid_step(i, x, v, u, p, h)
        current[s + 1], position[s + 1] = i, x
    return i, x, v


@numba.njit(cache=True)
def _paths(u, i0, x, stopped, p, ts, substeps):
    """The current and position at the sub-step boundaries of each interval, (n - 1, substeps + 1) each, and the
    path's possible error per interval (m): the solenoid of p (KERNEL_SLOTS; the stops at the record's extreme
    positions) driven by the held voltage, the current carried over from interval to interval (its flux linkage
    continuous), the armature started on each interval from the measured position: at rest on a stop, else at
    the velocity that brings it to the next measured position (found by the secant method), or, arriving at a
    stop, at the velocity it had. The error: half a sample times the velocity's jump at either end of the
    interval, plus the miss of the next measured position."""
    n = x.size
    current = np.empty((n - 1, substeps + 1))
    position = np.empty((n - 1, substeps + 1))
    error = np.zeros(n - 1)
    h = ts / substeps
    i, v_end = i0, (x[1] - x[0]) / ts
    for k in range(n - 1):
        v_before = v_end
        if stopped[k]:
            v = 0.0
        elif stopped[k + 1]:
            v = v_end
        else:
            v = (x[k + 1] - x[k]) / ts
            slope = ts
            for _ in range(4):
                miss = _interval(i, x[k], v, u[k], p, h, substeps, current[k], position[k])[1] - x[k + 1]
                if miss == 0.0:
                    break
                nudge = -miss / slope
                again = _interval(i, x[k], v + nudge, u[k], p, h, substeps, current[k], position[k])[1] - x[k + 1]
                if again != miss:
                    slope = (again - miss) / nudge
                v -= miss / slope
        i, x_end, v_end = _interval(i, x[k], v, u[k], p, h, substeps, current[k], position[k])
        jump = 0.5 * ts * abs(v - v_before) if k > 0 and not stopped[k] else 0.0
        error[k] = max(error[k], jump) + abs(x_end - x[k + 1])
        if k > 0:
            error[k - 1] = max(error[k - 1], jump)
        if k + 1 < n - 1:   # the flux linkage carries over to the measured position
            psi = flux(i + p[_REMANENCE], inductance(x_end, p[1], p[2], p[3]), p[_SATURATION])
            i = _circuit_at(psi, x[k + 1], p[1], p[2], p[3], p[_SATURATION], p[_REMANENCE])
    return current, position, error


def _nodes(u, i, x, stopped, electrical, mechanical, speed, ts, substeps):
    """(The armature's positions at the half sub-steps of each interval, (n - 1, 2 substeps + 1), their possible
    error per interval in m): along the spline (mechanical None, the first pass), else along the paths the
    parameters (and a friction's v_s `speed`) give (`_paths`)."""
    if mechanical is None:
        return _spline_nodes(x, stopped, substeps), _spline_error(x, stopped)
    friction = max(mechanical[4:5].sum(), 0.0)
    kernel = np.concatenate((electrical[:4], mechanical[:4], (x.min(), x.max(), friction, speed or 0.0),
                             np.maximum(electrical[4:], 0.0)))   # KERNEL_SLOTS
    _, nodes, error = _paths(u, float(i[0]), x, stopped, kernel, ts, 2 * substeps)
    return nodes, error


def _simulated(u, i, nodes, electrical, ts, substeps):
    """(current predicted at the samples, magnetizing current psi / L(x) at the sub-step boundaries) of the
    electrical vector (ELECTRICAL_FIELDS), the armature moved along `nodes`."""
    return _driven(u, float(i[0]), nodes, *electrical, ts, substeps)


def _start(u, i, x, ts, source, nodes, substeps):
    """(R, L0, a, g0): of the flux-form equation's solutions, the one whose current, simulated along `nodes` from
    its settling on, is nearest the measured. They: over a grid of g0 the one with the least equation residual, by
    instrumental variables (the regressors two samples earlier: the equation's error holds the current's noise at
    t_k and t_k+1 only, which a voltage that feeds the measured current back, a current loop, meets; the earlier
    regressors are free of it) and by least squares (the instruments are weak where the current hardly changes);
    and, for an armature held over too short a span of the gap for the current to see L(x) change, a constant L
    by either, split evenly between L0 and a / (g0 - x) at g0 a stroke above the record's greatest position."""
    stroke = max(np.ptp(x), 1e-9)
    y = u[:-1] * ts
    trapezoid = 0.5 * ts * (i[1:] + i[:-1])

    def solved(phi, lag):
        instruments = phi[:-lag] if lag else phi
        return np.linalg.lstsq(instruments.T @ phi[lag:], instruments.T @ y[lag:], rcond=None)[0]
    candidates = []
    for lag in (2, 0):
        best = None
        for g0 in x.max() + stroke * np.geomspace(1e-2, 20.0, GAP_GRID):
            phi = np.column_stack((trapezoid, np.diff(i), np.diff(i / (g0 - x))))
            theta = solved(phi, lag)
            cost = np.sum((y - phi @ theta) ** 2)
            if theta[0] > 0 and theta[2] > 0 and (best is None or cost < best[0]):
                best = (cost, np.array([theta[0], max(theta[1], 1e-3 * theta[2] / g0), theta[2], g0]))
        if best is not None:
            candidates.append(best[1])
        r, total = solved(np.column_stack((trapezoid, np.diff(i))), lag)
        if r > 0 and total > 0:
            g0 = x.max() + stroke
            candidates.append(np.array([r, 0.5 * total, 0.5 * total * (g0 - np.mean(x)), g0]))
    best, least = None, np.inf
    for candidate in candidates:
        electrical = np.append(candidate, (0.0, 0.0, 0.0))
        misfit = (i - _simulated(u, i, nodes, electrical, ts, substeps)[0])[_settling(electrical, x, ts, len(u)):]
        cost = _cost(misfit) / misfit.size
        if cost < least:
            best, least = electrical, cost
    if best is None:
        raise InputError(f'{source}: the solenoid model\'s flux-linkage equation has no positive R and inductance '
                         f'on these data')
    return best


def free_rows(x, stopped, nodes, stride=1, first=0):
    """Force-balance rows k (W + 1 <= k < n - W - 1, W the `stride`) whose span t_k-W-1..t_k+W+1 starts at the
    sample `first` or later (the model's flux linkage settled) and the armature spends off the end stops: its path
    between the samples (`nodes`) more than STOP_STEPS position steps (the smallest change in the record) and
    STOP_SHARE of the stroke from them, and each of the span's samples farther from them than twice the larger
    step to its neighbours (an armature that arrives at a stop and is pulled off again between two samples touches
    it unseen, and the path found between the samples need not show it)."""
    steps = np.diff(np.unique(x))
    margin = max(STOP_STEPS * (steps.min() if steps.size else 0.0), STOP_SHARE * np.ptp(x))
    clearance = np.minimum(x - x.min(), x.max() - x)
    travel = np.abs(np.diff(x))
    reach = 2.0 * np.maximum(np.append(travel, 0.0), np.insert(travel, 0, 0.0))
    sample_clear = ~stopped & (clearance > reach + margin)
    clear = np.min(np.minimum(nodes - x.min(), x.max() - nodes), axis=1) > margin   # per interval
    clear &= sample_clear[:-1] & sample_clear[1:]
    window = np.lib.stride_tricks.sliding_window_view(clear, 2 * stride + 2).all(axis=1)   # intervals k-W-1 .. k+W
    window[:first] = False
    return np.flatnonzero(window) + stride + 1


def _triangle_means(values, rows, stride=1):
    """(The triangle-weighted mean over [t_k-W, t_k+W], W the `stride`; the mean over [t_k, t_k+W] less that over
    [t_k-W, t_k], over W) at each row of `values` given at the (even number of) sub-step boundaries of each
    interval, by Simpson's rule on each interval (the weight's kinks fall on the samples): from each interval's
    mean and its mean of s times the values (s from 0 to 1 over it), the weight being linear in s there."""
    panels = values.shape[1] - 1
    s = np.arange(panels + 1) / panels
    simpson = np.ones(panels + 1)
    simpson[1:-1:2], simpson[2:-1:2] = 4.0, 2.0
    simpson /= 3.0 * panels
    mean, moment = values @ simpson, values @ (simpson * s)
    triangle, rise = np.zeros(rows.size), np.zeros(rows.size)
    for m in range(stride):   # the m-th interval after t_k and the m-th before it
        after, before = rows + m, rows - 1 - m
        triangle += (stride - m) * mean[after] - moment[after] + (stride - m - 1) * mean[before] + moment[before]
        rise += mean[after] - mean[before]
    return triangle / stride ** 2, rise / stride ** 2


class _Balance:
    """The force balance on `rows` along the path `nodes` (positions at the half sub-steps of each interval), at a
    `stride` of W samples: its output, the second difference of position over (W Ts)^2 (`acceleration`), and its
    regressors at an electrical vector (`regressors`); `friction` the friction's column once its v_s is chosen
    (None: no friction)."""

    def __init__(self, x, nodes, rows, ts, stride=1):
        self.rows, self.position, self.stride = rows, nodes[:, ::2], stride
        self.acceleration = (x[rows + stride] - 2.0 * x[rows] + x[rows - stride]) / (stride * ts) ** 2
        mean_position, rise = _triangle_means(nodes, rows, stride)
        self.fixed = [rise / ts, mean_position, np.ones(rows.size)]
        self.velocity = np.gradient(nodes, axis=1) * (nodes.shape[1] - 1) / ts   # at the half sub-steps
        self.friction = None

    def friction_column(self, v_s):
        """The triangle-weighted mean of tanh(v / v_s) (v_s 0: sign(v)) along the path at the rows."""
        shape = np.sign(self.velocity) if v_s == 0 else np.tanh(self.velocity / v_s)
        return _triangle_means(shape, self.rows, self.stride)[0]

    def regressors(self, magnetizing, electrical, with_friction=True):
        """(F_k, v_k, xbar_k, 1 [, the friction's column]) at the rows: the force the triangle-weighted mean of
        M^2 L'(x) / 2, M the magnetizing current at the sub-step boundaries."""
        force = _triangle_means(0.5 * magnetizing ** 2 * inductance_slope(self.position, *electrical[2:4]),
                                self.rows, self.stride)[0]
        friction = [self.friction] if with_friction and self.friction is not None else []
        return np.column_stack([force] + self.fixed + friction)

    def stiffness(self, magnetizing, electrical):
        """How an error of the path's position enters the force's regressor (N/m, triangle-weighted at the rows):
        (at once, at constant flux linkage, M^2 (L''(x) / 2 - L'(x)^2 / L(x)); through the flux linkage, which
        follows with the coil's lag L / R, M^2 L'(x)^2 / L(x)): together, slowly, I^2 L''(x) / 2 at constant
        current."""
        l0, a, g0 = electrical[1:4]
        slope = inductance_slope(self.position, a, g0)
        lagged = magnetizing ** 2 * slope ** 2 / inductance(self.position, l0, a, g0)
        direct = magnetizing ** 2 * slope / (g0 - self.position) - lagged
        return tuple(_triangle_means(values, self.rows, self.stride)[0] for values in (direct, lagged))


def _mechanics(balance, magnetizing, electrical, speeds=()):
    """(theta: the least-squares coefficients of the force balance's regressors, 1/m, -B/m, -k/m, -F0/m [, -Fc/m];
    the friction's v_s, None without; the residual in m/s^2) at the electrical vector whose magnetizing current
    along the path is `magnetizing`; with `speeds`, a friction Fc tanh(v / v_s) (0: sign(v)) along the path,
    triangle-weighted like the force, v_s the one of `speeds` that leaves the least residual."""
    phi = balance.regressors(magnetizing, electrical, with_friction=False)
    acceleration = balance.acceleration

    def with_friction(v_s):
        return np.column_stack((phi, balance.friction_column(v_s)))

    def misfit(v_s):
        columns = with_friction(v_s)
        return float(np.sum((acceleration - columns @ np.linalg.lstsq(columns, acceleration, rcond=None)[0]) ** 2))
    speed = None
    if len(speeds):
        grid = [misfit(v_s) for v_s in speeds]
        j = int(np.argmin(grid))
        speed = float(speeds[j])
        if 0 < j < len(speeds) - 1:   # refined between its neighbours (the sign's: as far below as the next above)
            low = speeds[j - 1] if speeds[j - 1] > 0 else speeds[j] ** 2 / speeds[j + 1]
            search = minimize_scalar(lambda z: misfit(np.exp(z)), bounds=(np.log(low), np.log(speeds[j + 1])),
                                     method='bounded', options={'xatol': 1e-3})
            speed = float(np.exp(search.x)) if search.fun < grid[j] else speed
        phi = with_friction(speed)
    theta = np.linalg.lstsq(phi, acceleration, rcond=None)[0]
    return theta, speed, acceleration - phi @ theta


def _stride(u, i, x, stopped, nodes, electrical, ts, substeps, keep, settled):
    """The force balance (_Balance) at the stride of STRIDES (of those that keep MIN_FREE_ROWS rows and
    STRIDE_ROWS of the first stride's: a variance from a few rows would choose by its own scatter) whose fit alone
    at `electrical` gives m, B and k the least sum of squared relative one-sigmas. Over a stride of W samples the
    second difference's position noise falls as W^-2, while the motion faster than W Ts is lost: an armature that
    crosses its stroke in a few samples needs W = 1, one held slowly between its stops at a high rate a long
    stride, or the position's noise swamps the acceleration and, entering the regressors too, biases the fit."""
    magnetizing = _simulated(u, i, nodes, electrical, ts, substeps)[1]
    none = np.zeros(len(electrical), bool)
    best, choice, least = np.inf, None, MIN_FREE_ROWS
    for stride in STRIDES:
        rows = free_rows(x, stopped, nodes, stride, settled)
        if rows.size < least:
            continue
        least = max(least, STRIDE_ROWS * rows.size) if choice is None else least
        balance = _Balance(x, nodes, rows, ts, stride)
        theta = _mechanics(balance, magnetizing, electrical)[0]
        covariance = _Joint(u, i, x, nodes, electrical, none, theta, balance, None, ts, substeps, keep,
                            (0.0, 1.0)).covariance()
        values = _mechanical_values(theta)[:3]
        with np.errstate(divide='ignore', invalid='ignore'):
            score = float(np.sum(np.diag(covariance)[:3] / values ** 2))
        if choice is None or score < best:
            best, choice = score, balance
    return choice


def _mechanical_values(theta):
    """(m, B, k, F0 [, Fc]) of the force balance's coefficients theta."""
    mass = 1.0 / theta[0]
    return np.concatenate(([mass], -theta[1:] * mass))


class _Joint:
    """The joint fit at a point (`electrical`, the force balance's coefficients `theta`, the friction's v_s `speed`),
    which minimises weights[0] times the current's squared residual plus weights[1] times the force balance's: the
    residuals, each one's Jacobian by every parameter (the electrical ones by forward differences, the force
    balance's coefficients and, searched, ln v_s), the weighted Gauss-Newton matrix of the two together, and how
    the position's noise enters the force balance (_NoiseMap)."""

    def __init__(self, u, i, x, nodes, electrical, free, theta, balance, speed, ts, substeps, keep, weights):
        self.u, self.i, self.x, self.ts, self.keep, self.weights = u, i, x, ts, keep, weights
        self.electrical, self.free, self.theta, self.balance = electrical, free, theta, balance
        current, magnetizing = _simulated(u, i, nodes, electrical, ts, substeps)
        self.phi = balance.regressors(magnetizing, electrical)
        self.e_residual = (i - current)[keep]
        self.residual = balance.acceleration - self.phi @ theta
        self.count = count = int(free.sum())
        steps = 1e-6 * _scales(u, i, x, electrical)
        self.e_jacobian = np.empty((self.e_residual.size, count))   # of the models, d(current) and d(acceleration)
        mechanical = np.empty((self.residual.size, count))
        stiffness = balance.stiffness(magnetizing, electrical)
        self.stiffness_slopes = []   # d(the force's stiffness)/d(each fitted electrical parameter)
        for column, j in enumerate(np.flatnonzero(free)):
            shifted = electrical.copy()
            shifted[j] += steps[j]
            moved, moved_magnetizing = _simulated(u, i, nodes, shifted, ts, substeps)
            self.e_jacobian[:, column] = (moved - current)[keep] / steps[j]
            mechanical[:, column] = (balance.regressors(moved_magnetizing, shifted) - self.phi) @ theta / steps[j]
            self.stiffness_slopes.append([(moved_part - part) / steps[j] for moved_part, part in
                                          zip(balance.stiffness(moved_magnetizing, shifted), stiffness)])
        mechanical = np.column_stack((mechanical, self.phi))
        if speed:   # v_s searched, not known: its column (d model / d ln v_s) joins the Jacobian
            ratio = balance.velocity / speed
            slope = _triangle_means(-ratio / np.cosh(np.clip(ratio, -300.0, 300.0)) ** 2, balance.rows,
                                    balance.stride)[0]
            mechanical = np.column_stack((mechanical, theta[-1] * slope))
        self.m_jacobian = mechanical
        self.e_full = np.zeros((self.e_residual.size, mechanical.shape[1]))
        self.e_full[:, :count] = self.e_jacobian
        self.noise_map = _NoiseMap(theta, balance, ts, stiffness, electrical, x)
        self.bread = (weights[0] * self.e_full.T @ self.e_full
                      + weights[1] * mechanical.T @ mechanical)
        self.inverse, self.unresolved = _inverse(self.bread)

    def fit(self):
        """(The fit check, the position noise's variance for the uncertainty, its white level): _fit's."""
        return _fit(self.u, self.i, self.x, self.ts, np.flatnonzero(self.keep), self.e_residual, self.e_jacobian,
                    self.electrical, self.residual / self.theta[0], self.phi, self.noise_map, 1.0 / self.theta[0])

    def corrected(self, noise):
        """(electrical, theta) moved by one Gauss-Newton step off the bias that white position noise of variance
        `noise` (m^2) puts in the fit. The path between the samples passes through the measured positions, so the
        force balance's regressors and their slopes by the parameters carry the noise that its output carries too
        (errors in variables): the weighted equations sum J' W r = 0 hold, on average, away from the truth by their
        expected value there, sum E[dJ_k' r_k], here from REALISATIONS of white noise through the regressors'
        stencils and the residual's (_NoiseMap). Held between its stops the armature shows the force's shape in x
        (and with it the split of L(x) between L0 and a) over a short span only, which that bias would move by
        several of its sigmas."""
        white = _white(self.x.size)
        residual = self.noise_map.through(white)
        position, lagged_position, velocity = self.noise_map.regressor_noise(white)
        direct, lagged = self.noise_map.stiffness
        columns = [self.theta[0] * (d_direct * position + d_lagged * lagged_position)
                   for d_direct, d_lagged in self.stiffness_slopes]
        columns += [direct * position + lagged * lagged_position, velocity, position]
        bias = np.zeros(self.m_jacobian.shape[1])
        bias[:len(columns)] = [np.mean(np.sum(column * residual, axis=1)) for column in columns]
        step = -self.inverse @ (self.weights[1] * noise * bias)
        electrical = self.electrical.copy()
        electrical[self.free] += step[:self.count]
        return electrical, self.theta + step[self.count:self.count + len(self.theta)]

    def covariance(self, noise=None):
        """The covariance of the fitted electrical parameters and m, B, k, F0 [, Fc]: a sandwich, the bread the
        Gauss-Newton matrix, the meat the current's residual over ELECTRICAL_LAGS samples of autocorrelation plus
        white position noise of variance `noise` (m^2; None: the level that explains the force balance's
        residual) through the force balance rows' stencils (_NoiseMap; the residuals' own lagged products would
        cancel to nearly nothing, the second difference holding no noise at low frequency but at the ends of each
        run of rows). Values that take in a direction the data do not see have an infinite variance."""
        if noise is None:
            noise = _rms(self.residual) ** 2 / np.mean(self.noise_map.through(_white(self.x.size)) ** 2)
        spread = self.noise_map.spread(self.m_jacobian)   # the rows' Jacobian carried to the samples' noise
        meat = (self.weights[0] ** 2 * _lagged(self.e_full * self.e_residual[:, None], ELECTRICAL_LAGS)
                + self.weights[1] ** 2 * noise * spread.T @ spread)
        size = self.count + len(self.theta)
        covariance = (self.inverse @ meat @ self.inverse)[:size, :size]
        mass = 1.0 / self.theta[0]
        transform = np.eye(size)   # d(values)/d(electrical, theta): m = 1/theta_0, the others -theta_j m
        block = -mass * np.eye(len(self.theta))
        block[:, 0] = self.theta * mass ** 2
        block[0, 0] = -mass ** 2
        transform[self.count:, self.count:] = block
        covariance = transform @ covariance @ transform.T
        lost = (np.abs(transform) @ self.unresolved[:size]) > 0   # values that take in an unresolved direction
        covariance[lost, :] = covariance[:, lost] = 0.0
        covariance[lost, lost] = np.inf
        return covariance


class _NoiseMap:
    """How white position noise q at the samples enters the force balance's rows (m/s^2 per m): through each row's
    stencil over the samples k-W-1 .. k+W+1 (W the stride): the stride's second difference less the shares of the
    path's mean velocity, mean position and force (theta's second, third and first coefficients), those of the
    path's means (_triangle_means) were it the cubic through each four samples x_j-1 .. x_j+2 about the interval
    [t_j, t_j+1] (CUBIC_MEAN, CUBIC_MOMENT); the force's share in two parts (_Balance.stiffness): at once, and
    through the flux linkage, which sees the noise low-passed by the coil's lag (`decay` per sample). Held between
    its stops the armature's force follows its position, and the force's stiffness and the spring's nearly
    cancel."""

    def __init__(self, theta, balance, ts, stiffness, electrical, x):
        stride = balance.stride
        self.rows, self.offsets = balance.rows, range(-stride - 1, stride + 2)
        size, centre = 2 * stride + 3, stride + 1
        second = np.zeros(size)
        second[[centre - stride, centre, centre + stride]] = 1.0, -2.0, 1.0
        position, velocity = np.zeros(size), np.zeros(size)
        for m in range(stride):   # the intervals k+m (samples k+m-1 .. k+m+2) and k-1-m (k-m-2 .. k-m+1)
            after, before = slice(centre + m - 1, centre + m + 3), slice(centre - m - 2, centre - m + 2)
            position[after] += (stride - m) * CUBIC_MEAN - CUBIC_MOMENT
            position[before] += (stride - m - 1) * CUBIC_MEAN + CUBIC_MOMENT
            velocity[after] += CUBIC_MEAN
            velocity[before] -= CUBIC_MEAN
        self.position, self.velocity = position / stride ** 2, velocity / (stride ** 2 * ts)
        position = self.position
        common = second / (stride * ts) ** 2 - theta[1] * self.velocity - theta[2] * position
        self.stiffness = direct, lagged = stiffness
        self.direct = common - theta[0] * direct[:, None] * position
        self.lagged = -theta[0] * lagged[:, None] * position
        r, l0, a, g0 = electrical[:4]
        self.decay = np.exp(-r * ts / (inductance(x, l0, a, g0) * (1.0 + r * electrical[6])))

    def through(self, noise):
        """The rows' residuals (realisations x rows) that noise (realisations x samples) leaves."""
        slow = _low_pass(noise.T, self.decay, False).T
        return sum(self.direct[:, c] * noise[:, self.rows + o] + self.lagged[:, c] * slow[:, self.rows + o]
                   for c, o in enumerate(self.offsets))

    def regressor_noise(self, noise):
        """(The rows' mean position's noise, that of the mean position the coil's lag low-passes, the mean
        velocity's; realisations x rows) that noise (realisations x samples) puts in the path."""
        slow = _low_pass(noise.T, self.decay, False).T
        return tuple(sum(weights[c] * values[:, self.rows + o] for c, o in enumerate(self.offsets))
                     for weights, values in ((self.position, noise), (self.position, slow), (self.velocity, noise)))

    def spread(self, jacobian):
        """The rows' `jacobian` (rows x parameters) carried to the samples whose noise it meets: S with the rows'
        noise part sum over rows of J_k' e_k = S' q."""
        direct, slow = (np.zeros((self.decay.size, jacobian.shape[1])) for _ in range(2))
        for c, o in enumerate(self.offsets):
            direct[self.rows + o] += self.direct[:, c:c + 1] * jacobian
            slow[self.rows + o] += self.lagged[:, c:c + 1] * jacobian
        return direct + _low_pass(slow, self.decay, True)


@numba.njit(cache=True)
def _low_pass(values, decay, transposed):
    """y_k = decay_k y_k-1 + (1 - decay_k) v_k down each column of `values` (samples x columns), the coil's lag on
    each sample; `transposed`: the transpose of that map (run backwards)."""
    out = np.empty_like(values)
    y = np.zeros(values.shape[1])
    n = values.shape[0]
    if transposed:   # w_j = v_j + decay_j+1 w_j+1, out_j = (1 - decay_j) w_j
        for j in range(n - 1, -1, -1):
            y = values[j] + (decay[j + 1] if j + 1 < n else 0.0) * y
            out[j] = (1.0 - decay[j]) * y
    else:
        for k in range(n):
            y = decay[k] * y + (1.0 - decay[k]) * values[k]
            out[k] = y
    return out


def _white(samples):
    """REALISATIONS of white noise of unit variance over the samples (seeded: the same on every call)."""
    return np.random.default_rng(0).standard_normal((REALISATIONS, samples))


def _lagged(g, lags):
    """sum over |l| <= lags of sum_k g_k g_k+l': the meat of a sandwich whose rows' scores g are correlated over
    up to `lags` rows."""
    meat = g.T @ g
    for lag in range(1, lags + 1):
        cross = g[lag:].T @ g[:-lag]
        meat += cross + cross.T
    return meat


def _inverse(matrix):
    """(The inverse of a symmetric non-negative matrix, on the directions it resolves; which of its parameters it
    does not resolve): scaled to a unit diagonal, the eigenvectors whose eigenvalue falls below SINGULAR of the
    largest are left out, and the parameters they take in more than SINGULAR of are unresolved (the data say
    nothing of some combination of them)."""
    diagonal = np.sqrt(np.clip(np.diag(matrix), 0.0, None))
    seen = diagonal > 0
    scale = np.where(seen, 1.0 / np.where(seen, diagonal, 1.0), 0.0)
    values, vectors = np.linalg.eigh(matrix * np.outer(scale, scale))
    kept = values > SINGULAR * max(values.max(), 0.0)
    inverse = (vectors[:, kept] / values[kept]) @ vectors[:, kept].T * np.outer(scale, scale)
    unresolved = ~seen | (np.abs(vectors[:, ~kept]) > SINGULAR ** 0.5).any(axis=1)
    return inverse, unresolved


def _fit(u, i, x, ts, kept, e_residual, jacobian, electrical, m_residual, phi, noise_map, mass):
    """({'electrical': EquationFit in V (the current's residual times R), 'mechanical': EquationFit in N}; the
    position noise's variance (m^2) for the uncertainty: the level the fit check finds in the force balance's high
    band, times its low band's ratio where that is above one, None where the rows are too few for a low band; that
    level itself). The force balance's rows are runs of samples with gaps between them, so the noise's share of its
    low band comes from REALISATIONS of white position noise through `noise_map` (_NoiseMap, times the `mass`) on
    those rows."""
    r = electrical[0]
    equations = {'electrical': (r * e_residual, {'current': np.array([r])}),
                 'mechanical': (m_residual, {'position': mass * noise_map.through(_white(len(x)))})}
    bands = low_band(equations, ts)
    white = noise_variances(equations, ts)['position']
    level = white * max(bands['mechanical'].ratio, 1.0)
    if not (np.isfinite(level) and level > 0):   # too few rows for a low band: the residual's own level (None)
        level = None
    signals = {'voltage': u, 'current': i, 'position': x}
    return {'electrical': equation_fit('electrical', r * e_residual, bands['electrical'], jacobian, signals, kept,
                                       ts, r * float(np.sqrt(np.mean(i[kept] ** 2)))),
            'mechanical': equation_fit('mechanical', m_residual, bands['mechanical'], phi, signals, noise_map.rows,
                                       ts, float(np.sqrt(np.mean(phi[:, 0] ** 2))))}, level, white
