"""Physical EMLA parameters (R, L, Km, m, B, Fl) and their covariance from the regressions' statistics.

Each regression's state (theta and P, the inverse of its normal equations' matrix) holds those equations
completely, so the coefficient that depends on h = R Ts / L (see regressors.py) is tied afterwards: the
equations are solved for the reduced coefficients with that tie, for h from the electrical estimate, a few
times until h settles. Stream and batch therefore give the same parameters from the same samples. The
coefficients' covariance comes from the sensor-noise model (noise.py); the delta method carries it to the
physical parameters, the regressions taken as independent. Effects estimated online (online_effects.py) add
coefficients p / m after the mechanical regression's own; their parameters p follow as the load force does.
"""
import math

import numpy as np

from emla_core.parameters import PARAMETER_NAMES

from .noise import coefficient_covariances, noise_variances
from .regressors import emf_lag, tie

MODEL_PARAMETERS = {
    'electrical': ('resistance', 'inductance', 'emf_constant'),
    'mechanical': ('mass', 'damping', 'load_force'),
    'full': PARAMETER_NAMES,
}
_TIE_ITERATIONS = 6     # h settles to rounding level in 3-5 (the tie depends on h only through eta ~ h/12)


def log_decay(alpha):
    """h = -ln(alpha), NaN unless 0 < alpha < 1 (elementwise)."""
    if isinstance(alpha, float):  # a scalar (the tie's iteration): math, not numpy
        return -math.log(alpha) if 0.0 < alpha < 1.0 else math.nan
    return np.where((alpha > 0.0) & (alpha < 1.0), -np.log(np.where(alpha > 0.0, alpha, 1.0)), np.nan)


def coil_parameters(vector, sample_period):
    """R, L, Km, m, B, Fl (and the effects' p) from [alpha, beta, gamma, Km/m, B/m, Fl/m (, p/m ...)] along the
    last axis of `vector`."""
    alpha, beta, gamma, km_over_m, b_over_m, fl_over_m = np.moveaxis(vector[..., :6], -1, 0)
    h = log_decay(alpha)
    resistance = (1.0 - alpha) / beta
    km = gamma / beta
    # the intra-sample back-EMF rise acts as the extra mass Km^2 eta Ts / R (regressors.py)
    mass = km / km_over_m + km * km * emf_lag(h) * sample_period / resistance
    nominal = np.stack([resistance, resistance * sample_period / h, km, mass, km * b_over_m / km_over_m,
                        km * fl_over_m / km_over_m], axis=-1)
    return np.concatenate((nominal, (km / km_over_m)[..., None] * vector[..., 6:]), axis=-1)


def force_parameters(vector, sample_period):
    """m, B, Fl (and the effects' p) from [1/m, B/m, Fl/m (, p/m ...)] along the last axis."""
    inverse_mass, b_over_m, fl_over_m = np.moveaxis(vector[..., :3], -1, 0)
    nominal = np.stack([1.0 / inverse_mass, b_over_m / inverse_mass, fl_over_m / inverse_mass], axis=-1)
    return np.concatenate((nominal, vector[..., 3:] / inverse_mass[..., None]), axis=-1)


def propagate(function, vector, covariance, sample_period):
    """function(vector) and its covariance J C J' (central differences at a fraction of each sigma)."""
    sigma = np.sqrt(np.abs(np.diag(covariance)))
    steps = np.where(np.isfinite(sigma) & (sigma > 0), 1e-4 * sigma, 1e-8 * (np.abs(vector) + 1e-12))
    shifts = np.diag(steps)
    points = function(np.concatenate((vector[None], vector + shifts, vector - shifts)), sample_period)
    n = len(vector)
    jacobian = ((points[1:n + 1] - points[n + 1:]) / (2.0 * steps[:, None])).T
    return points[0], jacobian @ covariance @ jacobian.T


def physical(model, statistics, sample_period):
    """(names, values, covariance) of `model`'s parameters (and the online effects') from {kind: Statistics}."""
    with np.errstate(all='ignore'):
        restricted = _restricted(statistics)
        variances = noise_variances(statistics, restricted, sample_period)
        covariances = coefficient_covariances(statistics, restricted, variances, sample_period)
        vector = np.concatenate([theta for _, theta in restricted.values()])
        covariance = np.zeros((len(vector), len(vector)))
        start = 0
        for part in covariances.values():  # the regressions' coefficients taken as independent
            covariance[start:start + len(part), start:start + len(part)] = part
            start += len(part)
        names, function = _parameter_function(statistics)
        values, covariance = propagate(function, vector, covariance, sample_period)
    reported = _reported(model, statistics)
    keep = [names.index(n) for n in reported]
    return reported, values[keep], covariance[np.ix_(keep, keep)]


def physical_values(model, statistics, sample_period):
    """(names, values) as physical() gives them, without the noise model and the uncertainties."""
    with np.errstate(all='ignore'):
        vector = np.concatenate([theta for _, theta in _restricted(statistics).values()])
        names, function = _parameter_function(statistics)
        values = function(vector[None], sample_period)[0]
    reported = _reported(model, statistics)
    return reported, values[[names.index(n) for n in reported]]


def _effect_names(statistics):
    """The parameters of the online effects' columns of the mechanical (or force) regression."""
    kind = 'force' if 'force' in statistics else 'mechanical'
    return tuple(e.parameter for e in statistics[kind].effects) if kind in statistics else ()


def _reported(model, statistics):
    return MODEL_PARAMETERS[model] + _effect_names(statistics)


def _parameter_function(statistics):
    """(parameter names, function of the restricted coefficients) for these regressions."""
    if 'force' in statistics:
        return MODEL_PARAMETERS['mechanical'] + _effect_names(statistics), force_parameters
    return PARAMETER_NAMES + _effect_names(statistics), coil_parameters


def _restricted(statistics):
    """{kind: (T, theta_r)}: each regression with its h-dependent coefficient tied, h from the electrical one."""
    if 'force' in statistics:
        T = tie('force', 0.0, len(statistics['force'].effects))
        return {'force': (T, statistics['force'].restrict(T))}
    electrical = statistics['electrical']
    h = log_decay(electrical.theta[0])
    for _ in range(_TIE_ITERATIONS):
        T = tie('electrical', h)
        restricted = {'electrical': (T, electrical.restrict(T))}
        h, previous = log_decay(restricted['electrical'][1][0]), h
        if abs(h - previous) <= 1e-13 * h:
            break
    T = tie('mechanical', h, len(statistics['mechanical'].effects))
    restricted['mechanical'] = T, statistics['mechanical'].restrict(T)
    return restricted
