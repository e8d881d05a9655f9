"""Physical EMLA parameters (R, L, Km, m, B, Fl and the online effects' p) and their covariance from the
regressions' statistics, by minimum distance.

Each regression of regressors.py estimates its coefficients theta freely; the exact sampled-data relations
make them functions g(q) of the physical parameters q (coefficients()). q is the weighted least-squares fit of
g(q) to theta, the weight being the inverse covariance of theta that the sensor-noise model gives (noise.py),
the regressions taken as independent; its covariance is (J' W J)^-1, J = dg/dq at the fit. With the optimal
weight this is as efficient as fitting q to the rows directly, and it works from the regressions' running
statistics alone, so stream and batch give the same parameters from the same samples. Effects estimated online
(online_effects.py) add a column with coefficient (gain of a unit load force) x p to each regression.

The fit starts from the coefficients' meaning for a short sample period (initial_guess) or from a given start
(the online identifier's last estimate) and converges in a few Gauss-Newton steps (scipy's Levenberg-Marquardt).
"""
import math

import numba
import numpy as np
from scipy.linalg import block_diag
from scipy.optimize import least_squares

from emla_core.parameters import PARAMETER_NAMES

from .noise import coefficient_covariances, noise_variances
from .regressors import COLUMNS, FIRST_ORDER

MODEL_PARAMETERS = {
    'electrical': ('resistance', 'inductance', 'emf_constant'),
    'mechanical': ('mass', 'damping', 'load_force'),
    'full': PARAMETER_NAMES,
}
COIL_PARAMETERS = 5     # R, L, Km, m, B: the parameters the coil regressions depend on nonlinearly
DECAYS = (0.1, 0.5, 2.0, 8.0, 32.0)   # R Ts / L of the fit's further starts (starts_for)
MASS_FACTORS = (0.1, 1.0, 10.0)      # and their masses, over the guess's
RESOLUTION = 1e-7                    # relative floor of a row's residual (_white_covariance)
MAX_EVALUATIONS = 100                # a start's fit: most converge in under 20, one running away takes 600
RUNAWAY = 1e6                        # a coil parameter this many times its start's has no finite optimum (_ran_away)
OFFSET_EVIDENCE = 25.0               # chi-square a free electrical constant must gain, in misfit units


def transition(q, sample_period, stiffness=None):
    """(P, G, H) of the coil and mass over one sample period for parameter rows q[..., :5] = R, L, Km, m, B:
    s_k+1 = P s_k + G u_k + H F for the state s = [I, x, v], the held voltage u and a held load force F (opposing
    +x); stiffness: None, or the index in q of a spring's k (its force k x opposing +x is then part of the
    motion). Leading axes of q are kept."""
    q = np.asarray(q, dtype=float)
    r, ind, km, m, b = np.moveaxis(q[..., :COIL_PARAMETERS], -1, 0)
    a = np.zeros(np.shape(r) + (5, 5))
    a[..., 0, 0], a[..., 0, 2], a[..., 0, 3] = -r / ind, -km / ind, 1.0 / ind
    a[..., 1, 2] = 1.0
    a[..., 2, 0], a[..., 2, 2], a[..., 2, 4] = km / m, -b / m, -1.0 / m
    if stiffness is not None:
        a[..., 2, 1] = -q[..., stiffness] / m
    e = exponential(a * sample_period)
    return e[..., :3, :3], e[..., :3, 3], e[..., :3, 4]


def exponential(a, terms=18):
    """expm of a stack of small matrices (..., n, n): scaled to norm 1/2, a Taylor series of `terms` terms (its
    remainder below 1e-22), squared back. scipy.linalg.expm per call costs some 100 times more for 5 x 5, and numpy's
    stacked products some 5 times more than these loops (the minimum-distance fit takes thousands of calls)."""
    a = np.asarray(a, dtype=float)
    flat = np.ascontiguousarray(a.reshape((-1,) + a.shape[-2:]))
    return _exponentials(flat, terms).reshape(a.shape)


@numba.njit(cache=True)
def _exponentials(a, terms):
    out = np.empty_like(a)
    n = a.shape[-1]
    for i in range(a.shape[0]):
        norm = 0.0   # the infinity norm
        for r in range(n):
            norm = max(norm, np.sum(np.abs(a[i, r])))
        squarings = max(0, int(math.ceil(math.log2(max(norm, 1e-300) / 0.5))))
        scaled = a[i] / 2.0 ** squarings
        e = np.eye(n)
        for k in range(terms, 0, -1):   # Horner: I + a/1 (I + a/2 (I + ...))
            e = np.eye(n) + _product(scaled, e) / k
        for _ in range(squarings):
            e = _product(e, e)
        out[i] = e
    return out


