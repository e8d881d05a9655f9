"""Rank the candidates against a model: each at its best variant (its grid of settings searched on one-pass
fits' held-out error, a continuous setting refined between its neighbours), refitted and judged."""
from dataclasses import replace

import numpy as np
from scipy.optimize import minimize_scalar

from emla_core.errors import InputError

from .fit import fit, greybox_start, physical
from .judge import MOST, forbidden, judged
from .measures import adequacy_of, heldout_errors, heldout_total, least_left
from .noise import gains, noise_free_error, noise_free_of
from .rows import nominal_names

REFINE_TOLERANCE = 1e-3   # of a continuous setting's logarithm: its relative precision after the grid


def rank(base, candidates, progress=None, stage='ranking'):
    """Assessments of `candidates` added to the model `base` (a Fit), best score first; `progress(stage, done,
    total, name)` (workflow.Progress), if given, is told each candidate's name before it is assessed."""
    candidates = list(candidates)
    assessments = []
    for candidate in candidates:
        if progress is not None:
            progress(stage, len(assessments), len(candidates), candidate.name)
        assessments.append(assess(base, candidate))
    return sorted(assessments, key=lambda a: -a.score)


def assess(base, candidate, variants=None):
    """The candidate at its best variant of `variants` (default: all its variants; held-out error of a one-pass fit,
    a continuous setting refined between its grid's neighbours), refitted and judged.

    A candidate that re-aligns the data (a sensor's delay) moves the optimum of every nominal parameter: the base
    model, identified on the misaligned data, can be so far from it that one linearised step lands on an
    impossible actuator (a 3-sample delay at 5 kHz: R half, L four times the truth). Where the fit is impossible
    or removes most (MOST) of the held-out error, its variants are searched again, and it is fitted, about the
    grey-box estimate of the data as its best variant re-aligns them; the fit that predicts the held-out blocks
    better is kept."""
    variants = variants or candidate.variants(base.data)
    best, result = _best_reading(base, variants, base.linearised_about)
    moved = best.realigned(base.data)
    result = result or fit(moved, base.candidates + (best,), base)
    if moved is not base.data and (not physical(result.parameters) or
                                   heldout_total(result) <= (1.0 - MOST) * base.heldout.sum()):
        start = _realigned_start(moved)
        if start is not None:
            again = _best_reading(base, variants, start)[0]
            result = min((result, fit(again.realigned(base.data), base.candidates + (again,), base, about=start)),
                         key=heldout_total)
    return _within_signs(base, judged(base, result))


def _within_signs(base, assessment):
    """The assessment refitted with the parameters it resolves at a sign physics forbids held at zero (pinned), the
    bound they cross, while some are and others stay free; itself when none are. The constrained optimum lies on
    the bound: a dead-time drop made negative to take up a force constant's variation in the back-EMF is no dead
    time, and the offset beside it may still be one; a friction's contact damping made negative by a breakaway
    above the sliding level leaves the Coulomb level, then the Stribeck candidate, to explain it."""
    while not assessment.plausible:
        result = assessment.fit
        best, part = result.candidates[-1], result.added_slices()[-1][1]
        wrong = forbidden(best, result.added[part], result.added_std[part])
        if not wrong or len(best.pinned) + len(wrong) >= len(best.parameters):
            break
        pinned = replace(best, pinned=best.pinned + wrong)
        assessment = judged(base, fit(pinned.realigned(base.data), base.candidates + (pinned,), base))
    return assessment


def _best_reading(base, variants, about):
    """(_best_variant, None); where the candidate reads the signals in several ways (Candidate.reading),
    _best_variant of each, and of those the one whose fit leaves the least disagreement (least_left, as _chosen),
    with that fit. The held-out error rewards a reading that shares the rows' own noise: a
    friction's velocity over a narrow cubic carries the position quantiser's noise that the force balance holds
    too, and at 10 kHz it was chosen for a tanh over 5 mm/s, v_s read 16 % low and the force balance left at 3.3
    times its floor (the wide cubic: 1 %, 2.1)."""
    key = variants[0].reading
    if key is None:
        return _best_variant(base, variants, about), None
    ways = {}
    for variant in variants:
        ways.setdefault(getattr(variant, key), []).append(variant)
    bests = [_best_variant(base, way, about) for way in ways.values()]
    fits = [fit(best.realigned(base.data), base.candidates + (best,), base) for best in bests]
    best = least_left([adequacy_of(result) for result in fits])
    return bests[best], fits[best]


def _best_variant(base, variants, about):
    """The variant whose one-pass fit, linearised about `about` ({name: value}), predicts the held-out blocks best
    (a continuous setting refined between its grid's neighbours); a re-alignment's on its held-out error less the
    sensor noise it passes into it (noise_free_of, the noise levels fitted to the variant best before that)."""
    def heldout_fit(variant):
        return fit(variant.realigned(base.data), base.candidates + (variant,), base, relinearise=False, about=about)
    if len(variants) == 1:
        return variants[0]
    fits = []   # (variant, each equation's held-out error, noise gains where it re-aligns); the fit of the lowest
    first = None
    for variant in variants:
        result = heldout_fit(variant)
        errors = heldout_errors(result)
        fits.append((variant, errors, gains(result, errors, variants[0])))
        if first is None or np.sum(errors) < heldout_total(first):
            first = result
    noise_free = noise_free_of(first, variants[0])
    best = min(fits, key=lambda f: noise_free(f[2], f[1]))[0]
    if best.scale is not None:
        best = refined(best, variants, lambda v: noise_free_error(heldout_fit(v), noise_free, v), base.data)
    return best


def refined(best, variants, error, data):
    """`best` with its continuous setting (Candidate.scale) at the held-out error's minimum between the grid
    points either side of it (bounded Brent search in the logarithm, to REFINE_TOLERANCE), if lower there."""
    grid = sorted(v for v in {getattr(v, best.scale) for v in variants} if 0.0 < v < np.inf)
    value = getattr(best, best.scale)
    if not 0.0 < value < np.inf:
        return best
    low = max([g for g in grid if g < value], default=value)
    high = min([g for g in grid if g > value], default=value)
    if low == high:
        return best
    search = minimize_scalar(lambda z: error(best.at(data, np.exp(z))), bounds=(np.log(low), np.log(high)),
                             method='bounded', options={'xatol': REFINE_TOLERANCE})
    refined = best.at(data, float(np.exp(search.x)))
    return refined if error(refined) < error(best) else best


def _realigned_start(moved):
    """The grey-box estimate of re-aligned data `moved`, or None (no physical estimate)."""
    try:
        start = greybox_start(moved)
    except InputError:
        return None
    start = {name: float(start[name]) for name in nominal_names(moved)}
    return start if physical(start) else None
