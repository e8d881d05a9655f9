"""Grey-box identification of a whole record: physical EMLA parameters (R, L, Km, m, B, Fl) with one-sigma
uncertainties and their convergence over the record.

Each regression of regressors.py is solved by exponentially weighted least squares over the record, the
electrical one by instrumental variables (offline.py; streams: rls.py, see online.py and streaming.py); the
physical parameters follow from the solutions (physical.py) with uncertainties from a sensor-noise model
(noise.py). On the test data the reported values match the scatter over noise realisations to within some 50 %.

The regressions are made for SI magnitudes: their prior (P0 = 1e6 I) must be negligible beside the data's
information, and their sums of squares must neither over- nor underflow. A record whose sample period or
signal peaks lie more than RESCALE_BEYOND from typical ones (checks.TYPICAL) is identified in rescaled units, by
powers of two (exact), and its parameters are scaled back by their dimensions.
"""
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from emla_core.data import as_recording
from emla_core.errors import InputError
from emla_core.recording import Recording

from . import offline
from .checks import TYPICAL, check_excitation, checked, numerical_failures
from .fit_check import check_fit
from .moments import RowMoments
from .online_effects import regression_rows, spring_options
from .physical import fit, reported
from .regressors import COLUMNS, HISTORY
from .segments import identify_segments
from .summary import summary_text

RESCALE_BEYOND = 2.0 ** 16
MEMORY_SPANS = 2          # memory times of the record the fit of an estimate with forgetting is checked on
MIN_FIT_SAMPLES = 256     # samples below which the fit is not checked (too short for its spectra)
UNRESOLVED = 0.1          # one-sigma over |value| above which a parameter is reported as not resolved
PHYSICAL = ('resistance', 'inductance', 'mass')   # positive in any estimate that explains the data
SPRING_SHARE = 0.9        # of the mechanical equation's unexplained low band a spring must explain to be added


@dataclass
class Trajectory:
    """Estimates after growing parts of a record: time (s) of the last sample used, {name: array}."""

    time: np.ndarray
    parameters: dict
    std: dict


@dataclass
class GreyBoxResult:
    model: str
    parameters: dict        # {name: value}, SI; only the parameters the model identifies
    std: dict               # {name: one-sigma}
    covariance: np.ndarray  # of the parameters, in the order of `parameters`
    samples: int
    sample_period: float
    forgetting: float
    trajectory: Trajectory | None = field(repr=False, default=None)
    fit: dict = field(repr=False, default_factory=dict)   # {equation: fit_check.EquationFit}
    notes: list = field(default_factory=list)              # what the identification chose, in words

    def unresolved(self) -> list:
        """The parameters the data do not resolve: a one-sigma above UNRESOLVED of the value (the inductance of
        a coil whose L/R is far below the sample period)."""
        return [name for name, value in self.parameters.items()
                if name != 'load_force' and not self.std[name] < UNRESOLVED * abs(value)]

    def warnings(self) -> list:
        """One line for each equation that does not fit the data and for each unresolved parameter."""
        lines = [line for line in (f.warning() for f in self.fit.values()) if line]
        impossible = [f'{name} {self.parameters[name]:.4g}' for name in PHYSICAL
                      if name in self.parameters and not self.parameters[name] > 0]
        if impossible:
            lines.append(f'the estimate is not physical ({", ".join(impossible)}): the model does not explain these '
                         f'data; run `emla discrepancy` to find what is missing')
        unresolved = self.unresolved()
        for name in unresolved:
            lines.append(f'the data do not resolve the {name}: {self.parameters[name]:.4g} +- {self.std[name]:.2g}'
                         + (f' (the coil\'s L/R is {self.time_constant() / self.sample_period:.2g} sample periods)'
                            if name == 'inductance' else ''))
        if unresolved and self.forgetting < 1.0:   # the estimate rests on its memory, not on the whole record
            lam = self.forgetting
            lines.append(f'with forgetting factor {lam:g} the estimate remembers only 1/(1 - {lam:g}) = '
                         f'{1.0 / (1.0 - lam):.3g} of the {self.samples} samples: a memory that short leaves it '
                         f'noisy; a forgetting factor closer to 1 (--forgetting 1 uses the whole record) or a '
                         f'longer --memory-time resolves more')
        return lines

    def summary(self) -> str:
        """The result as a table a person reads: parameters, one-sigma, relative sigma, the fit verdict per
        equation, notes and warnings (summary.py)."""
        return summary_text(f'{self.model} model, {self.samples} samples at {1.0 / self.sample_period:g} Hz',
                            self.parameters, self.std, {k: f.to_dict() for k, f in self.fit.items()}, self.notes,
                            self.warnings())

    def __str__(self) -> str:
        return self.summary()

    def time_constant(self) -> float:
        """L/R of the estimate (s), NaN without them."""
        p = self.parameters
        return p['inductance'] / p['resistance'] if {'inductance', 'resistance'} <= set(p) else math.nan

    def to_dict(self) -> dict:
        """The `emla identify` JSON object."""
        return {'model': self.model, 'samples': self.samples, 'sample_period': self.sample_period,
                'parameters': dict(self.parameters), 'std': dict(self.std),
                'fit': {name: f.to_dict() for name, f in self.fit.items()}, 'unresolved': self.unresolved(),
                'notes': list(self.notes)}