@numba.njit(cache=True)
def _product(a, b):
    """a @ b of small square matrices, without a BLAS call per product."""
    n = a.shape[0]
    out = np.zeros((n, n))
    for r in range(n):
        for k in range(n):
            x = a[r, k]
            for c in range(n):
                out[r, c] += x * b[k, c]
    return out


def input_gains(kind, q, sample_period, motion=None):
    """(voltage gains, load gains) of a coil regression `kind` for parameter rows q: how a voltage or a load force
    (opposing +x) held over each interval the row spans enters its output, along the last axis, one entry per
    interval: [t_k-1, t_k] for the electrical rows, ([t_k-1, t_k], [t_k, t_k+1]) for the mechanical ones.

    An extra voltage drop or force that varies slowly against the sample period (an effect's term) enters the
    rows through these gains (the discrepancy workflow's candidate columns); a constant one through their sum."""
    P, G, H = transition(q, sample_period) if motion is None else motion
    if kind in ('electrical_velocity', 'mechanical_velocity'):
        row = 0 if kind == 'electrical_velocity' else 2
        return G[..., row, None], H[..., row, None]
    if kind == 'electrical':
        ratio = P[..., 0, 2] / P[..., 1, 2]
        return (G[..., 0] - ratio * G[..., 1])[..., None], (H[..., 0] - ratio * H[..., 1])[..., None]
    a, pxv = P[..., 2, 2], P[..., 1, 2]
    scale = 2.0 / ((1.0 - _lag_coefficient(P)) * sample_period ** 2)   # the second difference is over Ts^2
    return (scale[..., None] * np.stack((pxv * G[..., 2] - a * G[..., 1], G[..., 1]), -1),
            scale[..., None] * np.stack((pxv * H[..., 2] - a * H[..., 1], H[..., 1]), -1))


def piece_gains(kind, q, sample_period, pieces):
    """(voltage gains, load gains) of a voltage or a load force held over each of `pieces` equal parts of each
    interval a row of regression `kind` spans, at one parameter vector q: (intervals, pieces) each, in time order;
    over each interval they sum to input_gains'. A term that switches within an interval (a friction reversing)
    enters the row exactly through them, where the interval's gain would take it as held over the whole interval:
    the row's response to an input depends on when within the interval it acts (the back-EMF through the coil's
    L/R weighs the interval's end; a mass's second difference, the middle)."""
    q = np.asarray(q, dtype=float)
    if kind == 'force':   # the triangle over [t_k-1, t_k+1] on a free mass: -1/m times its area over each piece
        m = np.arange(pieces)
        rising = (2.0 * m + 1.0) / (2.0 * pieces ** 2)
        load = -np.stack((rising, rising[::-1])) / q[0]
        return np.zeros_like(load), load
    P = transition(q, sample_period)[0]
    Ph, Gh, Hh = transition(q, sample_period / pieces)
    later = [np.eye(3)]   # the state carried from the end of a piece to the end of its interval
    for _ in range(pieces - 1):
        later.append(Ph @ later[-1])
    responses = np.stack([[later[pieces - 1 - j] @ column for j in range(pieces)] for column in (Gh, Hh)])
    if kind == 'electrical':   # as input_gains: the state change at t_k, the velocity eliminated
        ratio = P[0, 2] / P[1, 2]
        voltage, load = (r[None, :, 0] - ratio * r[None, :, 1] for r in responses)
        return voltage, load
    a, pxv = P[2, 2], P[1, 2]
    scale = 2.0 / ((1.0 - _lag_coefficient(P)) * sample_period ** 2)
    voltage, load = (scale * np.stack((pxv * r[:, 2] - a * r[:, 1], r[:, 1])) for r in responses)
    return voltage, load


