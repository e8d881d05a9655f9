"""The nominal model's exact regressions linearised about a model (rows.py), augmented by candidate terms, solved
jointly and judged on held-out blocks.

The unknowns are the correction dq of the nominal parameters (one for all equations) and the candidates'
parameters. Rows of the electrical and the mechanical regression are stacked, each weighted by 1/sigma of its
nominal residual; the electrical rows are solved by instrumental variables (their regressors' instruments,
regressors.py, and the candidate columns rows.INSTRUMENT_LAG rows earlier: the current's noise sits in the rows'
regressors and their output), the mechanical ones by least squares. `fit` refits about the result until it stops
moving (Gauss-Newton), so the candidates' columns and the exact rows' Jacobian follow the re-identified model.

The mechanical rows (target, nominal and candidate columns alike, which keeps the estimates unbiased) are
prefiltered by (1 - rho) / (1 - rho q^-1)^2, rho = PREFILTER. The second difference of position multiplies the
white position noise by (1 - q^-1)^2, putting nearly all of it at high frequency where no effect of interest
lives; the prefilter undoes most of that (a partial whitening, as in generalised least squares), so held-out
errors measure the effects rather than the quantisation. rho -> 1 would whiten fully but lets the lowest
frequencies dominate a misspecified nominal fit.

The record is cut into FOLDS contiguous blocks and every block's sums of squares are kept, so each
leave-one-block-out fit and its error on the block it left out cost one small solve. The blocks give the
held-out (cross-validated) residuals and delete-one-block jackknife uncertainties, which stay honest when
residuals are coloured (by correlations shorter than a block).
"""
from dataclasses import dataclass, replace

import numpy as np
from scipy.signal import lfilter

from emla_core.errors import InputError
from emla_core.physics import Candidate
from emla_core.recording import Recording

from ..greybox import identify
from .data import Data, regression_rows
from .rows import bending, has_inductance, nominal_names, rows_of

FOLDS = 10
# A delete-one-block jackknife's sigma has FOLDS - 1 degrees of freedom: an estimate's error in its units follows
# Student's t with as many, whose standard deviation is sqrt(nu / (nu - 2)) times it (JCGM 101:2008, GUM
# Supplement 1, 6.4.9). The sigmas reported take that factor (1.134 for 10 blocks); the significance tests do not.
# Measured on the discrepancy sweep: 1.3 % of the errors beyond 3 jackknife sigmas and 7.9 % beyond 2 (t with 9:
# 1.5 and 7.7 %; a normal 0.27 and 4.6 %).
STUDENT = float(np.sqrt((FOLDS - 1) / (FOLDS - 3)))
PREFILTER = 0.9
RELINEARISATIONS = 6
ENOUGH = 1.0           # chi-square a refit must gain for the next one (_refined)
SYSTEMATIC_PREFILTERS = (0.8, 0.95)   # alternatives whose estimates bound the misfit bias (with_systematic)


def design(data, model, candidates, rho=PREFILTER, added=None, kept=None):
    """{kind: (nominal columns, target, candidate columns)} of the regressions about `model` and the candidates'
    parameters `added` (None: zero); the mechanical rows prefiltered with `rho` (None: not prefiltered), those where
    a candidate holds the part still set to the measured second difference alone. `kept`: a dict that receives each
    regression's Rows."""
    out = {}
    for kind in data.kinds:
        rows = rows_of(data, kind, model)
        if kept is not None:
            kept[kind] = rows
        nominal, target, extra = rows.nominal, rows.target, rows.columns(candidates)
        if added is not None and len(added):
            nominal = nominal + rows.slopes(candidates, added)
        if kind != 'electrical':
            nominal, target, extra = _mechanical(data, rows, candidates, nominal, target, extra, rho)
        out[kind] = (nominal, target, extra)
    return out