def identify(data: Recording | Path | str | None = None, model: str | None = None, forgetting: float = 1.0, *,
             memory_time: float | None = None, sample_period: float | None = None, voltage: ArrayLike | None = None,
             current: ArrayLike | None = None, position: ArrayLike | None = None, force: ArrayLike | None = None,
             velocity: ArrayLike | None = None, time: ArrayLike | None = None,
             initial_covariance: float = 1e6, points: int = 200, spring: bool | None = None,
             progress: Callable[[float], object] | None = None) -> GreyBoxResult:
    """Identify the physical parameters of an actuator from a whole record of its signals.

    The grey-box model is u = R I + L dI/dt + Km v (electrical) and m dv/dt = Km I - B v - Fl (mechanical),
    identified from its exact zero-order-hold discretisation (the electrical equation by instrumental
    variables, which keeps closed-loop sensor noise from biasing it), with one-sigma uncertainties from a
    model of the sensor noise.

    Parameters
    ----------
    data : Recording, str, Path or pandas.DataFrame, optional
        The record: a Recording (emla_core.Recording), a CSV file or ROS 2 bag to load, or a DataFrame of
        columns as a CSV file holds them (headers with their units, such as x_mm, and a time column t or time).
        Leave it out to pass the signals as arrays instead.
    model : {'full', 'electrical', 'mechanical'}, optional
        Which parameters to report: all six, R, L, Km only, or m, B, Fl only. Each needs voltage, current
        and position; mechanical also works from force and position alone. Default: full with coil signals,
        mechanical with a force signal.
    forgetting : float, optional
        Exponential forgetting factor lambda in (0, 1]; 1 (default) weighs every sample equally.
    memory_time : float, optional
        Memory time constant tau in s instead of `forgetting` (lambda = 1 - Ts / tau).
    sample_period : float, optional
        Sample period Ts in s of the arrays (required with arrays unless `time` is given; a Recording or file
        carries its own).
    voltage, current, position, force, velocity : array_like, optional
        Uniformly sampled signals of equal length in V, A, m, N and m/s: the coil voltage as applied over each
        sample interval (held), the coil current and the position at the interval's start. A velocity (a
        tachometer's, sampled like the current) serves in place of the position.
    time : array_like, optional
        The arrays' sample times in s, in place of `sample_period` (jitter and gaps read as in a CSV file).
    initial_covariance : float, optional
        Prior covariance of the regression coefficients (P0 = c I).
    points : int, optional
        About how many estimates the convergence trajectory holds.
    spring : bool, optional
        A return spring k x (a flexure, a valve's spring; `spring_stiffness`, N/m, with the load force then the
        total force at x = 0) in the mechanical equation: True always, False never, None (default) where the
        data call for it: where the mechanical equation does not fit without it and the spring explains at
        least SPRING_SHARE of what it leaves (the result's `notes` say so). Coil signals with position only.
    progress : callable, optional
        Called with the fraction of the work done (0..1) as it goes.

    Returns
    -------
    GreyBoxResult
        `parameters` and `std` ({name: value} in SI units: resistance ohm, inductance H, emf_constant V s/m
        = N/A, mass kg, damping N s/m, load_force N), `covariance`, `samples`, and the `trajectory` of the
        estimates over growing parts of the record (the last one is the final estimate); `to_dict()` gives
        the JSON of `emla identify`.

    Raises
    ------
    InputError
        Missing or non-finite signals, too few samples, data that do not excite the model, or an
        unreadable file; the message names the source and the problem.

    Examples
    --------
    >>> from emla_sim.datasets import closed_loop
    >>> recording, truth = closed_loop(duration=0.5)          # simulated closed-loop data, Table 1 actuator
    >>> result = identify(sample_period=recording.sample_period, **recording.signals)
    >>> round(result.parameters['resistance'], 2), round(result.parameters['mass'], 4)
    (4.0, 0.036)
    """
    recording = as_recording(data, sample_period=sample_period, voltage=voltage, current=current,
                             position=position, force=force, velocity=velocity, time=time, gaps=True)
    model_name, kinds, lam = checked(recording, model, forgetting, memory_time)   # model None: the default
    scales = unit_scales(recording)
    report = progress or (lambda done: None)
    with numerical_failures(recording.source, f'the {model_name} model cannot be identified'):
        if recording.gaps:   # in segments: no row spans a gap (segments.py restarts the rows at each)
            identified = identify_segments(_scaled(recording, scales), model_name, kinds, lam, initial_covariance,
                                           points, report, spring, chosen_result)
        else:
            identified = _sprung(_scaled(recording, scales), model_name, kinds, lam, initial_covariance, points,
                                 report, spring)
    return _unscaled(identified, scales)