def coefficients(kind, q, sample_period, motion=None, stiffness=None):
    """The coefficients g(q) of regression `kind` (regressors.py) for parameter rows q: [R, L, Km, m, B, Fl, p...]
    ([m, B, Fl, p...] for the force regression: [1, B, Fl, p...] / m), along the last axis; motion: transition(q)
    if it is at hand; stiffness: the index in q of a spring's k, whose column (-x_k-1, -x_k: online.py of the
    physics layer) takes the coefficient of the exact relation with k in the transition (docs/physics.md §3.8)."""
    q = np.asarray(q, dtype=float)
    if kind == 'force':   # columns [f_tri, -v_tri, -1, f_effect...]: accelerations
        return q[..., :1] ** -1 * np.concatenate((np.ones_like(q[..., :1]), q[..., 1:]), axis=-1)
    P, G, H = motion = transition(q, sample_period, stiffness) if motion is None else motion
    voltage, load = input_gains(kind, q, sample_period, motion)
    # the load-force coefficients: Fl (column 1) and the effects' p (columns -f, online_effects.py)
    loads = np.sum(load, axis=-1, keepdims=True) * np.concatenate(
        (q[..., COIL_PARAMETERS:COIL_PARAMETERS + 1], -q[..., COIL_PARAMETERS + 1:]), axis=-1)
    if kind in ('electrical_velocity', 'mechanical_velocity'):
        row = 0 if kind == 'electrical_velocity' else 2
        return np.concatenate((np.stack((P[..., row, 0], P[..., row, 2], voltage[..., 0]), -1), loads), axis=-1)
    ratio, ts = P[..., 0, 2] / P[..., 1, 2], sample_period
    if kind == 'electrical':   # the displacement's column is over Ts (regressors.rows)
        nominal = np.stack((P[..., 0, 0] - ratio * P[..., 1, 0], voltage[..., 0], ratio * ts), -1)
        if stiffness is not None:   # I_k gets (P_Ix + r (1 - P_xx)) x_k-1 beside r (x_k - x_k-1)
            loads[..., stiffness - COIL_PARAMETERS] = -(P[..., 0, 1] + ratio * (1.0 - P[..., 1, 1]))
        return np.concatenate((nominal, loads), axis=-1)
    a, pxv, lag = P[..., 2, 2], P[..., 1, 2], _lag_coefficient(P)
    scale = 2.0 / ((1.0 - lag) * ts * ts)   # the second difference is over Ts^2, the central one over 2 Ts
    nominal = np.stack((-2.0 * (1.0 + lag) / ((1.0 - lag) * ts), scale * P[..., 1, 0],
                        scale * (pxv * P[..., 2, 0] - a * P[..., 1, 0]), voltage[..., 1], voltage[..., 0]), -1)
    if stiffness is not None:   # x_k+1 - (P_xx + a) x_k - lag x_k-1: the level x_k keeps 1 - P_xx - a - lag
        loads[..., stiffness - COIL_PARAMETERS] = scale * (1.0 - P[..., 1, 1] - a - lag)
    return np.concatenate((nominal, loads), axis=-1)


def _lag_coefficient(P):
    """x_k-1's coefficient in the mechanical relation x_k+1 = (P_xx + a) x_k + (P_xv P_vx - a P_xx) x_k-1 + ...
    (a = P_vv; -a without a spring)."""
    return P[..., 1, 2] * P[..., 2, 1] - P[..., 2, 2] * P[..., 1, 1]


def jacobian(kind, q, sample_period):
    """(g(q), dg/dq) of regression `kind` at one parameter vector q (central differences)."""
    q = np.asarray(q, dtype=float)
    return coefficients(kind, q, sample_period), _differences(lambda z: coefficients(kind, z, sample_period), q,
                                                              _steps(kind, q))


def gains_jacobian(kind, q, sample_period):
    """(voltage gains, load gains, their derivatives d/dq (intervals x parameters) each) of a coil regression at
    one parameter vector q[:6] (input_gains; central differences)."""
    q = np.asarray(q, dtype=float)

    def gains(z):
        return np.concatenate(input_gains(kind, z, sample_period), axis=-1)
    both, derivative = gains(q), _differences(gains, q, _steps(kind, q))
    half = len(both) // 2
    return both[:half], both[half:], derivative[:half], derivative[half:]


def piece_gains_jacobian(kind, q, sample_period, pieces):
    """(voltage piece gains, load piece gains, their derivatives d/dq: (intervals, pieces, parameters) each) of a
    regression at one parameter vector q (piece_gains; central differences)."""
    q = np.asarray(q, dtype=float)

    def gains(rows):
        return np.array([np.concatenate([g.ravel() for g in piece_gains(kind, z, sample_period, pieces)])
                         for z in np.atleast_2d(rows)])
    shape = piece_gains(kind, q, sample_period, pieces)[0].shape
    both, derivative = gains(q)[0], _differences(gains, q, _steps(kind, q))
    half = len(both) // 2
    return (both[:half].reshape(shape), both[half:].reshape(shape), derivative[:half].reshape(shape + (len(q),)),
            derivative[half:].reshape(shape + (len(q),)))


