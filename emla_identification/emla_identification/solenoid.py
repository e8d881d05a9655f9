"""Offline identification of a solenoid (docs/physics.md §9.1): R, L0, a, g0 from the coil's voltage, current and
position, then m, B, k, F0 from the co-energy force, each with a one-sigma, and the fit check of each equation.

Electrical, output error. Along a path x(t) of the armature between the samples and with the held voltage, the
flux linkage obeys dpsi/dt = u - R psi / L(x) exactly; integrated over each sample interval (RK4 in sub-steps of
at most SUBSTEP, from psi = L(x_0) I_0) it predicts the current I_k = psi_k / L(x_k), and R, L0, a, g0 minimise
its squared difference from the measured current. The current's noise is then the output's noise alone, and what
happens between the samples is integrated, not approximated: no discretisation or errors-in-variables bias at
any L/R against the sample period. The start comes from the flux-form equation
    psi_k - psi_k-1 = u_k-1 Ts - R (trapezoid of I),   psi = L0 I + a I / (g0 - x)
by least squares over a grid of g0 (linear in R, L0, a for a fixed g0).

The path between the samples matters at 1 kHz, where the armature crosses its stroke in four samples and stops
dead: the first pass takes a cubic spline through each run of samples off the stops (`_spline_nodes`), the later
passes the path the identified model gives between each pair of measured positions (`_paths`: the solenoid's own
equations with its end stops, started at the velocity that reaches the next measured position), PASSES passes in
all; each fits only the samples whose predicted current its path's possible error spoils by less than RELIABLE
of the current's noise (`_reliable`).

Mechanical, equation error on the rows over which the armature keeps off the stops (`free_rows`). The second
difference of position is the triangle-weighted mean of the acceleration over [t_k-1, t_k+1] (exactly), so with
the same weighting of every force:
    (x_k+1 - 2 x_k + x_k-1) / Ts^2 = (F_k - B v_k - k xbar_k - F0) / m
F_k: the weighted mean of I^2 L'(x) / 2 along the path, from the electrical model's current between the samples
(Simpson's rule on the sub-steps; it carries no current noise), v_k and xbar_k the weighted mean velocity and
position along the path (a five-point formula, exact only for a quartic motion, left B 0.3 % high at 1 kHz). The
noisy second difference is the regression's output, so its noise does not bias the fit.

Uncertainties: the electrical fit's from its residuals (a sandwich estimator over ELECTRICAL_LAGS samples), the
mechanical fit's from white position noise passed through the rows' stencils (its level from the residual), and
the electrical parameters' covariance carried into the mechanical ones through the force (the Jacobian of the
mechanical fit by the electrical parameters).
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
from .noise_floor import low_band

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
HINT_SAMPLES = 10000  # samples a moving coil's misfit record is tried as a solenoid on (a second at 10 kHz: ~2 s)
PASSES = 3            # electrical and mechanical fits in turn (the first on a spline path between the samples)
_SATURATION, _REMANENCE = (KERNEL_SLOTS.index(name) for name in ELECTRICAL_FIELDS[4:6])
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
    return _identify(u, i, x, ts, source, friction, saturation, remanence, eddy)


def solenoid_hint(recording: Recording) -> str | None:
    """For a record the moving coil does not fit: a warning line that the solenoid model fits it (both of its
    equations within their noise floors, on its first HINT_SAMPLES samples) and how to ask for it; None when it
    does not (or cannot be fitted)."""
    first = {name: np.asarray(values)[:HINT_SAMPLES] for name, values in recording.signals.items()
             if name in ('voltage', 'current', 'position')}
    try:
        with np.errstate(all='ignore'):
            result = identify_solenoid(sample_period=recording.sample_period, **first)
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
    electrical = np.append(_start(u, i, x, ts), (0.0, 0.0, 0.0))   # ELECTRICAL_FIELDS: the effects from zero
    free = np.array([True] * 4 + [saturation, remanence, eddy])      # which of them are fitted
    mechanical, speed = None, None   # the first pass: the armature's path a spline through the samples
    for _ in range(PASSES):
        nodes, error = _nodes(u, i, x, stopped, electrical, mechanical, speed, ts, substeps)
        keep = np.ones(len(u), bool)
        keep[:_settling(electrical, x, ts, len(u))] = False
        if mechanical is None:
            electrical = _electrical(u, i, nodes, electrical, free, ts, substeps, keep, x, source)[0]
        keep &= _reliable(i, x, stopped, error, electrical, ts)
        electrical, jacobian, e_residual = _electrical(u, i, nodes, electrical, free, ts, substeps, keep, x, source)
        rows = free_rows(x, stopped, nodes)
        if rows.size < MIN_FREE_ROWS:
            raise InputError(f'{source}: the armature is free on {rows.size} force-balance rows only (at least '
                             f'{MIN_FREE_ROWS} needed): the mechanics need it to move between its stops')
        speeds = FRICTION_SPEEDS * np.max(np.abs(np.diff(nodes, axis=1))) * 2 * substeps / ts if friction else ()
        mechanical, m_cov, m_residual, phi, stencil, speed = _mechanics(u, i, x, nodes, electrical, ts, substeps,
                                                                        rows, speeds)
    e_cov = _sandwich(jacobian, e_residual, ELECTRICAL_LAGS)
    count = int(free.sum())
    gain = np.empty((len(mechanical), count))   # d(mechanical)/d(electrical)
    for column, j in enumerate(np.flatnonzero(free)):
        step = 1e-6 * (electrical[j] or np.sqrt(e_cov[column, column]))
        shifted = electrical.copy()
        shifted[j] += step
        gain[:, column] = (_mechanics(u, i, x, nodes, shifted, ts, substeps, rows,
                                      () if speed is None else (speed,))[0] - mechanical) / step
    names = tuple(np.array(ELECTRICAL_FIELDS)[free]) + MECHANICAL + (('coulomb_force',) if friction else ())
    covariance = np.zeros((len(names), len(names)))
    covariance[:count, :count] = e_cov
    covariance[count:, count:] = m_cov + gain @ e_cov @ gain.T
    covariance[count:, :count] = gain @ e_cov
    covariance[:count, count:] = covariance[count:, :count].T
    values = np.concatenate((electrical[free], mechanical))
    if not np.all(np.isfinite(values)) or not np.all(np.diag(covariance) >= 0):
        raise InputError(f'{source}: the solenoid model gives no finite estimate from these data')
    std = np.sqrt(np.diag(covariance))
    fit = _fit(u, i, x, ts, np.flatnonzero(keep), e_residual, jacobian, electrical, m_residual, phi, rows, stencil)
    return SolenoidResult(parameters=dict(zip(names, map(float, values))),
                          std=dict(zip(names, map(float, std))), covariance=covariance,
                          samples=len(u), sample_period=ts, free_rows=int(rows.size),
                          stroke=(float(x.min()), float(x.max())), fit=fit,
                          settings={} if speed is None else {'friction_speed': float(speed)})


def _electrical(u, i, nodes, start, free, ts, substeps, keep, x, source):
    """(The ELECTRICAL_FIELDS vector with the `free` ones fitted, the Jacobian of the current's residual by those and
    that residual at the samples `keep`): the output-error fit from `start`, the armature moved along `nodes`. The
    effects are scaled by the largest current: c by it over the cube of the largest flux linkage without them (c
    psi^3 a share of I), I_r by it, G by it over the largest voltage."""
    peak = np.max(np.abs(i))
    scale = np.abs(start)
    scale[4:] = np.maximum(scale[4:], (peak / np.max(np.abs(inductance(x, *start[1:4]) * i)) ** 3, peak,
                                       peak / max(np.max(np.abs(u)), 1e-12)))
    scale = scale[free]
    low = np.array([1e-6, 0.0, 1e-6, (x.max() - x.min()) * 1e-3 + x.max(), 0.0, 0.0, 0.0])[free] / scale

    def full(q):
        values = start.copy()
        values[free] = q * scale
        return values

    def residual(q):
        return (i - _simulated(u, i, nodes, full(q), ts, substeps)[0])[keep]
    try:
        solution = least_squares(residual, np.maximum(start[free] / scale, low), bounds=(low, np.inf),
                                 x_scale='jac', xtol=1e-12, ftol=1e-12)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise InputError(f'{source}: the solenoid model cannot be fitted to these data ({exc})') from None
    return full(solution.x), -solution.jac / scale, solution.fun


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


def _reliable(i, x, stopped, error, electrical, ts):
    """The samples whose predicted current the path's possible error per interval (`error`, m) does not spoil:
    the current error it would cause, R I L'(x) dx Ts / L(x)^2, carried forward with the coil's decay
    exp(-R Ts / (L(x) (1 + R G))), below RELIABLE of the current's noise (from its second difference on the stops,
    at least 1e-6 of the current's RMS)."""
    r, l0, a, g0 = electrical[:4]
    inductances = inductance(x[:-1], l0, a, g0)
    kick = r * np.abs(i[:-1]) * inductance_slope(x[:-1], a, g0) * error * ts / inductances ** 2
    carried = _carried(kick, np.exp(-r * ts / (inductances * (1.0 + r * electrical[6]))))
    still = stopped[1:-1] & stopped[:-2] & stopped[2:]
    noise = 1.4826 * np.median(np.abs(np.diff(i, 2)[still])) / np.sqrt(6.0) if still.any() else 0.0
    return np.concatenate(([False], carried < RELIABLE * max(noise, 1e-6 * np.sqrt(np.mean(i * i)))))


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