def chosen(tried, spring):
    """(the (snapshots, ends, final estimate) of `tried`, in the order of spring_options, to report; a note or
    None): the nominal where `spring` is None (auto) and its estimate is sound, else as _choice decides."""
    if len(tried) == 1 or (spring is None and _sound(tried[0][2])):
        return tried[0], None
    return _choice(tried)


def chosen_result(model, snapshots, ends, recording, samples, forgetting, spring=None):
    """The GreyBoxResult (result) of the options' `snapshots` (one list per online_effects.spring_options, all
    after the same rows `ends`) that identify chooses (chosen) from their final estimates, with its note. An
    option whose estimate fails is left out; an InputError where all do."""
    tried, failure = [], None
    for option in snapshots:
        try:
            tried.append((option, ends, final_estimate(model, option[-1], recording, forgetting)))
        except InputError as error:
            failure = error
    if not tried:
        raise failure
    (option, ends, final), note = chosen(tried, spring)
    out = result(model, option, ends, recording, samples, forgetting, final=final)
    if note:
        out.notes.append(note)
    return out


def _sprung(recording, model, kinds, lam, initial_covariance, points, report, spring):
    """The GreyBoxResult with or without the spring's column, as `spring` asks (identify): each candidate's
    final estimate decides, and only the chosen one's trajectory is fitted."""
    options = spring_options(kinds, spring)
    tried, failure = [], None
    for j, columns in enumerate(options):
        def part(done, j=j):
            report((j + done) / (len(options) + 1))
        try:
            snapshots, ends = _snapshots(recording, kinds, lam, initial_covariance, points, part, columns)
            tried.append((snapshots, ends, final_estimate(model, snapshots[-1], recording, lam)))
        except InputError as error:
            failure = error
            continue
        if spring is None and j == 0 and _sound(tried[0][2]):
            break
    if not tried:
        raise failure
    (snapshots, ends, final), note = chosen(tried, spring)
    out = result(model, snapshots, ends, recording, len(recording), lam,
                 lambda j: report((len(options) + (j + 1) / len(ends)) / (len(options) + 1)), final=final)
    if note:
        out.notes.append(note)
    return out


def _physical(final):
    """Whether a final estimate's R, L, m (those it reports) are positive."""
    q = dict(zip(final.names, final.values))
    return all(q.get(name, 1.0) > 0 for name in PHYSICAL)


def _sound(final):
    """Whether a final estimate is finite and physical, and its mechanical equation fits the data."""
    fit = final.fit.get('mechanical')
    return bool(np.all(np.isfinite(final.values))) and _physical(final) and (fit is None or fit.adequate)


