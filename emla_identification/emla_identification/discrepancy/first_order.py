"""The discrepancy workflow's regressions: first order in the sample period (exact up to terms of second order
in Ts, so for Ts well below L/R); the identification itself uses the exact ones of regressors.py, and the workflow
moves to them with its candidates (the next step of docs/physics.md §8).

Sample k holds the current I_k and position x_k measured at t_k and the voltage u_k applied over
[t_k, t_k+1]. Each row uses samples k-2 .. k+2 (rows for k = 2 .. N-3).

Electrical. Over one interval the coil obeys dI/dt = (u_k - R I - Km v) / L, hence

    I_k+1 = alpha I_k + beta u_k - gamma [v_mean + eta Ts a],   alpha = exp(-h), h = R Ts / L,
    beta = (1 - alpha) / R,  gamma = Km beta,

where v_mean = (x_k+1 - x_k) / Ts is the interval's mean velocity and eta(h) Ts a corrects to first order for
the exponential weighting of the back-EMF towards the interval's end (a: acceleration at its middle). The
regression is on [alpha, beta, gamma, gamma eta], the last tied to the others (tie()).

Mechanical. The second difference of position is the exact triangle-weighted mean acceleration over
[t_k-1, t_k+1]:

    (x_k+1 - 2 x_k + x_k-1) / Ts^2 = F_tri / m - (B/m) v_tri - Fl/m,

F_tri = Km I_tri, the current taken as exponential with rate R/L between samples (adding eta(h) (I_k+1 - I_k-1)
/ 2), v_tri the central difference with a third-difference correction. The back-EMF's rise within an interval
acts like an extra mass Km^2 eta Ts / R (to first order), added when m is formed (coil_parameters). A measured
force (the force regression) is regressors.triangle_rows.

Instruments: the electrical regression by instrumental variables, the same signals one sample earlier.
"""
import math

import numpy as np

from emla_identification.regressors import noise_stencils as _stencils
from emla_identification.regressors import triangle_rows

HISTORY = 4  # samples k-2 .. k+2
COLUMNS = {
    'electrical': ('alpha', 'beta', 'gamma', 'gamma_eta'),
    'mechanical': ('km_over_m', 'eta_km_over_m', 'b_over_m', 'fl_over_m'),
    'force': ('one_over_m', 'b_over_m', 'fl_over_m'),
}


def rows(kind, signals, sample_period):
    """(Phi, Y) of regression `kind` from a dict of equally long 1-D arrays; row j is sample k = j + 2."""
    ts = float(sample_period)
    x = np.asarray(signals['position'], dtype=float)
    if len(x) <= HISTORY:
        return np.empty((0, len(COLUMNS[kind]))), np.empty(0)
    lags = {d: x[2 + d:len(x) - 2 + d] for d in range(-2, 3)}
    if kind == 'force':
        force = np.asarray(signals['force'], dtype=float)
        return triangle_rows(lags, {d: force[2 + d:len(x) - 2 + d] for d in range(-2, 3)}, ts)
    xm2, xm1, x0, xp1, xp2 = (lags[d] for d in range(-2, 3))
    if kind == 'electrical':
        u = np.asarray(signals['voltage'], dtype=float)[2:-2]
        i = np.asarray(signals['current'], dtype=float)
        v_mean = (xp1 - x0) / ts
        lag = (xp2 - xp1 - x0 + xm1) / (2.0 * ts)  # Ts a at t_k + Ts/2 (mean of two second differences)
        return np.column_stack((i[2:-2], u, -v_mean, -lag)), i[3:-1].copy()
    drive = np.asarray(signals['current'], dtype=float)
    fm1, f0, fp1 = drive[1:-3], drive[2:-2], drive[3:-1]
    f_lin = (fm1 + 4.0 * f0 + fp1) / 6.0
    v_tri = (xp1 - xm1) / (2.0 * ts) - (xp2 - 2.0 * xp1 + 2.0 * xm1 - xm2) / (24.0 * ts)
    y = (xp1 - 2.0 * x0 + xm1) / ts ** 2
    return np.column_stack((f_lin, 0.5 * (fp1 - fm1), -v_tri, -np.ones_like(y))), y


def instruments(kind, signals, sample_period):
    """The electrical regression's instruments (N-4 x 4): its signals one sample earlier."""
    i = np.asarray(signals['current'], dtype=float)
    u = np.asarray(signals['voltage'], dtype=float)
    x = np.asarray(signals['position'], dtype=float)
    if len(x) <= HISTORY:
        return np.empty((0, len(COLUMNS[kind])))
    # samples k-1 (slice [1:-3]) and k-2 ([:-4]) for k = 2 .. N-3
    return np.column_stack((i[1:-3], u[1:-3], -(x[1:-3] - x[:-4]) / float(sample_period), i[:-4]))


def noise_stencils(kind, sample_period):
    """regressors.noise_stencils of these rows: index j for the noise of sample k - 2 + j."""
    return _stencils(kind, sample_period, rows, HISTORY)


def emf_lag(h):
    """eta(h) = coth(h/2)/2 - 1/h (= h/12 - h^3/720 + ...), h = R Ts / L; 0 where h is not positive or NaN.

    Both the back-EMF weighting of the electrical equation and the antisymmetric part of the exponential
    current shape in the mechanical one reduce to this function. Elementwise on arrays.
    """
    if isinstance(h, float):  # a scalar (the tie, at every online estimate): math is 10x faster than numpy here
        return 0.5 / math.tanh(0.5 * h) - 1.0 / h if h > 1e-2 else h / 12.0 - h ** 3 / 720.0 if h > 0.0 else 0.0
    h = np.asarray(h, dtype=float)
    closed = h > 1e-2  # below, the closed form loses digits to cancellation; NaN compares False
    half = 0.5 * np.where(closed, h, 1.0)
    return np.where(closed, 0.5 / np.tanh(half) - 0.5 / half, np.where(h > 0.0, h / 12.0 - h ** 3 / 720.0, 0.0))


def tie(kind, h, extra=0):
    """T (n_reduced x n) with coefficients = T' theta_reduced: ties the h-dependent coefficient of `kind`;
    `extra` further columns (online_effects.py) are kept as they are."""
    eta = float(emf_lag(h))
    if kind == 'electrical':   # [alpha, beta, gamma] -> [alpha, beta, gamma, gamma eta]
        T = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, eta]])
    elif kind == 'mechanical':   # [Km/m, B/m, Fl/m] -> [Km/m, eta Km/m, B/m, Fl/m]
        T = np.array([[1.0, eta, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    else:
        T = np.eye(len(COLUMNS[kind]))
    if not extra:
        return T
    return np.block([[T, np.zeros((len(T), extra))], [np.zeros((extra, T.shape[1])), np.eye(extra)]])


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
