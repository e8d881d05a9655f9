"""Issue 21 (identification at any sample rate), measured: `emla identify` (greybox.identify) against a reference
estimator built on the exact zero-order-hold discretisation, on the Table 1 actuator logged at several rates by a
generator independent of emla_sim (tests/independent_data.py: the linear plant discretised exactly by
scipy.signal.cont2discrete, PD position loop with dither, 5 mA current noise, 1 um position quantisation).

Run: .venv/bin/python scripts/sample_rates.py [rates in Hz, comma-separated] [seeds]   (about a minute)

Per rate and parameter: the largest |error| in % over the seeds, the mean reported one-sigma in %, and the largest
|error| / sigma.

The reference estimator (exact_zoh) is a measurement aid, not part of the suite. With the state [I, x, v], the
inputs [u, Fl] and Phi, Gamma = expm of the continuous model over Ts, the velocity is eliminated exactly:

    I_k+1 = (Phi_II - Phi_Iv Phi_xI / Phi_xv) I_k + (Gamma_I - Phi_Iv Gamma_x / Phi_xv) u_k
            + (Phi_Iv / Phi_xv) (x_k+1 - x_k) + const                                       (electrical)
    x_k+2 - x_k+1 = Phi_vv (x_k+1 - x_k) + Phi_xI I_k+1 + (Phi_xv Phi_vI - Phi_vv Phi_xI) I_k
                    + Gamma_x u_k+1 + (Phi_xv Gamma_v - Phi_vv Gamma_x) u_k + const          (mechanical)

Both are linear in their 4 + 6 coefficients and exact for the continuous plant at any Ts. They are solved by
instrumental variables (instruments: the regressors' signals one, resp. two, samples earlier), with a
Newey-West sandwich covariance; the six physical parameters follow by minimum distance (the coefficients'
covariance as weight, Gauss-Newton through scipy.optimize.least_squares), their covariance from its Jacobian.
"""
import sys
from pathlib import Path

import numpy as np
from scipy.linalg import expm
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / 'tests'))
import independent_data  # noqa: E402

from emla_identification.greybox import identify  # noqa: E402

TRUTH = {'resistance': 4.0, 'inductance': 1.6e-3, 'emf_constant': 10.8, 'mass': 0.036, 'damping': 2.0,
         'load_force': 0.0}   # Table 1
NAMES = tuple(TRUTH)


def exact_coefficients(p, ts):
    """The 4 electrical and 6 mechanical coefficients of the exact relations (module doc) for parameters p."""
    r, ind, km, m, b, fl = p
    a = np.zeros((5, 5))
    a[:3, :3] = [[-r / ind, 0.0, -km / ind], [0.0, 0.0, 1.0], [km / m, 0.0, -b / m]]
    a[0, 3], a[2, 4] = 1.0 / ind, -1.0 / m
    e = expm(a * ts)
    P, G, F = e[:3, :3], e[:3, 3], e[:3, 4] * fl
    electrical = [P[0, 0] - P[0, 2] * P[1, 0] / P[1, 2], G[0] - P[0, 2] * G[1] / P[1, 2], P[0, 2] / P[1, 2],
                  F[0] - P[0, 2] * F[1] / P[1, 2]]
    mechanical = [P[2, 2], P[1, 0], P[1, 2] * P[2, 0] - P[2, 2] * P[1, 0], G[1], P[1, 2] * G[2] - P[2, 2] * G[1],
                  F[1] + P[1, 2] * F[2] - P[2, 2] * F[1]]
    return np.array(electrical + mechanical)


def _iv(phi, y, z, lags=5):
    """IV solution and its Newey-West (Bartlett, `lags`) sandwich covariance; columns scaled for conditioning."""
    sp, sz = np.sqrt(np.mean(phi ** 2, 0)), np.sqrt(np.mean(z ** 2, 0))
    phi, z = phi / sp, z / sz
    theta = np.linalg.solve(z.T @ phi, z.T @ y)
    g = z * (y - phi @ theta)[:, None]
    middle = g.T @ g
    for lag in range(1, lags + 1):
        c = (1.0 - lag / (lags + 1.0)) * (g[lag:].T @ g[:-lag])
        middle += c + c.T
    a = np.linalg.inv(z.T @ phi)
    return theta / sp, a @ middle @ a.T / np.outer(sp, sp)