def _choice(tried):
    """(the nominal or the sprung of [(snapshots, ends, final)] x 2, a note or None): the spring where the
    nominal gives no sound estimate and the spring explains SPRING_SHARE of what the nominal leaves."""
    nominal, sprung = tried
    before, left = (_ratio(t[2]) for t in tried)
    physical = _physical(nominal[2])
    if not _sound(sprung[2]) or (physical and not left <= (1.0 - SPRING_SHARE) * before):
        return nominal, None
    final = sprung[2]   # the spring's k is the last of all parameters q (also where the model does not report it)
    k, sk = final.q[-1], math.sqrt(final.q_covariance[-1, -1])
    without = (f'{before:.3g} times the sensor noise in its low band' if physical
               else 'impossible parameters')
    return sprung, (f'a return spring is in the mechanical equation: k = {k:.4g} +- {sk:.2g} N/m (the load force is '
                    f'the total force at x = 0); without it the equation left {without}, with it {left:.3g}')


def _ratio(final):
    fit = final.fit.get('mechanical')
    return math.inf if fit is None else fit.ratio


def unit_scales(recording):
    """{'t' or signal: the power of two its values are divided by for the regressions}: 1 within RESCALE_BEYOND
    of TYPICAL, else the power of two nearest to the peak (sample period) over the typical one."""
    def scale(size, typical):
        ratio = size / typical
        return 1.0 if not ratio or 1 / RESCALE_BEYOND <= ratio <= RESCALE_BEYOND else 2.0 ** round(math.log2(ratio))
    scales = {'t': scale(recording.sample_period, TYPICAL['t'])}
    for name, values in recording.signals.items():
        if name in TYPICAL:
            values = np.abs(np.asarray(values, dtype=float))
            scales[name] = scale(float(np.max(values[np.isfinite(values)], initial=0.0)), TYPICAL[name])
    return scales


def parameter_scales(names, scales):
    """The factor each parameter of `names` takes from the signals' `scales` (by its dimension: R in V/A, Km in
    V s/m, m in N s^2/m with N = V A s/m unless a force is measured, ...)."""
    u, i, t = (scales.get(k, 1.0) for k in ('voltage', 'current', 't'))
    x = scales['position'] if 'position' in scales else scales.get('velocity', 1.0) * t
    force = scales['force'] if 'force' in scales else u * i * t / x
    factors = {'resistance': u / i, 'inductance': u * t / i, 'emf_constant': u * t / x, 'mass': force * t * t / x,
               'damping': force * t / x, 'load_force': force, 'spring_stiffness': force / x}
    return np.array([factors[name] for name in names])


def _scaled(recording, scales):
    """The recording in the units of `scales` (itself when they are all 1)."""
    if all(s == 1.0 for s in scales.values()):
        return recording
    return replace(recording, sample_period=recording.sample_period / scales['t'],
                   start_time=recording.start_time / scales['t'],
                   signals={k: np.asarray(v) / scales.get(k, 1.0) for k, v in recording.signals.items()})


def _unscaled(result, scales):
    """A GreyBoxResult of a _scaled recording in SI units again."""
    if all(s == 1.0 for s in scales.values()):
        return result
    factor = dict(zip(result.parameters, parameter_scales(list(result.parameters), scales), strict=True))
    vector, t, trajectory = np.array(list(factor.values())), scales['t'], result.trajectory

    def unscaled(values):
        return {k: v * factor[k] for k, v in values.items()}
    u, force = scales.get('voltage', 1.0), parameter_scales(['load_force'], scales)[0]
    fit = {name: f.scaled(u if name == 'electrical' else force) for name, f in result.fit.items()}
    return replace(result, parameters=unscaled(result.parameters), std=unscaled(result.std), fit=fit,
                   covariance=result.covariance * np.outer(vector, vector), sample_period=result.sample_period * t,
                   trajectory=replace(trajectory, time=trajectory.time * t, parameters=unscaled(trajectory.parameters),
                                      std=unscaled(trajectory.std)))


