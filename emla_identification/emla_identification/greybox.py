"""Physical EMLA parameters (R, L, Km, m, B, Fl) from the regressions of regressors.py.

Each regression is solved by exponentially weighted least squares, the electrical one by instrumental
variables (regressors.instruments; whole recordings: offline.py; streams: rls.py, see online.py). Its state
(theta and P, the inverse of its normal equations' matrix) holds those equations completely, so the
coefficient that depends on h = R Ts / L (see regressors.py) is tied afterwards: the equations are solved
for the reduced coefficients with that tie, for h from the electrical estimate, a few times until h
settles. Stream and batch therefore give the same parameters from the same samples.

Uncertainties are one-sigma. The residuals are far from white (differencing the quantised position colours
them), so sigma2 P would misstate them badly; they come from a noise model instead: white noise on each
measured signal, carried through the rows, with variances fitted to the residual autocovariances
(_noise_variances), and the sandwich covariance that noise gives the weighted estimate
(_coefficient_covariances), from lagged moments of the rows and the instruments kept alongside the
least-squares state (LagMoments). The
delta method carries it to the physical parameters, the regressions taken as independent. On the test data
the reported values match the scatter over noise realisations to within some 50 %.
"""
import functools
import itertools
from dataclasses import dataclass, field

import numba
import numpy as np

from emla_core.errors import InputError
from emla_core.parameters import PARAMETER_NAMES

from . import offline
from .regressors import (COLUMNS, HISTORY, SIGNALS, default_model, emf_lag, instruments, noise_stencils,
                         regressions_for, rows, tie)
from .rls import forgetting_factor

MODEL_PARAMETERS = {
    'electrical': ('resistance', 'inductance', 'emf_constant'),
    'mechanical': ('mass', 'damping', 'load_force'),
    'full': PARAMETER_NAMES,
}
MIN_ROWS = 16           # regression rows (samples - HISTORY) below which a record is too short
_TIE_ITERATIONS = 6     # h settles to rounding level in 3-5 (the tie depends on h only through eta ~ h/12)
_MAX_CONDITION = 1e12   # normalised information matrix above this: a parameter is not excited


class LagMoments:
    """The squared-weight moments the noise model needs, over a stream of rows z = [phi, y] in any frames:
    moments[d] = sum_k w_k^2 z_k z_(k-d)' for d = 0 .. HISTORY and weight = sum_k w_k^2, with the least-squares
    weights w_k = lambda^(N-k) (a weighted estimate's error sum_k w_k phi_k e_k has w^2 in its covariance)."""

    def __init__(self, width, forgetting=1.0):
        self.forgetting = forgetting
        self.moments = np.zeros((HISTORY + 1, width, width))
        self.weight = 0.0
        self._tail = np.zeros((HISTORY, width))  # zero rows before the first contribute nothing

    def update(self, z):
        m = len(z)
        if m == 0:
            return
        z = np.asarray(z, dtype=float)
        if self.forgetting == 1.0:
            weights = np.empty(0)
            self.weight += m
        else:
            squared = self.forgetting ** 2
            weights = squared ** np.arange(m - 1, -1, -1.0)
            self.moments *= squared ** m
            self.weight = squared ** m * self.weight + weights.sum()
        _lag_products(self._tail, z, weights, self.moments)
        self._tail = np.concatenate((self._tail, z[-HISTORY:]))[-HISTORY:]


class RowMoments:
    """The LagMoments a regression's noise model needs, kept beside its estimator: of its rows z = [phi, y] and,
    if it is solved by instrumental variables, of its instruments. statistics() adds the estimator's state."""

    def __init__(self, n, forgetting=1.0, instrumented=False):
        self.rows = LagMoments(n + 1, forgetting)
        self.instruments = LagMoments(n, forgetting) if instrumented else None

    def update(self, z, zeta=None):
        """Rows z (m x (n + 1)) and, if instrumented, their instruments zeta (m x n)."""
        self.rows.update(z)
        if self.instruments is not None:
            self.instruments.update(zeta)

    def statistics(self, theta, covariance):
        return Statistics(theta, covariance, self.rows.moments.copy(), self.rows.weight, self.rows.forgetting,
                          None if self.instruments is None else self.instruments.moments.copy())


