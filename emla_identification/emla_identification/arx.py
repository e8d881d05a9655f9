"""ARX(na, nb, nk) models identified by recursive least squares.

    y(t) + a1 y(t-1) + ... + a_na y(t-na) = b1 u(t-nk) + ... + b_nb u(t-nk-nb+1) + e(t)

is linear in theta = [a1 .. a_na, b1 .. b_nb] with the regressor
phi(t) = [-y(t-1) .. -y(t-na), u(t-nk) .. u(t-nk-nb+1)]. Regressor rows start at the first sample whose
history is complete (no zero padding).

Defaults of `emla identify --model arx` and the identifier node's ARX mode: orders 2 2 1 from the voltage to
the current (the exact structure of the coil current's response to the held voltage).
"""

from dataclasses import dataclass
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike

from .rls import RecursiveLeastSquares

DEFAULT_ORDERS = (2, 2, 1)
DEFAULT_SIGNALS = ('voltage', 'current')  # (input u, output y)
RESCALE_BEYOND = 2.0 ** 16  # peak |u| or |y| (any units) beyond which, or below whose inverse, identify_arx rescales
# Largest orders taken: na, nb (the regressor has na + nb columns; higher orders fit noise) and the delay nk
MAX_ORDERS = {'na': 100, 'nb': 100, 'nk': 10_000}