def _mechanical(data, rows, candidates, nominal, target, extra, rho):
    held = held_samples(data, candidates)
    if held is not None:   # rows whose whole second difference is stuck: no acceleration, whatever the forces
        k = rows.index
        stuck = (held[k - 1] & held[k] & held[k + 1])[:, None]
        nominal, extra, target = np.where(stuck, 0.0, nominal), np.where(stuck, 0.0, extra), \
            np.where(stuck[:, 0], rows.y, target)
    if rho is None:
        return nominal, target, extra
    # (linear: the model's own columns, the same for every candidate fitted about it, are filtered once)
    own = rows.memoised(('prefiltered', rho), nominal is rows.nominal and target is rows.target,
                        lambda: prefiltered(np.column_stack((nominal, target)), rho))
    return own[:, :-1], own[:, -1], prefiltered(extra, rho)


def prefiltered(columns, rho):
    """The columns through the mechanical rows' prefilter (1 - rho) / (1 - rho q^-1)^2."""
    return lfilter([1.0 - rho], [1.0, -2.0 * rho, rho * rho], columns, axis=0)


def held_samples(data, candidates):
    """Samples at which some candidate holds the part still (Candidate.held), or None."""
    masks = [m for m in (c.held(data) for c in candidates) if m is not None]
    return np.logical_or.reduce(masks) if masks else None


@dataclass
class ModelOnData:
    """The model nominal + `candidates` on `data`: what the subsystem predictions (predict.py) and the residuals
    need, whether the model was fitted here (a Fit) or given."""

    data: Data
    candidates: tuple
    shift: np.ndarray      # the nominal parameters' correction dq from `linearised_about` (nominal_names order)
    added: np.ndarray      # the candidates' parameters, in order
    parameters: dict       # nominal physical parameters (greybox names), + 'sample_period'
    linearised_about: dict  # the model the rows, their Jacobian and the candidates' columns are evaluated about
    linearised_added: np.ndarray | None = None   # and the candidates' parameters (None: zero)

    def added_slices(self):
        """(candidate, slice of `added`) pairs."""
        out, start = [], 0
        for c in self.candidates:
            out.append((c, slice(start, start + len(c.parameters))))
            start += len(c.parameters)
        return out

    def residuals(self):
        """{kind: one-step residual of each regression row (rows: data.regression_rows)}."""
        return {kind: target - nominal @ self.shift - extra @ self.added
                for kind, (nominal, target, extra) in design(self.data, self.linearised_about, self.candidates,
                                                             None, self.linearised_added).items()}


@dataclass(kw_only=True)
class Fit(ModelOnData):
    """The model nominal + `candidates` fitted to `data`, with its uncertainties and held-out blocks."""

    added_std: np.ndarray  # the added parameters' jackknife one-sigma
    sigma: dict            # kind -> the reference's residual std: heldout and kept are in its units
    weights: dict          # kind -> the residual std whose inverse weighs the rows (sigma, or self_weighted's)
    rms: dict              # kind -> this fit's residual std
    heldout: np.ndarray    # (FOLDS, kinds): weighted residual sum of squares of each block when left out
    std: dict              # the nominal parameters' jackknife one-sigma
    left_out: np.ndarray   # (FOLDS, unknowns): the fit without each block ([dq | added])
    kept: np.ndarray       # (FOLDS,): weighted residual sum of squares of each such fit on the blocks it kept
    bounds: np.ndarray     # regression rows of each block: bounds[f] .. bounds[f + 1]
    degrees_of_freedom: int  # of each equation's rows: rows less unknowns

    def each_added(self, added_std):
        """(candidate, its parameters' values, their one-sigma from `added_std`) of each candidate, a pinned
        parameter exactly zero with no std: its zeroed columns leave the solve a round-off value (~1e-16) whose
        round-off std would read as a figure known to 1e-14."""
        return [(c, np.where(c.free() > 0, self.added[part], 0.0), np.where(c.free() > 0, added_std[part], 0.0))
                for c, part in self.added_slices()]

    def heldout_residuals(self):
        """{kind: one-step residual of each regression row, each block's from the fit that left it out}."""
        out = {}
        width = len(self.shift)
        for kind, (nominal, target, extra) in design(self.data, self.linearised_about, self.candidates, None,
                                                     self.linearised_added).items():
            e = np.empty(len(target))
            for f in range(FOLDS):
                r = slice(self.bounds[f], self.bounds[f + 1])
                e[r] = target[r] - nominal[r] @ self.left_out[f, :width] - extra[r] @ self.left_out[f, width:]
            out[kind] = e
        return out