_TILE = 512  # rows per tile of _lag_products: a tile's columns stay in the first-level cache


@numba.njit(cache=True, fastmath={'reassoc', 'contract'})  # reassociated sums: vectorised dot products
def _lag_products(tail, z, weights, moments):
    """moments[d] += sum_k weights_k z_k z_(k-d)' over the rows z_k of z, tail holding the HISTORY rows before
    (weights empty: all ones). Tile by tile, the rows are copied into columns: contiguous dot products."""
    m, width = z.shape
    ahead = np.empty((width, _TILE))
    behind = np.empty((width, _TILE + HISTORY))  # the tile's rows with the HISTORY before them
    for start in range(0, m, _TILE):
        n = min(_TILE, m - start)
        for k in range(n + HISTORY):
            row = z[start - HISTORY + k] if start - HISTORY + k >= 0 else tail[k]
            for i in range(width):
                behind[i, k] = row[i]
        if weights.size:
            for i in range(width):
                for k in range(n):
                    ahead[i, k] = weights[start + k] * behind[i, HISTORY + k]
        for i in range(width):
            a = ahead[i, :n] if weights.size else behind[i, HISTORY:HISTORY + n]
            for d in range(HISTORY + 1):
                for j in range(width):
                    b = behind[j, HISTORY - d:HISTORY - d + n]
                    total = 0.0
                    for k in range(n):
                        total += a[k] * b[k]
                    moments[d, i, j] += total


@dataclass(frozen=True)
class Statistics:
    """State of one regression: theta and P (unscaled) as rls.py and offline.py keep them, and the LagMoments
    (moments, weight) of its rows z = [phi, y] for the noise model, and of its instruments (None: least
    squares, the regressors are the instruments)."""

    theta: np.ndarray
    covariance: np.ndarray
    lags: np.ndarray
    weight: float
    forgetting: float
    instrument_moments: np.ndarray = None

    @functools.cached_property
    def information(self):
        """The normal equations' matrix: sum w phi phi' (least squares) or sum w zeta phi' (instruments)."""
        return np.linalg.inv(self.covariance)

    def restrict(self, T):
        """theta_r solving the same normal equations with coefficients T' theta_r (T's rows combine them)."""
        return np.linalg.solve(T @ self.information @ T.T, T @ self.information @ self.theta)

    def residual_products(self, T, theta):
        """sum_k w_k^2 r_k r_(k-d), d = 0 .. HISTORY, of the residuals with coefficients T' theta."""
        a = np.append(-(T.T @ theta), 1.0)
        return self.lags @ a @ a

    @functools.cached_property
    def instrument_lags(self):
        """[S_0, S_1, ..]: S_0 = sum w^2 zeta_k zeta_k', S_d = sum w^2 zeta_k zeta_(k-d)' + its transpose (zeta:
        the instruments, or the regressors phi under least squares)."""
        n = len(self.theta)
        ahead = self.lags[:, :n, :n] if self.instrument_moments is None else self.instrument_moments
        return np.concatenate((ahead[:1], ahead[1:] + np.swapaxes(ahead[1:], 1, 2)))


def _log_decay(alpha):
    """h = -ln(alpha), NaN unless 0 < alpha < 1 (elementwise)."""
    return np.where((alpha > 0.0) & (alpha < 1.0), -np.log(np.where(alpha > 0.0, alpha, 1.0)), np.nan)


def coil_parameters(vector, sample_period):
    """R, L, Km, m, B, Fl from [alpha, beta, gamma, Km/m, B/m, Fl/m] along the last axis of `vector`."""
    alpha, beta, gamma, km_over_m, b_over_m, fl_over_m = np.moveaxis(vector, -1, 0)
    h = _log_decay(alpha)
    resistance = (1.0 - alpha) / beta
    km = gamma / beta
    # the intra-sample back-EMF rise acts as the extra mass Km^2 eta Ts / R (regressors.py)
    mass = km / km_over_m + km * km * emf_lag(h) * sample_period / resistance
    return np.stack([resistance, resistance * sample_period / h, km, mass, km * b_over_m / km_over_m,
                     km * fl_over_m / km_over_m], axis=-1)


