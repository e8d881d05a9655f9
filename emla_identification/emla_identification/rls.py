"""Recursive least squares with exponential forgetting (covariance form).

The recursion is the one of the DC motor paper (physics.md), for y = phi' theta + noise:

    e     = y - phi' theta                 a-priori prediction error
    g     = P phi,   d = lambda + phi' g
    theta = theta + g e / d
    P     = (P - g g' / d) / lambda

After N samples theta minimises

    sum_k lambda^(N-k) (y_k - phi_k' theta)^2 + lambda^N (theta - theta0)' P0^-1 (theta - theta0)

and P = (lambda^N P0^-1 + sum_k lambda^(N-k) phi_k phi_k')^-1, the inverse of the weighted information
matrix; offline.py computes the same solution in batch.

Instrumental variables: given instruments zeta_k (update_block's `instruments`), g = P zeta and
P = (P - g phi' P / d) / lambda with d = lambda + phi' g. Then theta solves the weighted normal equations
with zeta in place of phi on the left, (lambda^N P0^-1 + sum_k lambda^(N-k) zeta_k phi_k') theta = lambda^N
P0^-1 theta0 + sum_k lambda^(N-k) zeta_k y_k, and P is that matrix's inverse (not symmetric). It is consistent
where noise in the regressors is correlated with the error (closed loop) and the instruments are not.

Covariance semantics: `covariance` is P itself (unscaled). The parameter covariance is sigma2 P
(`parameter_covariance()`, `parameter_std()`), sigma2 being the weighted residual sum of squares
divided by (effective samples - n). For lambda = 1 this is the usual least-squares covariance; for
lambda < 1 and stationary data the actual sampling covariance is about sigma2 P / (1 + lambda), so the
reported std is conservative by about sqrt(2).

Wind-up guard: without excitation forgetting makes P grow like lambda^-k. The forgetting actually
applied is lambda_k = clip(lambda trace(P) / limit, lambda, 1): plain lambda while trace(P) <= limit,
less above it, none from limit / lambda on, so trace(P) never exceeds max(limit, trace(P0)) / lambda.
The default limit is trace(P0), which excitation keeps P far below, so the guard is then inactive and
the recursion is exactly the exponentially weighted one. The default bounds P but still lets unexcited
directions drift back to the prior's uncertainty; an identifier that idles for long stretches should set
the limit to a few times the trace P has under normal excitation.
"""

import math

import numba
import numpy as np
from numpy.typing import ArrayLike

MIN_MEMORY = 2.0   # samples: the shortest memory 1 / (1 - lambda) a forgetting factor may have


@numba.njit(cache=True)
def _rls_kernel(theta, P, stats, Phi, Y, Zeta, instrumented, lam, limit, adapt, errors):
    """Run the recursion over the rows of Phi, Y in place; stats = [weighted RSS, effective samples, samples].

    Zeta: the instruments if `instrumented` (g = P zeta, P -= g (P' phi)' / d), else Phi itself (least squares:
    one triangle of P is computed and mirrored, which keeps P exactly symmetric)."""
    n = theta.shape[0]
    g = np.empty(n)
    h = np.empty(n)
    for k in range(Phi.shape[0]):
        e = Y[k]
        z = 0.0
        for i in range(n):
            e -= Phi[k, i] * theta[i]
            z += Zeta[k, i]
        if not (np.isfinite(e) and np.isfinite(z)):  # a non-finite sample is skipped, as if absent
            errors[k] = np.nan
            continue
        errors[k] = e
        if not adapt:
            continue
        q = 0.0
        trace = 0.0
        for i in range(n):
            s = 0.0
            t = 0.0
            for j in range(n):
                s += P[i, j] * Zeta[k, j]
                if instrumented:
                    t += P[j, i] * Phi[k, j]
            g[i] = s
            h[i] = t if instrumented else s
            q += Phi[k, i] * s
            trace += P[i, i]
        lam_k = min(1.0, max(lam, lam * trace / limit))
        d = lam_k + q
        for i in range(n):
            theta[i] += g[i] * (e / d)
            for j in range(0 if instrumented else i, n):
                p = (P[i, j] - g[i] * h[j] / d) / lam_k
                P[i, j] = p
                if not instrumented:
                    P[j, i] = p
        stats[0] = lam_k * stats[0] + e * e * (lam_k / d)  # e times the a-posteriori error
        stats[1] = lam_k * stats[1] + 1.0
        stats[2] += 1.0


