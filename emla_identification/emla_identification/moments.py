"""Lagged moments of regression rows (and instruments) kept beside the least-squares state: what the
sensor-noise model (noise.py) needs to give a weighted estimate its uncertainty, and the per-regression
statistics physical.py turns into physical parameters.

An estimate cannot be computed from statistics that overflowed (a sample of 1e100 squares to 1e200 in the
moments, and their products to inf) or whose information matrix is singular to working precision (one of 1e50
beside samples of order 1: its squares swamp every other's): Statistics.check() and Statistics.information say
so with an UnestimableError, the one place every estimate from them passes through (online.py).
"""
import functools
from dataclasses import dataclass

import numba
import numpy as np

from .regressors import HISTORY

# A matrix whose condition number (scaled to a unit diagonal, which takes the units out) exceeds 1/eps has no
# correct digit in its inverse. Real and simulated records stay below 1e13 (an idle actuator with a memory of
# 200 samples, the worst seen: 1.3e12); a frame of 1e50 among samples of order 1 gives 1e19 to inf.
SINGULAR = 1.0 / np.finfo(float).eps


class UnestimableError(ValueError):
    """An estimate cannot be computed from these statistics: an overflow, or a non-finite or singular
    information matrix (an input fault where it happens online: the identifier node reports it and goes back to
    the last statistics that gave one)."""


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

    def __init__(self, n, forgetting=1.0, instrumented=False, effects=()):
        self.rows = LagMoments(n + 1, forgetting)
        self.instruments = LagMoments(n, forgetting) if instrumented else None
        self.effects = effects

    def update(self, z, zeta=None):
        """Rows z (m x (n + 1)) and, if instrumented, their instruments zeta (m x n)."""
        self.rows.update(z)
        if self.instruments is not None:
            self.instruments.update(zeta)

    def statistics(self, theta, covariance):
        return Statistics(theta, covariance, self.rows.moments.copy(), self.rows.weight, self.rows.forgetting,
                          None if self.instruments is None else self.instruments.moments.copy(), self.effects)


_TILE = 512  # rows per tile of _lag_products: a tile's columns stay in the first-level cache


@numba.njit(cache=True, fastmath={'reassoc', 'contract'})  # reassociated sums: vectorised dot products
def _lag_products(tail, z, weights, moments):
    """moments[d] += sum_k weights_k z_k z_(k-d)' over the rows z_k of z, tail holding the HISTORY rows before
    (weights empty: all ones). Tile by tile, the rows are copied into columns: contiguous dot products. The
    history is the tail's length, not the global (numba would freeze a global into its cached compilation)."""
    m, width = z.shape
    history = tail.shape[0]
    ahead = np.empty((width, _TILE))
    behind = np.empty((width, _TILE + history))  # the tile's rows with the history before them
    for start in range(0, m, _TILE):
        n = min(_TILE, m - start)
        for k in range(n + history):
            row = z[start - history + k] if start - history + k >= 0 else tail[k]
            for i in range(width):
                behind[i, k] = row[i]
        if weights.size:
            for i in range(width):
                for k in range(n):
                    ahead[i, k] = weights[start + k] * behind[i, history + k]
        for i in range(width):
            a = ahead[i, :n] if weights.size else behind[i, history:history + n]
            for d in range(history + 1):
                for j in range(width):
                    b = behind[j, history - d:history - d + n]
                    total = 0.0
                    for k in range(n):
                        total += a[k] * b[k]
                    moments[d, i, j] += total


@dataclass(frozen=True)
class Statistics:
    """State of one regression: theta and P (unscaled) as rls.py and offline.py keep them, and the LagMoments
    (moments, weight) of its rows z = [phi, y] for the noise model, and of its instruments (None: least
    squares, the regressors are the instruments); effects: the online_effects columns after the regression's
    own, if any."""

    theta: np.ndarray
    covariance: np.ndarray
    lags: np.ndarray
    weight: float
    forgetting: float
    instrument_moments: np.ndarray | None = None
    effects: tuple = ()

    def check(self):
        """UnestimableError if no estimate can be computed from these statistics: a non-finite number (an overflow
        of the squared sums) or an information matrix singular to working precision (SINGULAR)."""
        arrays = {'coefficients': self.theta, 'covariance': self.covariance, 'moments': self.lags,
                  'weight': self.weight, 'instrument moments': self.instrument_moments}
        for name, values in arrays.items():
            if values is not None and not np.all(np.isfinite(values)):
                raise UnestimableError(f'the {name} of the regression are not finite (an overflow)')
        scale = np.sqrt(np.abs(np.diag(self.covariance)))
        with np.errstate(all='ignore'):
            condition = np.linalg.cond(self.covariance / np.outer(scale, scale)) if np.all(scale > 0) else np.inf
        if not condition <= SINGULAR:
            raise UnestimableError(f'the information matrix is singular to working precision (condition number '
                                   f'{condition:.3g})')
        return self

    @functools.cached_property
    def information(self):
        """The normal equations' matrix: sum w phi phi' (least squares) or sum w zeta phi' (instruments); an
        UnestimableError where it cannot be computed (a singular or non-finite covariance, or an overflow)."""
        if not np.all(np.isfinite(self.covariance)):
            raise UnestimableError('the covariance of the regression is not finite (an overflow)')
        try:
            with np.errstate(all='ignore'):
                information = np.linalg.inv(self.covariance)
        except np.linalg.LinAlgError as error:
            raise UnestimableError(f'the information matrix cannot be computed: {error}') from None
        if not np.all(np.isfinite(information)):
            raise UnestimableError('the information matrix is not finite (an overflow)')
        return information

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