def force_parameters(vector, sample_period):
    """m, B, Fl from [1/m, B/m, Fl/m] along the last axis."""
    inverse_mass, b_over_m, fl_over_m = np.moveaxis(vector, -1, 0)
    return np.stack([1.0 / inverse_mass, b_over_m / inverse_mass, fl_over_m / inverse_mass], axis=-1)


def _propagate(function, vector, covariance, sample_period):
    """function(vector) and its covariance J C J' (central differences at a fraction of each sigma)."""
    sigma = np.sqrt(np.abs(np.diag(covariance)))
    steps = np.where(np.isfinite(sigma) & (sigma > 0), 1e-4 * sigma, 1e-8 * (np.abs(vector) + 1e-12))
    shifts = np.diag(steps)
    points = function(np.concatenate((vector[None], vector + shifts, vector - shifts)), sample_period)
    n = len(vector)
    jacobian = ((points[1:n + 1] - points[n + 1:]) / (2.0 * steps[:, None])).T
    return points[0], jacobian @ covariance @ jacobian.T


def physical(model, statistics, sample_period):
    """(names, values, covariance) of `model`'s parameters from {regression kind: Statistics}."""
    with np.errstate(all='ignore'):
        restricted = _restricted(statistics)
        variances = _noise_variances(statistics, restricted, sample_period)
        covariances = _coefficient_covariances(statistics, restricted, variances, sample_period)
        vector = np.concatenate([theta for _, theta in restricted.values()])
        covariance = np.zeros((len(vector), len(vector)))
        start = 0
        for part in covariances.values():  # the regressions' coefficients taken as independent
            covariance[start:start + len(part), start:start + len(part)] = part
            start += len(part)
        names, function = _parameter_function(statistics)
        values, covariance = _propagate(function, vector, covariance, sample_period)
    keep = [names.index(n) for n in MODEL_PARAMETERS[model]]
    return MODEL_PARAMETERS[model], values[keep], covariance[np.ix_(keep, keep)]


def physical_values(model, statistics, sample_period):
    """(names, values) as physical() gives them, without the noise model and the uncertainties."""
    with np.errstate(all='ignore'):
        vector = np.concatenate([theta for _, theta in _restricted(statistics).values()])
        names, function = _parameter_function(statistics)
        values = function(vector[None], sample_period)[0]
    return MODEL_PARAMETERS[model], values[[names.index(n) for n in MODEL_PARAMETERS[model]]]


def _parameter_function(statistics):
    """(parameter names, function of the restricted coefficients) for these regressions."""
    if 'force' in statistics:
        return MODEL_PARAMETERS['mechanical'], force_parameters
    return PARAMETER_NAMES, coil_parameters


def _restricted(statistics):
    """{kind: (T, theta_r)}: each regression with its h-dependent coefficient tied, h from the electrical one."""
    if 'force' in statistics:
        T = tie('force', 0.0)
        return {'force': (T, statistics['force'].restrict(T))}
    electrical = statistics['electrical']
    h = _log_decay(electrical.theta[0])
    for _ in range(_TIE_ITERATIONS):
        T = tie('electrical', h)
        restricted = {'electrical': (T, electrical.restrict(T))}
        h, previous = _log_decay(restricted['electrical'][1][0]), h
        if abs(h - previous) <= 1e-13 * h:
            break
    T = tie('mechanical', h)
    restricted['mechanical'] = T, statistics['mechanical'].restrict(T)
    return restricted


def _noise_filters(kind, T, theta, sample_period):
    """{signal: c}: the residual of row k with coefficients T' theta gets sum_j c_j (noise of sample k - 2 + j)."""
    coefficients = T.T @ theta
    return {name: dy - dphi @ coefficients for name, (dy, dphi) in noise_stencils(kind, sample_period).items()}


def _autocorrelation(c):
    return np.correlate(c, c, 'full')[HISTORY:]  # lags 0 .. HISTORY