def fit(data, candidates=(), reference=None, *, relinearise=True, about=None):
    """Nominal + candidates fitted to data, linearised about the model `reference` (a Fit) was, or about `about`
    ({name: value}) where given, and weighted like `reference`.

    Without a reference, the nominal model is fitted and serves as one: one Gauss-Newton step from the grey-box
    identification's estimate (the exact rows' minimum distance; the step is within the noise when the model fits,
    and where it does not, its optimum may lie far off or at no finite point: a missing spring lets the mass grow
    without bound, so the grey-box estimate stays the point the candidates are linearised about). With
    `relinearise` the result is refitted about itself (_refined), so that the rows' Jacobian and the candidates'
    columns follow the re-identified model.

    The refits hold the current's path bent by the fitted terms (_fitted). An inductance term's bend is a fixed
    point the refits iterate to, not a Gauss-Newton step: at the form and setting the data have, it converges and
    closes the misfit (docs/physics.md 6.3), but from a saturation current drawn far from the data's (2.8 A for
    10 A) it ran off, the term unresolved and L 19 % off. So where an inductance term bent the
    path in those refits, the model is refined without the bend as well and the better fit (a possible actuator
    first) is kept; a single pass (not `relinearise`: the variant searches) takes no inductance term's bend.
    """
    candidates = tuple(candidates)
    if reference is None:
        reference = nominal_fit(data)
        if not candidates:
            return reference
    about = reference.linearised_about if about is None else about
    result = solve(data, candidates, about, reference.sigma)
    if not relinearise:   # one pass (a variant search): an inductance term's bend needs its refits
        return _bent(data, result, about, False)
    taken = []
    bent = _refined(data, _bent(data, result, about, True, taken), True, taken)
    if not any(taken):   # no inductance term bent a path: the fit without the bend is this one
        return bent
    straight = _refined(data, _bent(data, result, about, False), False)
    return min((bent, straight), key=lambda chain: (not physical(chain.parameters), chi_square(chain, reference.sigma)))


def _bent(data, result, about, inductive, taken=None):
    """`result` solved again with the current's path bent by its fitted terms (_fitted) where they bend it; `taken`:
    a list that receives whether an inductance term bends it (_inductively)."""
    fitted = _fitted(result, inductive)
    if taken is not None:
        taken.append(_inductively(fitted, data, about))
    if 'resistance' in about and bending(fitted, data, about):
        return solve(data, fitted, about, result.sigma)
    return result


def _inductively(candidates, data, model):
    """Does an inductance term of `candidates` bend the current's path in the rows about `model` (rows.bending)?"""
    return 'resistance' in model and any(has_inductance(c) for c in bending(candidates, data, model))


def nominal_fit(data, start=None):
    """The nominal model fitted to data, linearised about `start` ({name: value}; default: the grey-box
    identification's estimate), weighted by its residuals there first, then by the fit's own."""
    start = greybox_start(data) if start is None else start
    weights = {kind: _rms(target) for kind, (_, target, _) in design(data, start, ()).items()}
    return solve(data, (), start, solve(data, (), start, weights).rms)


def _refined(data, result, inductive=True, taken=None):
    """`result` refitted about itself (Gauss-Newton) while a refit still improves the fit by more than ENOUGH
    (chi-square units of the refit's own residuals: a step worth less than about a sigma is not taken further) and
    stays a possible actuator, at most RELINEARISATIONS times. A model that misses an effect may have no finite
    optimum (a missing spring lets the mass grow without bound at ever smaller gains): the refits stop where the
    evidence for moving does. `inductive`: the path bent by the candidates' inductance terms too (_fitted); `taken`:
    a list that receives, for each refit, whether one bends it."""
    for _ in range(RELINEARISATIONS):
        if not physical(result.parameters):
            break
        fitted = _fitted(result, inductive)
        if taken is not None:
            taken.append(_inductively(fitted, data, result.parameters))
        refit = solve(data, fitted, result.parameters, result.sigma, added=result.added, weights=result.weights)
        if not physical(refit.parameters):
            break
        gain, result = chi_square(result, refit.rms) - chi_square(refit, refit.rms), refit
        if gain < ENOUGH:
            break
    return result


