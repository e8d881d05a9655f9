"""Exponentially weighted least squares over whole recordings, chunk by chunk.

The batch form of rls.py's recursion: after N samples, with z_k = [phi_k, y_k] and the prior (theta0, P0),

    S_N = lambda^N S_0 + sum_k lambda^(N-k) z_k z_k',   S_0 = [[P0^-1, P0^-1 theta0], [., theta0' P0^-1 theta0]]

holds the information matrix R (top-left n x n), the vector r (last column) and the weighted sum of y^2
(corner); theta_N = R^-1 r equals the unguarded recursion's estimate, P_N = R^-1 its covariance, and
S_yy - r' theta_N its weighted residual sum of squares. Rows are read in chunks of at most 65536;
S is carried across chunks as S <- lambda^m S + (chunk sum weighted relative to the chunk's end). A chunk
is short enough that lambda^-m <= e^300, so no intermediate overflows; weights that underflow belong to
samples forgotten long ago (lambda^N itself underflows harmlessly on long records). WeightedAccumulator
carries S the same way across chunks its caller feeds, for records that are never whole in memory.

With instruments zeta_k (instrumental variables, rls.py) the rows are z_k = [phi_k, y_k, zeta_k] and S holds
sum_k lambda^(N-k) z_k [phi_k, y_k]' (the prior's P0^-1 in the zeta-phi block too): theta_N solves the
zeta rows' normal equations A theta = b, P_N = A^-1, as the instrumented recursion gives them.

Inputs must be finite (ValueError otherwise); RecursiveLeastSquares instead skips non-finite samples.
"""

import math
from dataclasses import dataclass

import numpy as np

from .rls import check_instruments, check_order, check_regression, forgetting_factor, prior

_CHUNK_ROWS = 65536
_MAX_BLOCKS = 4096      # bounds the (blocks, n+1, n+1) intermediates of trajectory()
_MAX_LOG_DECAY = 300.0  # a chunk of m rows keeps lambda^-m <= e^300


@dataclass(frozen=True)
class WeightedEstimate:
    """Estimate after `samples` rows; with a leading axis when it is a trajectory."""

    samples: np.ndarray | int
    theta: np.ndarray
    covariance: np.ndarray  # P = R^-1, unscaled, as RecursiveLeastSquares.covariance
    residual_variance: np.ndarray | float  # weighted RSS / (effective samples - n), NaN when undefined

    @property
    def std(self):
        """sqrt(diag(sigma2 P)), as RecursiveLeastSquares.parameter_std()."""
        diag = np.diagonal(self.covariance, axis1=-2, axis2=-1)
        return np.sqrt(np.asarray(self.residual_variance)[..., None] * diag)


def weighted_least_squares(Phi, Y, *, instruments=None, forgetting=1.0, memory_time=None, sample_period=None,
                           initial_covariance=1e6, initial_theta=None):
    """The estimate after all rows of Phi (N x n) and Y (N,); instruments: None or N x n (see the module doc)."""
    samples, S, lam = _accumulate(Phi, Y, instruments, None, forgetting, memory_time, sample_period,
                                  initial_covariance, initial_theta)
    return _solve(samples[-1], S[-1], lam)


def trajectory(Phi, Y, every, *, instruments=None, forgetting=1.0, memory_time=None, sample_period=None,
               initial_covariance=1e6, initial_theta=None):
    """Estimates after every `every` rows and after the last row (samples = every, 2 every, ..., N).

    Memory grows with N / every (one (n+1) x (n+1) matrix per estimate), not with N."""
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f'every must be a positive integer, got {every!r}')
    return _solve(*_accumulate(Phi, Y, instruments, int(every), forgetting, memory_time, sample_period,
                               initial_covariance, initial_theta))


class WeightedAccumulator:
    """weighted_least_squares fed chunk by chunk: add rows as they come, estimate() at any time.

    Holds S only ((n+1) x (n+1), or (2n+1) x (n+1) with instruments), carried across chunks as within one;
    estimate() equals weighted_least_squares on all rows added so far, to rounding."""

    def __init__(self, n, *, instrumented=False, forgetting=1.0, memory_time=None, sample_period=None,
                 initial_covariance=1e6, initial_theta=None):
        self.n = check_order(n)
        self.forgetting = forgetting_factor(forgetting, memory_time, sample_period)
        self._S = _initial_state(self.n, initial_covariance, initial_theta, instrumented)
        self.samples = 0

    def add(self, Phi, Y, instruments=None):
        """Rows Phi (m x n), outputs Y (m,) and, if instrumented, the instruments (m x n)."""
        Phi, Y = check_regression(Phi, Y, self.n)
        self._add(len(Y), _stacker(Phi, Y, instruments))

    def add_stacked(self, Z):
        """Rows z = [phi, y] (or [phi, y, zeta] if instrumented) as one array (no copy of the rows is made)."""
        Z = np.asarray(Z, dtype=float)
        if Z.ndim != 2 or Z.shape[1] != self._S.shape[0]:
            raise ValueError(f'stacked rows must be an (m, {self._S.shape[0]}) array, got shape {Z.shape}')
        self._add(len(Z), lambda start, stop: Z[start:stop])

    def _add(self, m, stacked):
        if m:
            _, S = _stacked_states(stacked, m, self.forgetting, self._S, m)
            self._S = S[-1]
            self.samples += m

    def estimate(self):
        """The WeightedEstimate after the rows added so far."""
        return _solve(self.samples, self._S, self.forgetting)