def forgetting_factor(forgetting=1.0, memory_time=None, sample_period=None):
    """lambda from a forgetting factor, or from a memory time constant tau: lambda = 1 - Ts / tau.

    The memory 1 / (1 - lambda) must be at least MIN_MEMORY samples (lambda >= 0.5): with less, the weights
    lambda^k underflow within a few hundred samples and the information matrix is as good as singular."""
    if memory_time is None:
        lam = float(forgetting)
        if not 1.0 - 1.0 / MIN_MEMORY <= lam <= 1.0:
            raise ValueError(f'forgetting factor must be in [{1.0 - 1.0 / MIN_MEMORY:g}, 1] (a memory '
                             f'1/(1 - lambda) of at least {MIN_MEMORY:g} samples), got {forgetting!r}')
        return lam
    if forgetting != 1.0:
        raise ValueError('give either a forgetting factor or a memory time, not both')
    tau = float(memory_time)
    if sample_period is None:
        raise ValueError('a memory time needs the sample period')
    ts = float(sample_period)
    if not 0.0 < ts < math.inf:
        raise ValueError(f'sample period must be positive and finite, got {sample_period!r}')
    if not tau >= MIN_MEMORY * ts:
        raise ValueError(f'memory time must be at least {MIN_MEMORY:g} sample periods ({MIN_MEMORY * ts:g} s), '
                         f'got {memory_time!r}')
    return 1.0 - ts / tau


def prior(n, initial_covariance=1e6, initial_theta=None):
    """(theta0, P0) from a scalar variance (P0 = c I) or an n x n positive definite matrix, and theta0 (default 0)."""
    cov = np.asarray(initial_covariance, dtype=float)
    if cov.ndim == 0:
        if not 0.0 < cov < math.inf:
            raise ValueError(f'initial covariance must be positive and finite, got {initial_covariance!r}')
        P0 = float(cov) * np.eye(n)
    else:
        if cov.shape != (n, n) or not np.allclose(cov, cov.T) or not np.all(np.isfinite(cov)):
            raise ValueError(f'initial covariance must be a scalar or a symmetric {n} x {n} matrix')
        try:
            np.linalg.cholesky(cov)
        except np.linalg.LinAlgError:
            raise ValueError('initial covariance must be positive definite') from None
        P0 = 0.5 * (cov + cov.T)
    theta0 = np.zeros(n) if initial_theta is None else np.array(initial_theta, dtype=float).reshape(-1)
    if theta0.shape != (n,) or not np.all(np.isfinite(theta0)):
        raise ValueError(f'initial theta must be {n} finite numbers')
    return theta0, P0


def check_order(n):
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f'number of parameters must be a positive integer, got {n!r}')
    return int(n)


def check_regression(Phi, Y, n):
    """Phi as a C-contiguous float (N, n) array and Y as float (N,)."""
    Phi = np.ascontiguousarray(Phi, dtype=float)
    Y = np.ascontiguousarray(Y, dtype=float)
    if Phi.ndim != 2 or Phi.shape[1] != n:
        raise ValueError(f'regressors must be an (N, {n}) array, got shape {Phi.shape}')
    if Y.shape != (Phi.shape[0],):
        raise ValueError(f'outputs must be a 1-D array of {Phi.shape[0]} values, got shape {Y.shape}')
    return Phi, Y


def check_instruments(Zeta, Phi):
    """Zeta as a C-contiguous float array of the regressors' shape (instrumental variables)."""
    Zeta = np.ascontiguousarray(Zeta, dtype=float)
    if Zeta.shape != Phi.shape:
        raise ValueError(f'instruments must be an array of the regressors\' shape {Phi.shape}, got {Zeta.shape}')
    return Zeta