def _check_orders(na, nb, nk):
    for name, value in (('na', na), ('nb', nb), ('nk', nk)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value <= MAX_ORDERS[name]:
            raise ValueError(f'ARX order {name} must be an integer in [0, {MAX_ORDERS[name]}], got {value!r}')
    if na + nb == 0:
        raise ValueError('ARX orders na and nb cannot both be zero')
    return int(na), int(nb), int(nk)


def _history(na, nb, nk):
    """Samples needed before the first complete regressor row."""
    return max(na, nk + nb - 1 if nb else 0)


def arx_regressors(u, y, na, nb, nk):
    """(Phi, Y): one row per sample t >= max(na, nk + nb - 1), Y = y(t)."""
    na, nb, nk = _check_orders(na, nb, nk)
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    if u.ndim != 1 or u.shape != y.shape:
        raise ValueError(f'input and output must be 1-D of equal length, got shapes {u.shape} and {y.shape}')
    N, t0 = len(y), _history(na, nb, nk)
    if N <= t0:
        return np.empty((0, na + nb)), np.empty(0)
    Phi = np.empty((N - t0, na + nb))
    for i in range(1, na + 1):
        Phi[:, i - 1] = -y[t0 - i:N - i]
    for j in range(nb):
        Phi[:, na + j] = u[t0 - nk - j:N - nk - j]
    return Phi, y[t0:].copy()


def fit_percent(y, yhat):
    """100 (1 - ||y - yhat|| / ||y - mean(y)||); NaN when y does not vary (no fit is defined)."""
    y, yhat = np.asarray(y, dtype=float), np.asarray(yhat, dtype=float)
    spread = np.linalg.norm(y - y.mean())
    return float(100.0 * (1.0 - np.linalg.norm(y - yhat) / spread)) if spread > 0 else float('nan')


def mse(y, yhat):
    """(1/N) sum (y - yhat)^2."""
    return float(np.mean((np.asarray(y, dtype=float) - np.asarray(yhat, dtype=float)) ** 2))


@dataclass(frozen=True)
class ArxModel:
    """A(q) y = q^-nk B(q) u with a = [1, a1 .. a_na], b = [b1 .. b_nb]; fit and MSE on the data it came from."""

    a: np.ndarray
    b: np.ndarray
    nk: int
    forgetting: float = 1.0
    fit_percent: float = float('nan')
    mse: float = float('nan')

    @classmethod
    def from_theta(cls, theta: ArrayLike, na: int, nb: int, nk: int, **fields: float) -> Self:
        theta = np.asarray(theta, dtype=float)
        return cls(a=np.concatenate(([1.0], theta[:na])), b=theta[na:na + nb].copy(), nk=nk, **fields)

    @property
    def orders(self) -> tuple[int, int, int]:
        return len(self.a) - 1, len(self.b), self.nk

    @property
    def theta(self) -> np.ndarray:
        return np.concatenate((self.a[1:], self.b))

    @property
    def poles(self) -> np.ndarray:
        """Roots of z^na + a1 z^(na-1) + ... + a_na (the delay's poles at the origin are not included)."""
        return np.roots(self.a)

    @property
    def zeros(self) -> np.ndarray:
        """Roots of B as a polynomial, b1 z^(nb-1) + ... + b_nb."""
        return np.roots(self.b) if len(self.b) else np.empty(0, dtype=complex)

    def predict(self, u: ArrayLike, y: ArrayLike) -> np.ndarray:
        """One-step-ahead predictions, aligned with arx_regressors(u, y, ...)[1]."""
        Phi, _ = arx_regressors(u, y, *self.orders)
        return Phi @ self.theta

    def to_dict(self) -> dict:
        """The `emla identify --model arx` JSON object."""
        def pairs(roots):
            return [[float(z.real), float(z.imag)] for z in roots]
        return {'model': 'arx', 'orders': list(self.orders), 'forgetting': self.forgetting,
                'a': self.a.tolist(), 'b': self.b.tolist(), 'poles': pairs(self.poles),
                'zeros': pairs(self.zeros), 'fit_percent': self.fit_percent, 'mse': self.mse}


def identify_arx(u: ArrayLike, y: ArrayLike, na: int, nb: int, nk: int, forgetting: float = 1.0,
                 initial_covariance: float = 1e6) -> ArxModel:
    """Identify a black-box ARX model A(q) y(t) = B(q) u(t - nk) by recursive least squares over a record.

    y(t) + a1 y(t-1) + ... + a_na y(t-na) = b1 u(t-nk) + ... + b_nb u(t-nk-nb+1); the recursion starts from
    theta = 0 and P = initial_covariance I, so with forgetting 1 it matches batch least squares.

    Parameters
    ----------
    u, y : array_like
        Input and output, 1-D, uniformly sampled, of equal length (any units; peaks beyond 2^16 or below 2^-16
        are rescaled by powers of two for the recursion, and b scaled back).
    na, nb, nk : int
        Orders: output lags, input lags and the input delay in samples (the DC-motor paper uses 4, 3, 1).
    forgetting : float, optional
        Forgetting factor lambda in (0, 1] (memory about 1 / (1 - lambda) samples).
    initial_covariance : float, optional
        P0 = initial_covariance I.

    Returns
    -------
    ArxModel
        `a` = [1, a1, ...], `b`, `nk`, `poles()`, `zeros()`, and `fit_percent`, `mse` of its one-step
        predictions on the record.

    Raises
    ------
    ValueError
        Bad orders, or a record too short for them.

    Examples
    --------
    >>> import numpy as np
    >>> u = np.random.default_rng(0).standard_normal(500)
    >>> y = np.zeros(500)
    >>> for t in range(1, 500):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    >>> model = identify_arx(u, y, 1, 1, 1)
    >>> np.round(model.a, 6).tolist(), np.round(model.b, 6).tolist()
    ([1.0, -0.9], [0.5])
    """
    su, sy = _scale(u), _scale(y)
    Phi, Y = arx_regressors(np.asarray(u, dtype=float) / su, np.asarray(y, dtype=float) / sy, na, nb, nk)
    if len(Y) == 0:
        raise ValueError(f'record of {len(np.asarray(y))} samples is too short for ARX({na}, {nb}, {nk})')
    rls = RecursiveLeastSquares(na + nb, forgetting=forgetting, initial_covariance=initial_covariance)
    rls.update_block(Phi, Y)
    if not np.all(np.isfinite(rls.theta)):
        raise ValueError('the recursion gives no finite estimate: the signals are too large or too small for it '
                         '(give their units with --units)')
    yhat = Phi @ rls.theta
    theta = rls.theta * np.concatenate((np.ones(na), np.full(nb, sy / su)))   # b in the units of y per u
    return ArxModel.from_theta(theta, na, nb, nk, forgetting=rls.forgetting, fit_percent=fit_percent(Y, yhat),
                               mse=mse(Y, yhat) * sy * sy)


def _scale(values):
    """The power of two nearest the peak of |values| if it lies beyond RESCALE_BEYOND of 1, else 1: dividing by
    it is exact and keeps the prior P0 negligible beside the data and their squares finite."""
    values = np.abs(np.asarray(values, dtype=float))
    peak = float(np.max(values[np.isfinite(values)], initial=0.0))
    return 2.0 ** round(np.log2(peak)) if peak and not 1 / RESCALE_BEYOND <= peak <= RESCALE_BEYOND else 1.0


class ArxEstimator:
    """Online ARX identification from consecutive frames of u and y (history kept across frames, restarted by
    gap()). Its `model` is identify_arx's on the same samples (of ordinary size; identify_arx rescales signals
    beyond RESCALE_BEYOND, this does not): the same theta, and the fit and MSE of the latest
    theta over every row used, from the rows' mean and scatter (to rounding; ill-conditioned rows cost digits)."""

    def __init__(self, na: int, nb: int, nk: int, **rls_options: Any) -> None:
        self._orders = _check_orders(na, nb, nk)
        self.rls = RecursiveLeastSquares(na + nb, **rls_options)
        self._lag = _history(*self._orders)
        self.reset()

    def reset(self) -> None:
        self.rls.reset()
        self._rows = 0  # used so far; their mean z and scatter sum (z - mean)(z - mean)', z = [phi, y]
        self._mean = np.zeros(self.rls.n + 1)
        self._scatter = np.zeros((self.rls.n + 1,) * 2)
        self.gap()

    def gap(self) -> None:
        """Samples were lost: the next frame does not follow on from the last one, and no row will span the gap
        (the estimate is kept)."""
        self._u = self._y = np.empty(0)

    def update(self, u: ArrayLike, y: ArrayLike) -> np.ndarray:
        """Feed one frame; returns its a-priori prediction errors (NaN while the history is incomplete, and
        where a non-finite sample makes the recursion skip the row)."""
        u = np.concatenate((self._u, np.asarray(u, dtype=float).reshape(-1)))
        y = np.concatenate((self._y, np.asarray(y, dtype=float).reshape(-1)))
        Phi, Y = arx_regressors(u, y, *self._orders)
        frame = len(u) - len(self._u)
        errors = np.full(frame, np.nan)
        row_errors = self.rls.update_block(Phi, Y)
        errors[frame - len(Y):] = row_errors
        self._add_rows(np.column_stack((Phi, Y))[np.isfinite(row_errors)])
        keep = max(len(u) - self._lag, 0)
        self._u, self._y = u[keep:], y[keep:]
        return errors

    def _add_rows(self, z):
        """Merge the rows z into the mean and scatter (Chan et al.: no sums of squares of large means)."""
        if not len(z):
            return
        mean = z.mean(axis=0)
        centred, delta, rows = z - mean, mean - self._mean, self._rows + len(z)
        self._scatter += centred.T @ centred + np.outer(delta, delta) * (self._rows * len(z) / rows)
        self._mean += delta * (len(z) / rows)
        self._rows = rows

    @property
    def model(self) -> ArxModel:
        theta = self.rls.theta
        if not self._rows:
            return ArxModel.from_theta(theta, *self._orders, forgetting=self.rls.forgetting)
        residual = np.append(-theta, 1.0)  # z . residual = y - phi' theta
        squares = max(float(residual @ self._scatter @ residual), 0.0) + self._rows * (self._mean @ residual) ** 2
        spread = self._scatter[-1, -1]
        fit = 100.0 * (1.0 - np.sqrt(squares / spread)) if spread > 0 else np.nan  # a constant output has no fit
        return ArxModel.from_theta(theta, *self._orders, forgetting=self.rls.forgetting, fit_percent=float(fit),
                                   mse=float(squares / self._rows))