def _accumulate(Phi, Y, instruments, every, forgetting, memory_time, sample_period, initial_covariance,
                initial_theta):
    """(samples, S, lambda) at the block ends; every=None: one block, the whole record."""
    Phi = np.asarray(Phi, dtype=float)
    if Phi.ndim != 2 or Phi.shape[1] < 1:
        raise ValueError(f'regressors must be an (N, n) array with n >= 1, got shape {Phi.shape}')
    n = Phi.shape[1]
    Phi, Y = check_regression(Phi, Y, n)
    lam = forgetting_factor(forgetting, memory_time, sample_period)
    S0 = _initial_state(n, initial_covariance, initial_theta, instruments is not None)
    if len(Y) == 0:
        return np.zeros(1, dtype=np.int64), S0[None], lam
    return (*_stacked_states(_stacker(Phi, Y, instruments), len(Y), lam, S0, every or len(Y)), lam)


def _initial_state(n, initial_covariance, initial_theta, instrumented=False):
    """S_0 of the prior (theta0, P0)."""
    theta0, P0 = prior(n, initial_covariance, initial_theta)
    R0 = np.linalg.inv(P0)
    S0 = np.empty((2 * n + 1 if instrumented else n + 1, n + 1))
    S0[:n, :n] = R0
    S0[:n, n] = S0[n, :n] = R0 @ theta0
    S0[n, n] = theta0 @ R0 @ theta0
    if instrumented:
        S0[n + 1:] = S0[:n]  # the prior's rows for the instruments
    return S0


def _stacker(Phi, Y, instruments=None):
    """stacked(start, stop): rows [start, stop) as one array of z = [phi, y] or [phi, y, zeta]."""
    n = Phi.shape[1]
    if instruments is not None:
        instruments = check_instruments(instruments, Phi)

    def stacked(start, stop):
        Z = np.empty((stop - start, n + 1 if instruments is None else 2 * n + 1))
        Z[:, :n] = Phi[start:stop]
        Z[:, n] = Y[start:stop]
        if instruments is not None:
            Z[:, n + 1:] = instruments[start:stop]
        return Z
    return stacked


def _stacked_states(stacked, N, lam, S0, every):
    """S after rows [0, k) for k = every, 2 every, ..., N, the rows z given as stacked(start, stop) -> the
    (stop - start, width of S0) array of rows."""
    span = _CHUNK_ROWS if lam == 1.0 else max(1, min(_CHUNK_ROWS, int(_MAX_LOG_DECAY / -math.log(lam))))
    # chunks hold whole blocks when blocks are short; long blocks span chunks, which then end on block ends
    rows = every * min(span // every, _MAX_BLOCKS) if every <= span else span
    group = min(every, rows)
    # weights[-m:]: m rows weighted relative to the last; None: all ones (no forgetting)
    weights = None if lam == 1.0 else lam ** np.arange(group - 1, -1, -1.0)
    S, ends, states = S0, [], []
    start = 0
    while start < N:
        stop = min(start + rows, N, (start // every + 1) * every if every > rows else N)
        Z = stacked(start, stop)
        if not np.isfinite(Z).all():  # (the row-wise test only then: all(axis=1) over n + 1 columns is slow)
            finite = np.isfinite(Z).all(axis=1)
            raise ValueError(f'non-finite regressor or output in row {start + int(np.argmin(finite))}')
        C, group_ends = _group_sums(Z, S0.shape[1], group, weights)
        decay = (lam ** group_ends)[:, None, None]  # from the chunk start to each group end
        Sg = decay * (S + np.cumsum(C / decay, axis=0))
        group_ends += start
        keep = (group_ends % every == 0) | (group_ends == N)
        ends.append(group_ends[keep])
        states.append(Sg[keep])
        S, start = Sg[-1], stop
    return np.concatenate(ends), np.concatenate(states)


def _group_sums(Z, columns, group, weights):
    """Weighted sums of z z[:columns]' over consecutive groups of `group` rows (last one shorter), and the
    group ends."""
    m = Z.shape[0]
    full = m // group
    sums, ends = [], []
    if full:
        Zf = Z[:full * group].reshape(full, group, -1)
        sums.append(np.matmul(_weighted(Zf, weights).transpose(0, 2, 1), Zf[..., :columns]))
        ends.append(np.arange(1, full + 1) * group)
    if m > full * group:
        Zp = Z[full * group:]
        sums.append((_weighted(Zp, weights).T @ Zp[:, :columns])[None])
        ends.append(np.array([m]))
    return np.concatenate(sums), np.concatenate(ends)


def _weighted(Z, weights):
    """Rows (along the second-last axis) times the last len(rows) weights."""
    return Z if weights is None else Z * weights[-Z.shape[-2]:, None]


def _solve(samples, S, lam):
    n = S.shape[-1] - 1
    R, r, yy = S[..., :n, :n], S[..., :n, n], S[..., n, n]
    A, b = (S[..., n + 1:, :n], S[..., n + 1:, n]) if S.shape[-2] > n + 1 else (R, r)
    try:
        P = np.linalg.inv(A)
        theta = np.linalg.solve(A, b[..., None])[..., 0]
    except np.linalg.LinAlgError:
        raise ValueError('singular information matrix: the regressors do not excite all parameters') from None
    if A is R:  # S_yy - r' theta: the weighted RSS at its minimum
        rss = yy - np.einsum('...i,...i', r, theta)
    else:
        rss = yy - 2.0 * np.einsum('...i,...i', r, theta) + np.einsum('...i,...ij,...j', theta, R, theta)
    rss = np.maximum(rss, 0.0)
    effective = samples if lam == 1.0 else -np.expm1(samples * math.log(lam)) / (1.0 - lam)
    dof = np.asarray(effective - n, dtype=float)
    variance = np.divide(rss, dof, out=np.full(dof.shape, np.nan), where=dof > 0)
    if np.ndim(samples) == 0:
        samples, variance = int(samples), float(variance)
    return WeightedEstimate(samples=samples, theta=theta, covariance=P, residual_variance=variance)