def self_weighted(result):
    """The Fit `result` refitted (and refined) with its rows weighed by its own residual std of each equation instead
    of the reference's. The reference's are the nominal model's, where a missing effect swells its equation's: a
    model with the effect then leans on the other equation, whose weak hold on a shared parameter can carry its noise
    (a 770 N/m return spring at 2 kHz: the mass 0.8 % and k 0.85 % off, the force balance left at 14 times its
    floor; weighed by its own, 1.02 times, k within 0.03 %). Weighed by its own, though, an equation that keeps a
    misfit can drag what the other fixes (refine.best_weighted chooses)."""
    data = result.data
    inductive = any(c.fitted for c in result.candidates if has_inductance(c))
    return _refined(data, solve(data, _fitted(result, inductive), result.parameters, result.sigma, added=result.added,
                                weights=result.rms), inductive)


def _fitted(fit, inductive=True):
    """The Fit's candidates, those whose terms bend the current's path (a voltage steep in the current:
    Candidate.path_voltage; with `inductive`, an inductance: path_inductance) holding their values in it: the refit
    about it takes the path the fitted terms give."""
    return tuple(replace(c, fitted=tuple(map(float, fit.added[part])))
                 if _steep(c) or (inductive and has_inductance(c)) else c for c, part in fit.added_slices())


def _steep(candidate):
    """Does the candidate have a voltage that may be steep in the current (Candidate.path_voltage)?"""
    return type(candidate).path_voltage is not Candidate.path_voltage



def chi_square(fit, scale):
    """The residual sum of squares of a Fit, each equation's rows over `scale` (a residual std of each)."""
    return sum((fit.rms[kind] / scale[kind]) ** 2 for kind in fit.rms) * fit.degrees_of_freedom


def greybox_start(data):
    """The nominal parameters the first fit is linearised about: the grey-box identification's (exact rows,
    minimum distance from several starts, so the Gauss-Newton refits begin near the optimum)."""
    model = 'mechanical' if data.kinds == ('force',) else 'full'
    try:
        result = identify(Recording(data.sample_period, dict(data.signals), source=data.source), model=model,
                          points=1, spring=False)   # the workflow names a spring itself (candidates.py)
    except InputError as error:
        reason = str(error).removeprefix(f'{data.source}: ')
        raise InputError(f'{data.source}: the nominal model cannot be identified: {reason}') from None
    return result.parameters


def with_systematic(fit, std=None, added_std=None, alternatives=SYSTEMATIC_PREFILTERS, others=()):
    """(std of the nominal parameters, std of the added ones) of a Fit with a systematic part: the largest
    change of each estimate when the mechanical rows are prefiltered otherwise (a prefilter weighs the
    frequencies differently; estimates that move with it carry a misfit bias the jackknife cannot see), or in
    the fits `others` (the same model solved otherwise: profile.finer), added in quadrature to the jackknife
    sigma (the fit's own, or `std` and `added_std` where given) times STUDENT."""
    std = fit.std if std is None else std
    added_std = fit.added_std if added_std is None else added_std
    alternatives = [solve(fit.data, fit.candidates, fit.linearised_about, fit.sigma, rho, fit.linearised_added,
                          fit.weights) for rho in alternatives] + list(others)
    shift = {k: max(abs(a.parameters[k] - fit.parameters[k]) for a in alternatives) for k in fit.std}
    added_shift = np.max([np.abs(a.added - fit.added) for a in alternatives], axis=0) if len(fit.added) else fit.added
    return ({k: float(np.hypot(STUDENT * s, shift[k])) for k, s in std.items()},
            np.hypot(STUDENT * np.asarray(added_std), added_shift))


def physical(parameters):
    """Whether a parameter set is a possible actuator (finite; R, L, m positive where present)."""
    return all(np.isfinite(v) for v in parameters.values()) and \
        all(parameters.get(name, 1.0) > 0 for name in ('resistance', 'inductance', 'mass'))