class RecursiveLeastSquares:
    """Per-sample RLS with forgetting, a covariance wind-up guard, freeze and reset (see the module doc).

    Non-finite samples are skipped: their prediction error is NaN and the state is left unchanged.
    """

    def __init__(self, n: int, *, forgetting: float = 1.0, memory_time: float | None = None,
                 sample_period: float | None = None, initial_covariance: float = 1e6,
                 initial_theta: ArrayLike | None = None, windup_limit: float | None = None) -> None:
        self._n = check_order(n)
        self._lam = forgetting_factor(forgetting, memory_time, sample_period)
        self._theta0, self._P0 = prior(self._n, initial_covariance, initial_theta)
        limit = np.trace(self._P0) if windup_limit is None else float(windup_limit)
        if not limit > 0.0:
            raise ValueError(f'wind-up limit must be positive (inf disables the guard), got {windup_limit!r}')
        self._limit = float(limit)
        self._enabled = True
        self._one_phi = np.empty((1, self._n))
        self._one_y = np.empty(1)
        self._one_e = np.empty(1)
        self.reset()

    def reset(self) -> None:
        """Back to the prior (theta0, P0) with no samples seen; frozen/enabled is kept."""
        self._theta = self._theta0.copy()
        self._P = self._P0.copy()
        self._stats = np.zeros(3)

    def freeze(self) -> None:
        """Stop adapting: theta and P stay, prediction errors are still computed."""
        self._enabled = False

    def enable(self) -> None:
        self._enabled = True

    def update(self, phi: ArrayLike, y: float) -> float:
        """One sample; returns the a-priori prediction error y - phi' theta."""
        if np.shape(phi) != (self._n,):
            raise ValueError(f'regressor must have {self._n} entries, got shape {np.shape(phi)}')
        self._one_phi[0] = phi
        self._one_y[0] = y
        self._run(self._one_phi, self._one_y, self._one_e)
        return float(self._one_e[0])

    def update_block(self, Phi: ArrayLike, Y: ArrayLike, instruments: ArrayLike | None = None) -> np.ndarray:
        """The same recursion over the rows of Phi (N x n) and Y (N,); returns the N a-priori errors.

        instruments: None, or an N x n array of instruments (instrumental variables, see the module doc)."""
        rows, targets = check_regression(Phi, Y, self._n)
        errors = np.empty(targets.shape[0])
        self._run(rows, targets, errors, None if instruments is None else check_instruments(instruments, rows))
        return errors

    def _run(self, Phi, Y, errors, Zeta=None):
        _rls_kernel(self._theta, self._P, self._stats, Phi, Y, Phi if Zeta is None else Zeta, Zeta is not None,
                    self._lam, self._limit, self._enabled, errors)

    @property
    def n(self) -> int:
        return self._n

    @property
    def forgetting(self) -> float:
        return self._lam

    @property
    def windup_limit(self) -> float:
        return self._limit

    @property
    def enabled(self) -> bool:
        return self._enabled

    @property
    def samples(self) -> int:
        """Number of samples that updated the estimate (frozen and skipped samples do not count)."""
        return int(self._stats[2])

    @property
    def theta(self) -> np.ndarray:
        return self._theta.copy()

    @property
    def covariance(self) -> np.ndarray:
        """P, the unscaled covariance (inverse weighted information matrix); see parameter_covariance()."""
        return self._P.copy()

    @property
    def effective_samples(self) -> float:
        """sum of the weights lambda^(N-k); tends to 1 / (1 - lambda)."""
        return float(self._stats[1])

    @property
    def residual_variance(self) -> float:
        """sigma2 = weighted residual sum of squares / (effective samples - n); NaN until that is positive."""
        dof = self._stats[1] - self._n
        return float(self._stats[0] / dof) if dof > 0 else math.nan

    def parameter_covariance(self) -> np.ndarray:
        return self.residual_variance * self._P

    def parameter_std(self) -> np.ndarray:
        """sqrt(diag(sigma2 P))."""
        return np.sqrt(self.residual_variance * np.diag(self._P))