def exact_zoh(ts, voltage, current, position, start=None):
    """(parameters, one-sigma) in NAMES order from the exact relations (module doc)."""
    u, i, x = (np.asarray(s, dtype=float) for s in (voltage, current, position))
    k = np.arange(3, len(x) - 2)
    one = np.ones(len(k))
    te, ce = _iv(np.column_stack((i[k], u[k], x[k + 1] - x[k], one)), i[k + 1],
                 np.column_stack((i[k - 1], u[k - 1], x[k] - x[k - 1], one)))
    tm, cm = _iv(np.column_stack((x[k + 1] - x[k], i[k + 1], i[k], u[k + 1], u[k], one)), x[k + 2] - x[k + 1],
                 np.column_stack((x[k - 1] - x[k - 2], i[k - 1], i[k - 2], u[k - 1], u[k - 2], one)))
    theta = np.concatenate((te, tm))
    covariance = np.zeros((10, 10))
    covariance[:4, :4], covariance[4:, 4:] = ce, cm
    d = np.sqrt(np.diag(covariance))
    w, v = np.linalg.eigh(covariance / np.outer(d, d))
    whiten = (v / np.sqrt(np.maximum(w, 1e-14 * w.max()))).T / d   # whiten @ whiten.T ~ covariance^-1
    scale = np.array([1.0 if n == 'load_force' else TRUTH[n] for n in NAMES]) if start is None else start
    fit = least_squares(lambda q: whiten @ (exact_coefficients(q * scale, ts) - theta), np.full(6, 1.05),
                        method='lm')
    sigma = np.sqrt(np.diag(np.linalg.inv(fit.jac.T @ fit.jac)))
    return fit.x * scale, sigma * scale


def greybox(ts, voltage, current, position):
    result = identify(sample_period=ts, voltage=voltage, current=current, position=position)
    return (np.array([result.parameters[n] for n in NAMES]), np.array([result.std[n] for n in NAMES]))


def main(rates=(1000, 2000, 5000, 10000, 20000), seeds=range(1, 7)):
    truth = np.array([TRUTH[n] for n in NAMES])
    for label, estimator in (('emla identify (greybox.identify)', greybox), ('exact ZOH reference', exact_zoh)):
        print(f'\n{label}: max |error| %, mean sigma %, max |error|/sigma over seeds {list(seeds)}')
        print('   rate  h=RTs/L ' + ''.join(f'{n:>26s}' for n in NAMES[:5]))
        for rate in rates:
            ts = 1.0 / rate
            runs = []
            for seed in seeds:
                _, u, i, x = independent_data.simulate(duration=1.0, sample_period=ts, seed=seed, truth=TRUTH)
                runs.append(estimator(ts, u, i, x))
            values, sigmas = (np.array(r)[:, :5] for r in zip(*runs, strict=True))
            error = values - truth[:5]
            cells = [f'{100 * np.abs(error[:, j] / truth[j]).max():7.3f} {100 * sigmas[:, j].mean() / truth[j]:7.3f}'
                     f' {np.abs(error[:, j] / sigmas[:, j]).max():6.1f}  ' for j in range(5)]
            print(f'{rate:7.0f} {TRUTH["resistance"] * ts / TRUTH["inductance"]:6.2f}   ' + ''.join(cells), flush=True)


if __name__ == '__main__':
    main(tuple(float(r) for r in sys.argv[1].split(',')) if len(sys.argv) > 1 else (1000, 2000, 5000, 10000, 20000),
         range(1, int(sys.argv[2]) + 1) if len(sys.argv) > 2 else range(1, 7))