def _start(u, i, x, ts):
    """(R, L0, a, g0) from the flux-form equation by least squares over a grid of g0 (the best residual)."""
    stroke = max(np.ptp(x), 1e-9)
    best = None
    for g0 in x.max() + stroke * np.geomspace(1e-2, 20.0, GAP_GRID):
        per_ampere = 1.0 / (g0 - x)
        phi = np.column_stack((0.5 * ts * (i[1:] + i[:-1]), np.diff(i), np.diff(i * per_ampere)))
        y = u[:-1] * ts
        theta, *_ = np.linalg.lstsq(phi, y, rcond=None)
        cost = np.sum((y - phi @ theta) ** 2)
        if theta[0] > 0 and theta[2] > 0 and (best is None or cost < best[0]):
            best = (cost, np.array([theta[0], max(theta[1], 1e-3 * theta[2] / g0), theta[2], g0]))
    if best is None:
        raise InputError('the solenoid model\'s flux-linkage equation has no positive R and a on these data')
    return best[1]


def free_rows(x, stopped, nodes):
    """Force-balance rows k (2 <= k < n - 2) whose span t_k-2..t_k+2 the armature spends off the end stops: its path
    between the samples (`nodes`) more than STOP_STEPS position steps (the smallest change in the record) and
    STOP_SHARE of the stroke from them, and each of the five samples farther from them than twice the larger
    step to its neighbours (an armature that arrives at a stop and is pulled off again between two samples
    touches it unseen, and the path found between the samples need not show it)."""
    steps = np.diff(np.unique(x))
    margin = max(STOP_STEPS * (steps.min() if steps.size else 0.0), STOP_SHARE * np.ptp(x))
    clearance = np.minimum(x - x.min(), x.max() - x)
    travel = np.abs(np.diff(x))
    reach = 2.0 * np.maximum(np.append(travel, 0.0), np.insert(travel, 0, 0.0))
    sample_clear = ~stopped & (clearance > reach + margin)
    clear = np.min(np.minimum(nodes - x.min(), x.max() - nodes), axis=1) > margin   # per interval
    clear &= sample_clear[:-1] & sample_clear[1:]
    window = np.lib.stride_tricks.sliding_window_view(clear, 4).all(axis=1)   # intervals k-2 .. k+1
    return np.flatnonzero(window) + 2