def _steps(kind, q):
    """Difference steps: relative for the parameters g depends on nonlinearly (the coil's; the mass in the force
    row), 1 for the linear ones (the loads)."""
    nonlinear = np.arange(len(q)) < (1 if kind == 'force' else COIL_PARAMETERS)   # the force row's: 1/m
    return np.where(nonlinear, 1e-6 * np.maximum(np.abs(q), 1e-300), 1.0)


def _differences(function, z, steps):
    """d function / d z by central differences with `steps` (function maps rows of parameters to rows)."""
    shifted = function(np.concatenate((z + np.diag(steps), z - np.diag(steps))))
    n = len(z)
    return ((shifted[:n] - shifted[n:]) / (2.0 * steps[:, None])).T


def initial_guess(statistics, sample_period):
    """Parameters q from the coefficients read as they are for a short sample period (a start for the fit)."""
    ts = sample_period
    with np.errstate(all='ignore'):
        if 'force' in statistics:
            t = statistics['force'].theta
            return np.concatenate(([1.0], t[1:])) / t[0]
        velocity = 'electrical_velocity' in statistics
        e = statistics['electrical_velocity' if velocity else 'electrical'].theta
        mech = statistics['mechanical_velocity' if velocity else 'mechanical'].theta
        decay, gain = e[0], e[2 if velocity else 1]
        r = (1.0 - decay) / gain
        h = -math.log(decay) if 0.0 < decay < 1.0 else 5.0   # a decay beyond resolution: L somewhere below
        km = -e[1] / gain if velocity else -e[2] / gain
        if velocity:   # [P_vI, P_vv, G_v, loads]: P_vI ~ Km Ts / m, P_vv ~ exp(-B Ts / m)
            m = km * ts / mech[0]
            b = -m * math.log(mech[1]) / ts if mech[1] > 0.0 else m / ts
            loads = np.concatenate((-mech[3:4], mech[4:])) * m / ts
        else:   # restricted to the first-order form [-B/m, Km/(2m), Km/(2m), 0, 0, -Fl/m, p/m...]: the free
            # coefficients are poorly conditioned at high sample rates (nearly equal currents, weak instruments)
            extra = len(mech) - 6
            restricted = statistics['mechanical'].restrict(block_diag(FIRST_ORDER['mechanical'][0], np.eye(extra)))
            m = km / restricted[1]
            b = -m * restricted[0]
            loads = np.concatenate((-restricted[2:3], restricted[3:])) * m
        return np.concatenate(([r, r * ts / h, km, m, b], loads))


def parameter_names(statistics):
    """The parameters q of these regressions, in the order of coefficients()."""
    nominal = MODEL_PARAMETERS['mechanical'] if 'force' in statistics else PARAMETER_NAMES
    return nominal + _effect_names(statistics)


def physical(model, statistics, sample_period, start=None):
    """(names, values, covariance) of `model`'s parameters (and the online effects') from {kind: Statistics},
    their covariance from the sensor-noise model (noise.py); start: parameters q to start the fit from."""
    return reported(model, statistics, *fit(statistics, sample_period, start=start))


def fit(statistics, sample_period, noise=True, start=None):
    """(q, covariance) of all parameters (parameter_names order): weighted by the sensor-noise model's covariance
    of the coefficients, or (noise=False, for per-frame use) as if the rows' errors were white, which gives the
    same parameters when the model fits and costs far less."""
    with np.errstate(all='ignore'):
        if noise and start is not None and np.all(np.isfinite(start)):
            q = np.asarray(start, dtype=float)   # a close start (online, a trajectory): the noise model about it
        else:
            white = {kind: _white_covariance(s) for kind, s in statistics.items()}
            q, covariance = _minimum_distance(statistics, white, sample_period, start)
            if not noise or not np.all(np.isfinite(q)):
                return q, covariance
        # the noise model about the model's own coefficients (the free ones scatter widely at high rates)
        stiff = stiffness_index(statistics)
        fitted = {kind: (np.eye(len(s.theta)), coefficients(kind, q, sample_period, stiffness=stiff))
                  for kind, s in statistics.items()}
        variances = noise_variances(statistics, fitted, sample_period)
        if not any(v > 0 for v in variances.values()):   # noise-free: the white weights are all there is
            white = {kind: _white_covariance(s) for kind, s in statistics.items()}
            return _minimum_distance(statistics, white, sample_period, q)
        covariances = coefficient_covariances(statistics, fitted, variances, sample_period)
        return _minimum_distance(statistics, covariances, sample_period, q)