def solve(data, candidates, model, sigma, rho=PREFILTER, added=None, weights=None):
    """The Fit of `candidates` about `model` (and their parameters `added`) with row weights 1/weights ({kind: a
    residual std}; default `sigma`), its held-out errors and residual sums of squares in units of `sigma`."""
    regressions = {}
    blocks = design(data, model, candidates, rho, added, regressions)
    kinds = tuple(blocks)
    names = nominal_names(data)
    n = len(names) + sum(len(c.parameters) for c in candidates)
    index = regression_rows(data)
    bounds = np.searchsorted(index * FOLDS // len(data), np.arange(FOLDS + 1))   # contiguous blocks
    # per block and regression: Z'Z and W'Z, Z = [nominal | candidates | target] / sigma, W the instruments
    # (Z itself for least squares)
    sums = np.zeros((FOLDS, len(kinds), n + 1, n + 1))
    instrumented = np.zeros_like(sums)
    for j, kind in enumerate(kinds):
        nominal, target, extra = blocks[kind]
        z = np.column_stack((nominal, extra, target))
        w = z if kind != 'electrical' else np.column_stack((regressions[kind].instruments(candidates), target))
        for f in range(FOLDS):
            zf, wf = z[bounds[f]:bounds[f + 1]], w[bounds[f]:bounds[f + 1]]
            sums[f, j] = zf.T @ zf / sigma[kind] ** 2
            instrumented[f, j] = wf.T @ zf / sigma[kind] ** 2
    weights = sigma if weights is None else weights
    solved = np.array([(sigma[kind] / weights[kind]) ** 2 for kind in kinds])[None, :, None, None]
    weighted, weighted_w = sums * solved, instrumented * solved   # the sums the estimates are solved from
    total, total_w = weighted.sum(axis=(0, 1)), weighted_w.sum(axis=(0, 1))
    theta = _solve_normal(total_w, total, n)
    left_out = np.array([_solve_normal(total_w - weighted_w[f].sum(axis=0), total - weighted[f].sum(axis=0), n)
                         for f in range(FOLDS)])
    heldout = np.array([[_rss(sums[f, j], t, n) for j in range(len(kinds))] for f, t in enumerate(left_out)])
    kept = np.array([_rss(total - weighted[f].sum(axis=0), t, n) for f, t in enumerate(left_out)])
    # residual std of each equation, floored for noise-free data (it becomes a row weight)
    rms = {kind: sigma[kind] * max(np.sqrt(max(_rss(sums[:, j].sum(axis=0), theta, n), 0.0) / (len(index) - n)),
                                   1e-9 * np.sqrt(sums[:, j, n, n].sum() / len(index)))
           for j, kind in enumerate(kinds)}
    q0 = np.array([model[name] for name in names], dtype=float)
    width = len(names)
    return Fit(data=data, candidates=candidates, shift=theta[:width], added=theta[width:],
               parameters=dict(zip(names, map(float, q0 + theta[:width])), sample_period=data.sample_period),
               linearised_about={name: model[name] for name in names}, added_std=jackknife_std(left_out[:, width:]),
               sigma=sigma, weights=dict(weights), rms=rms, heldout=heldout,
               std=dict(zip(names, map(float, jackknife_std(left_out[:, :width])))), left_out=left_out, kept=kept,
               bounds=bounds, degrees_of_freedom=len(index) - n, linearised_added=added)


def _rms(values):
    """Root mean square, floored (a row weight must be positive)."""
    return max(float(np.sqrt(np.mean(np.square(values)))), 1e-300)


def jackknife_std(left_out):
    """Delete-one-block jackknife standard deviation of each column of the leave-one-out estimates."""
    deviation = left_out - left_out.mean(axis=0)
    return np.sqrt((FOLDS - 1) / FOLDS * np.sum(deviation ** 2, axis=0))


def _solve_normal(gw, g, n):
    """theta of the normal equations held in gw = W'Z (instruments; = Z'Z for least squares), Z = [Phi | Y];
    columns scaled by g = Z'Z for conditioning."""
    if not (np.all(np.isfinite(gw)) and np.all(np.isfinite(g))):
        return np.full(n, np.nan)
    scale = np.sqrt(np.diag(g)[:n])
    scale[scale == 0] = 1.0
    return np.linalg.lstsq(gw[:n, :n] / np.outer(scale, scale), gw[:n, n] / scale, rcond=1e-13)[0] / scale


def _rss(s, theta, n):
    return float(s[n, n] - 2.0 * theta @ s[:n, n] + theta @ s[:n, :n] @ theta)