def _noise_variances(statistics, restricted, sample_period):
    """{signal: variance} of white noise on the measured signals, fitted to the residual autocovariances.

    Noise on each sample reaches the residuals through the rows' construction (regressors.noise_stencils);
    the variances that explain the residuals' autocovariances at lags 0 .. HISTORY best are found by
    non-negative least squares, shared by all regressions of the model (the same sensors feed them all).
    """
    sources = sorted({name for kind in restricted for name in noise_stencils(kind, sample_period)})
    equations, targets = [], []
    for kind, (T, theta) in restricted.items():
        stats = statistics[kind]
        filters = _noise_filters(kind, T, theta, sample_period)
        products = stats.residual_products(T, theta)
        scale = 1.0 / products[0] if products[0] > 0 else 0.0  # each regression's equations in its own units
        equations.append(scale * stats.weight * np.column_stack(
            [_autocorrelation(filters[name]) if name in filters else np.zeros(HISTORY + 1) for name in sources]))
        targets.append(scale * products)
    return dict(zip(sources, _nonnegative_least_squares(np.concatenate(equations), np.concatenate(targets))))


def _coefficient_covariances(statistics, restricted, variances, sample_period):
    """{kind: covariance of its restricted coefficients} under the fitted white noise.

    The residuals are coloured (the second difference of the quantised position dominates the mechanical
    one; sigma2 P would overstate B's uncertainty some 60 times), so the covariance is the sandwich
    P_r (sum_s sigma_s^2 sum_i psi_i psi_i') P_r': the error sum_k w_k zeta_r,k e_k gets the noise of sample i
    through psi_i = sum_j c_j w_k zeta_r,k (k = i + 2 - j, c the signal's noise filter; zeta the instruments,
    phi under least squares). Expanded, that is sum_d lambda^d g_d S_d over the LagMoments, g the
    autocorrelation of c; it cancels to what is left at low frequency exactly, so it stays positive
    semi-definite.
    """
    covariances = {}
    for kind, (T, theta) in restricted.items():
        stats = statistics[kind]
        decay = stats.forgetting ** np.arange(HISTORY + 1)
        middle = sum(variances[name] * np.einsum('d,dij->ij', decay * _autocorrelation(c), stats.instrument_lags)
                     for name, c in _noise_filters(kind, T, theta, sample_period).items())
        inverse = np.linalg.inv(T @ stats.information @ T.T)
        covariances[kind] = inverse @ T @ middle @ T.T @ inverse.T
    return covariances


def _nonnegative_least_squares(A, b):
    """argmin |A x - b| with x >= 0 for a few columns: the plain solution if it is non-negative, else the best
    non-negative one on fewer free columns."""
    candidates = []
    for free in sorted(itertools.product((True, False), repeat=A.shape[1]), key=sum, reverse=True):
        x = np.zeros(A.shape[1])
        if any(free):
            x[list(free)] = np.linalg.lstsq(A[:, list(free)], b, rcond=None)[0]
        if np.all(x >= 0):
            if all(free):
                return x
            candidates.append((np.sum((A @ x - b) ** 2), x))
    return min(candidates, key=lambda c: c[0])[1]


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
    trajectory: Trajectory = field(repr=False, default=None)

    def to_dict(self):
        """The `emla identify` JSON object."""
        return {'model': self.model, 'samples': self.samples, 'sample_period': self.sample_period,
                'parameters': dict(self.parameters), 'std': dict(self.std)}