def _snapshots(recording, kinds, lam, initial_covariance, points, report, columns=()):
    """([{kind: Statistics after rows [0, end)}], ends) for about `points` ends, the last all rows; report(done)
    with the fraction done."""
    source = recording.source or 'recording'
    every = max(1, (len(recording) - HISTORY) // points)
    trajectories = {}  # kind -> [Statistics after rows [0, end) for each end]
    made = regression_rows(recording.signals, kinds, recording.sample_period, columns)
    for j, (kind, (phi, y, zeta)) in enumerate(made.items()):
        nominal = phi[:, :len(COLUMNS[kind])]
        check_excitation(nominal.T @ nominal, kind, source)
        track = offline.trajectory(phi, y, every, instruments=zeta, forgetting=lam,
                                   initial_covariance=initial_covariance)
        ends = track.samples
        moments = RowMoments(phi.shape[1], lam, zeta is not None, tuple(columns))
        z, start = np.column_stack((phi, y)), 0
        trajectories[kind] = []
        for theta, covariance, end in zip(track.theta, track.covariance, ends):
            moments.update(z[start:end], None if zeta is None else zeta[start:end])
            trajectories[kind].append(moments.statistics(theta, covariance))
            start = end
        report((j + 1) / len(kinds))
    return [{kind: trajectory[j] for kind, trajectory in trajectories.items()} for j in range(len(ends))], ends


@dataclass
class FinalEstimate:
    """The estimate from all rows: the reported names, values and covariance, all parameters q and their
    covariance, the fit check."""

    names: tuple
    values: np.ndarray
    covariance: np.ndarray
    q: np.ndarray
    q_covariance: np.ndarray
    fit: dict


def final_estimate(model, statistics, recording, forgetting):
    """The FinalEstimate of `model` from {kind: Statistics} of all rows, its fit started from physical.starts_for
    (so that it does not depend on any trajectory before it) and checked on the recording (fit_check.py)."""
    q, q_covariance = fit(statistics, recording.sample_period)
    names, values, covariance = reported(model, statistics, q, q_covariance)
    checked = _checked_fit(recording, statistics, q, forgetting) if np.all(np.isfinite(q)) else {}
    return FinalEstimate(names, values, covariance, q, q_covariance, checked)


def result(model, snapshots, ends, recording, samples, forgetting, done=lambda j: None, final=None):
    """The GreyBoxResult from {kind: Statistics} after rows [0, end) for each of `ends` (the last: all rows).

    recording: the record or its first part (source, start time, sample period, and the signals the fit is
    checked on, fit_check.py); done(j) after snapshot j. Each snapshot's fit starts from the one before; the last
    is the final estimate (final_estimate, or `final` where it is at hand)."""
    source, ts = recording.source or 'recording', recording.sample_period
    values, stds, q = [], [], None
    for j, statistics in enumerate(snapshots[:-1]):
        q, covariance = fit(statistics, ts, start=q if q is not None and np.all(np.isfinite(q)) else None)
        _, value, covariance = reported(model, statistics, q, covariance)
        values.append(value)
        stds.append(np.sqrt(np.diag(covariance)))
        done(j)
    final = final or final_estimate(model, snapshots[-1], recording, forgetting)
    names, covariance = final.names, final.covariance
    values.append(final.values)
    stds.append(np.sqrt(np.diag(covariance)))
    done(len(snapshots) - 1)
    values, stds = np.array(values), np.array(stds)
    if not np.all(np.isfinite(values[-1])):
        raise InputError(f'{source}: the {model} model gives no finite estimate from these data')
    trajectory = Trajectory(time=recording.start_time + (np.asarray(ends) + HISTORY - 1) * ts,
                            parameters=dict(zip(names, values.T)), std=dict(zip(names, stds.T)))
    return GreyBoxResult(model=model, parameters={k: float(v) for k, v in zip(names, values[-1])},
                         std={k: float(s) for k, s in zip(names, stds[-1])}, covariance=covariance,
                         samples=samples, sample_period=ts, forgetting=forgetting, trajectory=trajectory,
                         fit=final.fit)


def _checked_fit(recording, statistics, q, forgetting):
    """fit_check.check_fit on the record (with forgetting: on its last MEMORY_SPANS memory times, which the final
    estimate describes); {} when too few samples are at hand."""
    signals = recording.signals
    keep = len(recording) if forgetting == 1.0 else int(MEMORY_SPANS / (1.0 - forgetting))
    signals = {name: np.asarray(values)[-keep:] for name, values in signals.items()}
    if min(len(v) for v in signals.values()) < MIN_FIT_SAMPLES:
        return {}
    return check_fit(signals, statistics, q, recording.sample_period)