def _white_covariance(stats):
    """The coefficients' covariance for white row errors: s^2 A^-1 S A^-T, A the normal equations' matrix, S the
    instruments' (or regressors') squared-weight moment, s^2 the residuals' mean square."""
    inverse = stats.covariance
    products = stats.residual_products(np.eye(len(stats.theta)), stats.theta)
    weight = stats.weight if stats.weight > 0 else 1.0
    # at least (RESOLUTION x the output's RMS)^2: noise-free records would leave rounding, whose covariance spans
    # more decades than a weight can (the fit would lose the well-determined directions)
    spread = max(products[0], RESOLUTION ** 2 * stats.lags[0, -1, -1]) / weight
    return spread * inverse @ stats.instrument_lags[0] @ inverse.T


def _minimum_distance(statistics, covariances, sample_period, start):
    """(q, covariance of q): g(q) fitted to the regressions' coefficients with weights from `covariances`, from
    `start`, or (None) from each of starts() keeping the best fit.

    A current sensor's offset I0 or a drive's voltage offset puts a constant into the electrical regression that
    the physics (the load force's tiny gain into the current) cannot meet: fitted to it, R, L, Km and m go
    anywhere (R = 9e6 ohm for 0.28 A on a voice coil). So the fit is also made with that constant free (a
    nuisance, dropped from q), and the free fit is kept where it is better by more than OFFSET_EVIDENCE times
    the misfit per degree of freedom; the fixed one otherwise, since freeing the constant costs the information
    a mean current carries about R (a spring held by the coil)."""
    kinds = list(statistics)
    theta = np.concatenate([statistics[k].theta for k in kinds])
    whiten = _block_whitening([covariances[k] for k in kinds])
    starts = starts_for(statistics, sample_period) if start is None else [np.asarray(start, dtype=float)]
    starts = [q for q in starts if np.all(np.isfinite(q))]
    n = len(parameter_names(statistics))
    if not (starts and np.all(np.isfinite(theta)) and np.all(np.isfinite(whiten))):
        return np.full(n, np.nan), np.full((n, n), np.nan)
    coil = 0 if 'force' in statistics else COIL_PARAMETERS   # the parameters scaled by the first start's
    scale = np.where(np.arange(n) < coil, np.abs(starts[0]), 1.0)
    scale[scale == 0.0] = 1.0
    offset = _offset_column(statistics)
    free = whiten[:, [] if offset is None else [offset]]   # the free constant's column in the residual

    stiff = stiffness_index(statistics)

    def g(z):   # the coefficients of all regressions for scaled parameters z (rows of z)
        q = z * scale
        motion = None if 'force' in statistics else transition(q, sample_period, stiff)
        return np.concatenate([coefficients(k, q, sample_period, motion, stiff) for k in kinds], axis=-1)

    def residual(z):   # z: the scaled parameters, then the free constants (none or one)
        return whiten @ (g(z[:n]) - theta) + free[:, :len(z) - n] @ z[n:]

    def jacobian(z):
        steps = np.where(np.arange(n) < COIL_PARAMETERS, 1e-6 * np.maximum(np.abs(z[:n]), 1e-3), 1.0)
        if stiff is not None:   # k enters nonlinearly: relative to it, or to the mass's m / Ts^2
            steps[stiff] = 1e-6 * max(abs(z[stiff]), abs(z[3] * scale[3]) / sample_period ** 2)
        return np.column_stack((whiten @ _differences(g, z[:n], steps), free[:, :len(z) - n]))

    def best_fit(starts):
        best = None
        for z0 in starts:
            try:
                fit = least_squares(residual, z0, jac=jacobian, method='lm', xtol=1e-12, ftol=1e-12,
                                    max_nfev=MAX_EVALUATIONS)
            except ValueError:   # a start where the model is not finite
                continue
            if np.isfinite(fit.cost) and not _ran_away(fit.x[:coil]) and (best is None or fit.cost < best.cost):
                best = fit
        return best

    best = best_fit([q0 / scale for q0 in starts])   # the constant as the physics fixes it
    # and free, kept where it is better by far (it cannot gain more than the whole misfit: no try when that is small)
    if best is not None and offset is not None and best.cost > 0.5 * OFFSET_EVIDENCE:
        # from the given start alone (online, each frame: one more fit, not two), else also from the fixed one's
        loose = best_fit([np.append(z0, 0.0) for z0 in ([] if start is not None else [best.x]) + [starts[0] / scale]])
        spread = None if loose is None else 2.0 * loose.cost / max(len(theta) - n - 1, 1)   # chi-square per dof
        if loose is not None and best.cost - loose.cost > 0.5 * OFFSET_EVIDENCE * max(spread, 1.0):
            best = loose
    try:
        j = jacobian(best.x)
        covariance = np.linalg.inv(j.T @ j)[:n, :n]
    except (AttributeError, ValueError, np.linalg.LinAlgError):   # (no start converged: best is None)
        return np.full(n, np.nan), np.full((n, n), np.nan)
    # a Birge ratio: coefficients that g(q) meets only beyond their covariance (a closed loop feeding the noise
    # back into the voltage, an effect the model lacks) spread q more than (J' W J)^-1 says
    misfit = 2.0 * best.cost / max(len(theta) - len(best.x), 1)
    return best.x[:n] * scale, max(misfit, 1.0) * covariance * np.outer(scale, scale)