def identify(recording, model=None, forgetting=1.0, *, initial_covariance=1e6, points=200, progress=None):
    """Grey-box parameters of a whole Recording (default model: full for coil signals, mechanical for force).

    The result's trajectory holds the estimates after about `points` growing parts of the record (the
    last one is the final estimate), for convergence plots. progress: None or a function called with the
    fraction of the work done (0..1) as it goes.
    """
    model, kinds, lam = _checked(recording, model, forgetting)
    source = recording.source or 'recording'
    report = progress or (lambda fraction: None)
    n, ts = len(recording), recording.sample_period
    every = max(1, (n - HISTORY) // points)
    trajectories = {}  # kind -> [Statistics after rows [0, end) for each end]
    for j, kind in enumerate(kinds):
        phi, y = rows(kind, recording.signals, ts)
        zeta = instruments(kind, recording.signals, ts)
        _check_excitation(phi.T @ phi, kind, source)
        track = offline.trajectory(phi, y, every, instruments=zeta, forgetting=lam,
                                   initial_covariance=initial_covariance)
        ends = track.samples
        moments, z, start = RowMoments(phi.shape[1], lam, zeta is not None), np.column_stack((phi, y)), 0
        trajectories[kind] = []
        for theta, covariance, end in zip(track.theta, track.covariance, ends):
            moments.update(z[start:end], None if zeta is None else zeta[start:end])
            trajectories[kind].append(moments.statistics(theta, covariance))
            start = end
        report((j + 1) / (len(kinds) + 1))
    snapshots = [{kind: trajectory[j] for kind, trajectory in trajectories.items()} for j in range(len(ends))]
    return _result(model, snapshots, ends, recording, n, lam,
                   lambda j: report((len(kinds) + (j + 1) / len(ends)) / (len(kinds) + 1)))


def _result(model, snapshots, ends, recording, samples, forgetting, done=lambda j: None):
    """The GreyBoxResult from {kind: Statistics} after rows [0, end) for each of `ends` (the last: all rows).

    recording: the record or its first part (source, start time, sample period); done(j) after snapshot j."""
    source, ts = recording.source or 'recording', recording.sample_period
    values, stds = [], []
    for j, statistics in enumerate(snapshots):
        names, value, covariance = physical(model, statistics, ts)
        values.append(value)
        stds.append(np.sqrt(np.diag(covariance)))
        done(j)
    values, stds = np.array(values), np.array(stds)
    if not np.all(np.isfinite(values[-1])):
        raise InputError(f'{source}: the {model} model gives no finite estimate from these data')
    trajectory = Trajectory(time=recording.start_time + (np.asarray(ends) + HISTORY - 1) * ts,
                            parameters=dict(zip(names, values.T)), std=dict(zip(names, stds.T)))
    return GreyBoxResult(model=model, parameters={k: float(v) for k, v in zip(names, values[-1])},
                         std={k: float(s) for k, s in zip(names, stds[-1])}, covariance=covariance,
                         samples=samples, sample_period=ts, forgetting=forgetting, trajectory=trajectory)


def _checked(recording, model, forgetting):
    """(model, regression kinds, lambda) for this recording, or InputError naming its source and the problem."""
    model, kinds, lam = _setup(recording, model, forgetting)
    _check_finite(recording, kinds)
    _check_length(len(recording), model, recording.source)
    return model, kinds, lam


def _setup(recording, model, forgetting):
    """(model, regression kinds, lambda) for the signals of `recording` (all of it, or its first part)."""
    source = recording.source or 'recording'
    model = model or default_model(recording.signals)
    if model is None:
        raise InputError(f'{source}: needs columns voltage, current, position (or force, position); '
                         f'has {", ".join(recording.signals) or "none"}')
    try:
        kinds = regressions_for(model, recording.signals)
        lam = forgetting_factor(forgetting)
    except ValueError as exc:
        raise InputError(f'{source}: {exc}') from None
    return model, kinds, lam


def _check_finite(recording, kinds, first=0):
    """InputError at the first non-finite sample of the signals `kinds` use; `first`: index of sample 0."""
    for name in sorted({s for kind in kinds for s in SIGNALS[kind]}):
        bad = ~np.isfinite(recording.signals[name])
        if bad.any():
            raise InputError(f'{recording.source or "recording"}: non-finite {name} at sample '
                             f'{first + int(np.argmax(bad))}')


def _check_length(samples, model, source):
    if samples - HISTORY < MIN_ROWS:
        raise InputError(f'{source or "recording"}: {samples} samples are too few for the {model} model '
                         f'(needs at least {MIN_ROWS + HISTORY})')


def _check_excitation(gram, kind, source):
    """InputError when the regressors do not excite every coefficient (e.g. the actuator never moved); gram:
    sum of phi phi' over the rows."""
    scale = np.sqrt(np.diag(gram))
    if np.any(scale == 0) or np.linalg.cond(gram / np.outer(scale, scale)) > _MAX_CONDITION:
        raise InputError(f'{source}: the data do not excite the {kind} equation enough to identify '
                         f'{", ".join(COLUMNS[kind])}')
