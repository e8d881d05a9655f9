"""The sensor-noise model behind the grey-box uncertainties.

The residuals are far from white (differencing the quantised position colours them), so sigma2 P would
misstate the uncertainties badly. Instead: white noise on each measured signal, carried through the rows
(regressors.noise_stencils), with variances fitted to the residual autocovariances (noise_variances), and the
sandwich covariance that noise gives the weighted estimate (coefficient_covariances), from the lagged moments
of the rows and instruments (moments.LagMoments).
"""
import itertools

import numpy as np

from .regressors import HISTORY, noise_stencils


def noise_filters(kind, T, theta, sample_period, effects=()):
    """{signal: c}: the residual of row k with coefficients T' theta gets sum_j c_j (noise of sample k - LEAD + j);
    effects: the extra columns' (online_effects.py)."""
    coefficients = T.T @ theta
    def column(effect, name):   # an effect's stencil covers samples k-2 .. k+2 (online_effects.py)
        stencil = effect.stencil(name, kind)
        return np.pad(stencil, (HISTORY + 1 - len(stencil), 0))
    return {name: dy - np.column_stack([dphi] + [column(e, name) for e in effects]) @ coefficients
            for name, (dy, dphi) in noise_stencils(kind, sample_period).items()}


def _autocorrelation(c):
    return np.correlate(c, c, 'full')[HISTORY:]  # lags 0 .. HISTORY


def noise_variances(statistics, restricted, sample_period):
    """{signal: variance} of white noise on the measured signals, fitted to the residual autocovariances.

    Noise on each sample reaches the residuals through the rows' construction (regressors.noise_stencils);
    the variances that explain the residuals' autocovariances at lags 0 .. HISTORY best are found by
    non-negative least squares, shared by all regressions of the model (the same sensors feed them all).
    """
    sources = sorted({name for kind in restricted for name in noise_stencils(kind, sample_period)})
    equations, targets = [], []
    for kind, (T, theta) in restricted.items():
        stats = statistics[kind]
        filters = noise_filters(kind, T, theta, sample_period, stats.effects)
        products = stats.residual_products(T, theta)
        scale = 1.0 / products[0] if products[0] > 0 else 0.0  # each regression's equations in its own units
        equations.append(scale * stats.weight * np.column_stack(
            [_autocorrelation(filters[name]) if name in filters else np.zeros(HISTORY + 1) for name in sources]))
        targets.append(scale * products)
    return dict(zip(sources, _nonnegative_least_squares(np.concatenate(equations), np.concatenate(targets))))


def coefficient_covariances(statistics, restricted, variances, sample_period):
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
                     for name, c in noise_filters(kind, T, theta, sample_period, stats.effects).items())
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