def _ran_away(z):
    """Whether the coil's parameters z, scaled by the first start's, left that scale by more than RUNAWAY: on a
    record the model cannot fit (samples misaligned), the misfit may fall without end along a line where R, Km, m
    grow together, and where Levenberg-Marquardt stops on it (R = 4e11 ohm) is decided by rounding: no estimate."""
    return bool(np.max(np.abs(z), initial=0.0) > RUNAWAY)


def _offset_column(statistics):
    """The index, among all regressions' coefficients in order, of the electrical regression's constant (None
    without one)."""
    at = 0
    for kind, s in statistics.items():
        if kind in ('electrical', 'electrical_velocity'):
            return at + COLUMNS[kind].index('one')
        at += len(s.theta)
    return None


def starts_for(statistics, sample_period):
    """Where the fit starts without an estimate to start from: initial_guess, and with coil signals the same with
    the coil's L/R at a few multiples of the sample period and the mass at a few multiples of its guess's size
    (at sample periods of several L/R the guess is poor, and the fit has local minima); the best fit wins."""
    q0 = initial_guess(statistics, sample_period)
    if 'force' in statistics:
        return [q0]
    r, mass = abs(q0[0]), abs(q0[3])
    return [q0] + [np.concatenate(([r, r * sample_period / h], q0[2:3], [mass * f], q0[4:]))
                   for h in DECAYS for f in MASS_FACTORS]


def _block_whitening(blocks):
    """W with W' W the inverse of the block-diagonal covariance (eigenvalues floored relative to each block's
    largest, after scaling to unit diagonal)."""
    size = sum(len(b) for b in blocks)
    whiten, at = np.zeros((size, size)), 0
    for c in blocks:
        n = len(c)
        d = np.sqrt(np.abs(np.diag(c)))
        d[~(d > 0)] = 1.0
        w, v = np.linalg.eigh((c + c.T) / 2.0 / np.outer(d, d))
        w = np.maximum(w, 1e-14 * max(w.max(), 1e-300))
        whiten[at:at + n, at:at + n] = (v / np.sqrt(w)).T / d
        at += n
    return whiten


def stiffness_index(statistics):
    """The index in q (parameter_names) of a stiffness column's parameter (a spring's k), or None."""
    if 'force' in statistics:
        return None
    first = next(iter(statistics.values()))
    for j, effect in enumerate(first.effects):
        if effect.stiffness:
            return COIL_PARAMETERS + 1 + j
    return None


def _effect_names(statistics):
    """The parameters of the online effects' columns (every regression has the same ones)."""
    first = next(iter(statistics.values()))
    return tuple(e.parameter for e in first.effects)


def reported(model, statistics, values, covariance):
    """(names, values, covariance) of `model`'s parameters (and the online effects') from those of all q."""
    names = parameter_names(statistics)
    # the electrical model reports the coil's own: the effects (forces) are the mechanical equation's
    reported = MODEL_PARAMETERS[model] + (() if model == 'electrical' else _effect_names(statistics))
    keep = [names.index(n) for n in reported]
    return reported, values[keep], covariance[np.ix_(keep, keep)]