def _triangle_means(values, rows):
    """(The triangle-weighted mean over [t_k-1, t_k+1], the mean over [t_k, t_k+1] less that over [t_k-1, t_k]) at
    each row of `values` given at the (even number of) sub-step boundaries of each interval, by Simpson's rule
    (the weight's kink falls on t_k)."""
    panels = values.shape[1] - 1
    s = np.arange(panels + 1) / panels
    simpson = np.ones(panels + 1)
    simpson[1:-1:2], simpson[2:-1:2] = 4.0, 2.0
    simpson /= 3.0 * panels
    before, after = values[rows - 1], values[rows]
    return before @ (simpson * s) + after @ (simpson * (1.0 - s)), after @ simpson - before @ simpson


def _mechanics(u, i, x, nodes, electrical, ts, substeps, rows, speeds=()):
    """(m, B, k, F0 [, Fc]), their covariance, the force balance's residual (N), its regressors at `rows`, the
    stencil by which position noise enters the residual (N/m) and the friction's v_s (None without), the force from
    the electrical parameters with the armature moved along `nodes`; with `speeds`, a friction Fc tanh(v / v_s) (0:
    sign(v)) along the path, triangle-weighted like the force, v_s the one of `speeds` that leaves the least
    residual. The covariance is that of white position noise through the stencils (the residuals' own lagged
    products would cancel to nearly nothing: the second difference holds no noise at low frequency but at the ends
    of each run of rows)."""
    magnetizing = _simulated(u, i, nodes, electrical, ts, substeps)[1]
    position = nodes[:, ::2]
    force = _triangle_means(0.5 * magnetizing ** 2 * inductance_slope(position, *electrical[2:4]), rows)[0]
    acceleration = (x[rows + 1] - 2.0 * x[rows] + x[rows - 1]) / ts ** 2
    mean_position, rise = _triangle_means(nodes, rows)
    velocity = rise / ts
    columns = [force, velocity, mean_position, np.ones(rows.size)]
    path_velocity = np.gradient(nodes, axis=1) * (nodes.shape[1] - 1) / ts   # at the half sub-steps

    def with_friction(v_s):
        friction = np.sign(path_velocity) if v_s == 0 else np.tanh(path_velocity / v_s)
        return np.column_stack(columns + [_triangle_means(friction, rows)[0]])

    def misfit(v_s):
        phi = with_friction(v_s)
        return float(np.sum((acceleration - phi @ np.linalg.lstsq(phi, acceleration, rcond=None)[0]) ** 2))
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
    phi = with_friction(speed) if speed is not None else np.column_stack(columns)
    theta, *_ = np.linalg.lstsq(phi, acceleration, rcond=None)
    residual = acceleration - phi @ theta
    jacobian = phi
    if speed:   # v_s searched, not known: its column (d model / d ln v_s) joins the covariance's Jacobian
        ratio = path_velocity / speed
        slope = _triangle_means(-ratio / np.cosh(np.clip(ratio, -300.0, 300.0)) ** 2, rows)[0]
        jacobian = np.column_stack((phi, theta[-1] * slope))
    mass = 1.0 / theta[0]
    values = np.concatenate(([mass], -theta[1:] * mass))
    # how position noise q_k-2..q_k+2 enters a row's residual: the second difference less the fitted velocity's
    # and mean position's shares (those of the five-point formulas for the path's means, which pass the samples)
    stencil = (np.array([0.0, 1.0, -2.0, 1.0, 0.0]) / ts ** 2 - theta[1] * np.array([1, -14, 0, 14, -1]) / (24 * ts)
               - theta[2] * np.array([0.0, 1.0, 10.0, 1.0, 0.0]) / 12.0)
    spread = np.zeros((len(x), jacobian.shape[1]))   # W: the rows' Jacobian carried to the samples whose noise it meets
    for offset, weight in zip(range(-2, 3), stencil):
        spread[rows + offset] += weight * jacobian
    bread = np.linalg.inv(jacobian.T @ jacobian)
    noise = np.mean(residual ** 2) / np.sum(stencil ** 2)   # the position noise's variance (m^2)
    theta_cov = (noise * bread @ (spread.T @ spread) @ bread)[:len(theta), :len(theta)]
    transform = -mass * np.eye(len(theta))   # d(values)/d(theta): m = 1/theta_0, the others -theta_j m
    transform[:, 0] = theta * mass ** 2
    transform[0, 0] = -mass ** 2
    return values, transform @ theta_cov @ transform.T, residual * mass, phi, stencil * mass, speed


