"""Where a disagreement lies: which signal a residual is a smooth function of.

The residual is low-passed (a centred mean over SMOOTHING: the sensor noise is mostly high-frequency, the
effects slower) and explained by a step function of a signal (one level per each of QUANTILES bins of it)
together with the model's own regressors: a fit has already taken out of the residual whatever its terms
could absorb (a drag c v|v| leaves c v|v| minus a damping share), so the function is judged beside them
(added-variable regression). The fraction of what the regressors alone leave that the function explains
ranks the signals. Where no single signal explains much, pairs are tried on a grid of bins of both. A new
candidate effect's term must depend on the signal (or pair) at the top.
"""
import itertools

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import savgol_filter

SMOOTHING = 1e-3     # s
QUANTILES = 24       # bins of one signal
PAIR_QUANTILES = 8   # bins of each signal of a pair
PAIR_GAIN = 0.15     # a pair is listed when it explains this much more than the best single signal
SINGLE_ENOUGH = 0.6  # a single signal explaining this much needs no pair


def signals_of(data, index):
    """{name: values at regression rows `index`} of the signals a residual may depend on."""
    ts = data.sample_period
    x = data.signals['position']
    window = min(21, len(x) // 2 * 2 - 1)
    out = {'time': data.time[index], 'position': x[index],
           'velocity': savgol_filter(x, window, 3, deriv=1, delta=ts)[index],
           'acceleration': savgol_filter(x, window, 3, deriv=2, delta=ts)[index]}
    drive = data.drive
    out[drive] = data.signals[drive][index]
    out[f'{drive} rate'] = savgol_filter(data.signals[drive], window, 3, deriv=1, delta=ts)[index]
    if data.electrical:
        out['voltage'] = data.signals['voltage'][index]
        out['voltage rate'] = np.gradient(data.signals['voltage'], ts)[index]
    return out


def explained(e, z, basis, bins=QUANTILES):
    """Fraction of what the covariates (orthonormal `basis`, n x p) leave of e that a step function of z
    (quantile bins) explains."""
    return _binned_r2(e, _quantile_bins(z, bins), bins, basis)


def explained_jointly(e, z1, z2, basis, bins=PAIR_QUANTILES):
    return _binned_r2(e, _quantile_bins(z1, bins) * bins + _quantile_bins(z2, bins), bins * bins, basis)


def _quantile_bins(z, bins):
    edges = np.quantile(z, np.linspace(0.0, 1.0, bins + 1)[1:-1])
    return np.searchsorted(edges, z, side='right')


def _binned_r2(e, which, bins, basis):
    """The regression of e on [step function of the bins | basis], through sums over the bins: with B the
    bins' indicator columns and Q the basis, the steps explain w' r of what Q leaves, where
    (B'B - (Q'B)'(Q'B)) w = r = B'(e - Q Q'e) and B'B is the diagonal of the bin counts. O(n) per call."""
    rest = e - basis @ (basis.T @ e)
    spread = rest @ rest
    if spread <= 0:
        return 0.0
    qb = np.stack([np.bincount(which, column, minlength=bins) for column in basis.T])
    gram = np.diag(np.bincount(which, minlength=bins).astype(float)) - qb.T @ qb
    r = np.bincount(which, rest, minlength=bins)
    w = np.linalg.lstsq(gram, r, rcond=1e-10)[0]
    return float(min(max(r @ w / spread, 0.0), 1.0))


def dependence(residual, signals, regressors, sample_period):
    """({'signal': name, 'explained': fraction} ranked, [{'signals': [a, b], 'explained': fraction}]) of a
    residual, judged beside the model's `regressors` (rows x terms): the single signals of {name: values at the
    residual's rows} (signals_of), and the pairs that explain clearly more than any single one does (when none
    explains enough)."""
    width = max(1, int(round(SMOOTHING / sample_period)))
    smooth = uniform_filter1d(residual, width, mode='nearest')
    covariates = np.column_stack((uniform_filter1d(regressors, width, axis=0, mode='nearest'),
                                  np.ones(len(residual))))
    scale = np.linalg.norm(covariates, axis=0)
    basis = np.linalg.qr(covariates / np.where(scale > 0, scale, 1.0))[0]
    # the signals are smoothed alike, so a fast one (the current of a stroke) lines up with the smoothed residual
    candidates = {name: uniform_filter1d(z, width, mode='nearest') for name, z in signals.items()}
    singles = {name: explained(smooth, z, basis) for name, z in candidates.items()}
    best = max(singles.values(), default=0.0)
    pairs = []
    if best < SINGLE_ENOUGH:
        for a, b in itertools.combinations(candidates, 2):
            r2 = explained_jointly(smooth, candidates[a], candidates[b], basis)
            if r2 >= best + PAIR_GAIN:
                pairs.append({'signals': [a, b], 'explained': round(r2, 4)})
    ranked = sorted(({'signal': name, 'explained': round(r2, 4)} for name, r2 in singles.items()),
                    key=lambda d: -d['explained'])
    return ranked, sorted(pairs, key=lambda d: -d['explained'])
