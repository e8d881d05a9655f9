"""Residual analysis: whiteness, cross-correlation with the input, and residuals binned against a signal.

The correlation bounds follow MATLAB's resid: under the hypothesis that the residual e is white and
independent of the input u, the normalised correlation at each lag is about normal with standard
deviation 1/sqrt(N) (whiteness); for the cross-correlation Bartlett's formula
var r_eu = (1/N) sum_k r_ee(k) r_uu(k) keeps the bound honest when the input is itself coloured.
"""
from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

CONFIDENCE = 0.99
MAX_LAG = 50


@dataclass
class Correlation:
    lags: np.ndarray
    values: np.ndarray
    bound: float    # +-bound at CONFIDENCE under the white-residual hypothesis

    @property
    def outside(self):
        """Fraction of lags outside the bound."""
        return float(np.mean(np.abs(self.values) > self.bound))

    @property
    def peak_lag(self):
        return int(self.lags[np.argmax(np.abs(self.values))])


def _normalised_correlation(a, b, max_lag):
    """r_ab(tau) = sum_t a(t + tau) b(t) / (N std a std b), tau = -max_lag .. max_lag."""
    a, b = a - a.mean(), b - b.mean()
    n = len(a)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    full = np.fft.irfft(np.fft.rfft(a, size) * np.conj(np.fft.rfft(b, size)), size)
    lags = np.arange(-max_lag, max_lag + 1)
    scale = n * a.std() * b.std()
    return lags, full[lags] / scale if scale else np.zeros(len(lags))


def whiteness(e, max_lag=MAX_LAG):
    """Autocorrelation of e at lags 1 .. max_lag with its bound."""
    lags, r = _normalised_correlation(e, e, max_lag)
    keep = lags > 0
    return Correlation(lags[keep], r[keep], norm.ppf(0.5 + CONFIDENCE / 2) / np.sqrt(len(e)))


def cross_correlation(e, u, max_lag=MAX_LAG):
    """Correlation of e(t + tau) with u(t), tau = -max_lag .. max_lag, with Bartlett's bound."""
    lags, r = _normalised_correlation(e, u, max_lag)
    _, r_ee = _normalised_correlation(e, e, max_lag)
    _, r_uu = _normalised_correlation(u, u, max_lag)
    spread = np.sqrt(max(float(np.sum(r_ee * r_uu)), 1.0) / len(e))
    return Correlation(lags, r, norm.ppf(0.5 + CONFIDENCE / 2) * spread)


@dataclass
class Binned:
    centers: np.ndarray
    mean: np.ndarray
    error: np.ndarray    # standard error of each bin's mean (white-residual assumption: a lower bound)
    # centers: mean of z in each bin
    count: np.ndarray


def binned(e, z, bins=24, min_count=50):
    """Mean residual in equal-width bins of z over its central 99 % (bins with < min_count samples dropped)."""
    low, high = np.quantile(z, [0.005, 0.995])
    if high <= low:
        low, high = low - 0.5, high + 0.5
    inside = (z >= low) & (z <= high)
    e, z = e[inside], z[inside]
    which = np.minimum(((z - low) / (high - low) * bins).astype(int), bins - 1)
    count = np.bincount(which, minlength=bins).astype(float)
    keep = count >= min_count
    total, squares, centers = (np.bincount(which, w, minlength=bins)[keep] for w in (e, e * e, z))
    count = count[keep]
    mean = total / count
    spread = np.sqrt(np.maximum(squares / count - mean ** 2, 0.0))
    return Binned(centers / count, mean, spread / np.sqrt(count), count)