def _sandwich(jacobian, residual, lags):
    """Covariance of a least-squares fit with regressors (or residual Jacobian) `jacobian` and `residual`, the
    residual correlated over up to `lags` rows: (J'J)^-1 (sum over |l| <= lags of sum_k g_k g_k+l') (J'J)^-1
    with g_k = J_k e_k."""
    g = jacobian * residual[:, None]
    meat = g.T @ g
    for lag in range(1, lags + 1):
        cross = g[lag:].T @ g[:-lag]
        meat += cross + cross.T
    bread = np.linalg.inv(jacobian.T @ jacobian)
    return bread @ meat @ bread


def _fit(u, i, x, ts, kept, e_residual, jacobian, electrical, m_residual, phi, rows, stencil):
    """{'electrical': EquationFit in V (the current's residual times R), 'mechanical': EquationFit in N}. The force
    balance's rows are runs of samples with gaps between them, so the noise's share of its low band comes from
    REALISATIONS of white position noise through its `stencil` on those rows."""
    r = electrical[0]
    white = np.random.default_rng(0).standard_normal((REALISATIONS, len(x)))
    through = sum(weight * white[:, rows + offset] for offset, weight in zip(range(-2, 3), stencil))
    equations = {'electrical': (r * e_residual, {'current': np.array([r])}),
                 'mechanical': (m_residual, {'position': through})}
    bands = low_band(equations, ts)
    signals = {'voltage': u, 'current': i, 'position': x}
    return {'electrical': equation_fit('electrical', r * e_residual, bands['electrical'], jacobian, signals, kept,
                                       ts, r * float(np.sqrt(np.mean(i[kept] ** 2)))),
            'mechanical': equation_fit('mechanical', m_residual, bands['mechanical'], phi, signals, rows, ts,
                                       float(np.sqrt(np.mean(phi[:, 0] ** 2))))}
