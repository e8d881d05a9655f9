"""Refine a candidate the workflow names: its setting polished about the model fitted with it, the effects
named before it searched again beside it, their sign pins released, each equation weighed by its own residual
where that leaves less (`added`)."""
from dataclasses import replace

import numpy as np
from scipy.optimize import minimize_scalar

from .fit import fit, physical, self_weighted
from .judge import crosses_a_sign, judged
from .measures import adequacy_of, chi_squares, heldout_total, least_left
from .noise import noise_free_error, noise_free_of, realigns
from .profile import realigned
from .rank import REFINE_TOLERANCE, refined

POLISH = 0.005     # relative step either side of a refined setting, for its parabola (_polished)


POLISHES = 4       # parabola steps at most (polished)


def added(raw, base, assessment):
    """The assessment (`assess`) of a candidate added to the Fit `base`, the data `raw` as recorded, as the workflow
    names it: its setting polished, the settings of the effects before it searched again (backfitted), their pins
    released where it frees them, each equation weighed by its own residual where that leaves less (reweighted)."""
    return reweighted(base, released(base, backfitted(raw, base, polished(base, assessment))))


def polished(base, assessment):
    """The assessment (of a candidate added to `base`) with its continuous setting polished about the model fitted
    with it (_polished) and refitted, again about that refit while the setting moves a whole POLISH step (the
    minimum lay beyond it), up to POLISHES times; itself when the setting stays. The workflow polishes the effects
    it names: the held-out search that ranks them stops at REFINE_TOLERANCE of the setting, but its one-pass fits
    are linearised about the model without the effect, and that can be far from it: a position 2 samples late at
    5 kHz was searched to 1.984 samples and polished once to 1.994, which left the force balance at 9.5 times its
    floor (2.000 leaves it at 0.99)."""
    for _ in range(POLISHES):
        result = assessment.fit
        variant = result.candidates[-1]
        best = _polished(base, variant, variant.variants(base.data), result)
        if best is variant:
            break
        assessment = judged(base, fit(best.realigned(base.data), base.candidates + (best,), base,
                                       about=result.parameters))
        if not _whole_step(variant, best):
            break
    return assessment


def _polished(base, variant, variants, model):
    """`variant` with its continuous setting s at the lowest residual sum of squares (one-pass fits about the Fit
    `model`, which has it) of:
    s, the vertex of the parabola through s and s (1 +- POLISH) (at most POLISH s away), and the grid points of
    `variants` within POLISH s (a whole-sample delay, where the sum's curvature differs either side). The held-out
    search stops at REFINE_TOLERANCE of s, and a delay 0.003 samples off moves an inductance by many sigmas. A
    re-alignment's sums are taken less the sensor noise (noise_free_of)."""
    if variant.scale is None:
        return variant
    value = getattr(variant, variant.scale)
    grid = [getattr(v, variant.scale) for v in variants]
    if not min(grid) <= value * (1.0 - POLISH) < value * (1.0 + POLISH) <= max(grid) < np.inf:
        return variant
    noise_free = noise_free_of(model, variant)

    def chi_square(setting):
        trial = variant.at(base.data, setting)
        result = fit(trial.realigned(base.data), base.candidates + (trial,), base, relinearise=False,
                     about=model.parameters)
        return noise_free_error(result, noise_free, variant, chi_squares(result))
    low, middle, high = (chi_square(value * (1.0 + POLISH * u)) for u in (-1.0, 0.0, 1.0))
    tried = {value: middle}
    curvature = low + high - 2.0 * middle
    if np.isfinite(curvature) and curvature > 0:
        vertex = value * (1.0 + POLISH * float(np.clip((low - high) / (2.0 * curvature), -1.0, 1.0)))
        tried[vertex] = chi_square(vertex)
    for point in grid:
        if point not in tried and abs(point - value) <= POLISH * value:
            tried[point] = chi_square(point)
    return variant.at(base.data, min(tried, key=tried.get))


def _whole_step(variant, best):
    """Did _polished move the continuous setting a whole POLISH step (its parabola's vertex lay beyond)?"""
    before, after = getattr(variant, variant.scale), getattr(best, best.scale)
    return bool(before) and abs(after / before - 1.0) >= (1.0 - 1e-6) * POLISH


def backfitted(raw, base, assessment):
    """The assessment (of a candidate added to `base`, the data `raw` as recorded) with the continuous setting of
    each effect named before it searched again with it in the model, and refitted; itself when none moves, when the
    refit puts a parameter at a sign physics forbids, or when it does not predict the held-out blocks better (a
    re-alignment's less the sensor noise: noise_free_of). An effect named first takes up some of the misfit of one not
    yet in the model: a position sensor 0.637 samples late beside a position-dependent inductance was named at 0.5
    samples (20 sigma off; _searched_again); a Coulomb friction's pre-sliding band named before a magnetic stiffness
    at 6.9 um for 2.1 um, its level held at zero and the force balance left at 16 times its floor (2.1 with the band
    searched again; _chosen_again)."""
    result = assessment.fit
    candidates = result.candidates
    for i, earlier in enumerate(candidates[:-1]):
        if earlier.scale is not None and 0.0 < getattr(earlier, earlier.scale) < np.inf:
            again = (_searched_again if realigns(earlier) else _chosen_again)(raw, base, result, candidates, i)
            candidates = candidates[:i] + (again,) + candidates[i + 1:]
    if candidates == result.candidates:
        return assessment
    again = judged(base, fit(realigned(raw, candidates), candidates, base, about=result.parameters))
    if crosses_a_sign(again.fit):
        return assessment
    changed = [c for c, old in zip(candidates, result.candidates) if c is not old and realigns(c)]
    if not changed:
        return again if heldout_total(again.fit) < heldout_total(result) else assessment
    noise_free = noise_free_of(result, changed[0])
    better = noise_free_error(again.fit, noise_free, changed[0]) < noise_free_error(result, noise_free, changed[0])
    return again if better else assessment


def _searched_again(raw, base, model, candidates, i):
    """Re-alignment candidates[i] at the lowest held-out error less the noise (noise_free_of, at the levels of the
    Fit `model`) of one-pass fits of all `candidates` about `model`, its setting searched within a factor 2
    (bounded Brent search in the logarithm, to REFINE_TOLERANCE); itself where no setting does better."""
    earlier = candidates[i]
    value = getattr(earlier, earlier.scale)
    noise_free = noise_free_of(model, earlier)
    seen = realigned(raw, candidates[:i])   # the data as it was named on

    def error(setting):
        trial = candidates[:i] + (earlier.at(seen, setting),) + candidates[i + 1:]
        return noise_free_error(fit(realigned(raw, trial), trial, base, relinearise=False, about=model.parameters),
                                 noise_free, earlier)
    search = minimize_scalar(lambda z: error(np.exp(z)), bounds=(np.log(value / 2.0), np.log(value * 2.0)),
                             method='bounded', options={'xatol': REFINE_TOLERANCE})
    found = float(np.exp(search.x))
    return earlier.at(seen, found) if error(found) < error(value) else earlier


def _chosen_again(raw, base, model, candidates, i):
    """Effect candidates[i] (one that does not re-align the data) at the variant, over its whole grid and refined
    between the neighbours of the best (refined), whose one-pass fit of all `candidates` about the Fit `model`
    predicts the held-out blocks best; free of the pins its first fit set (a level held at zero beside a misfit
    the later effect explains: released would free it, but only at the setting that misfit chose); itself where no
    variant does better."""
    earlier = candidates[i]
    seen = realigned(raw, candidates[:i])
    moved = realigned(raw, candidates)   # the same for every variant: this effect re-aligns nothing

    def error(variant):
        trial = candidates[:i] + (variant,) + candidates[i + 1:]
        return heldout_total(fit(moved, trial, base, relinearise=False, about=model.parameters))
    variants = earlier.variants(seen)
    best = refined(min(variants, key=error), variants, error, seen)
    return best if error(best) < error(earlier) else earlier


def released(base, assessment):
    """The assessment (of a candidate added to `base`) refitted with the parameters the candidates before it had
    pinned at a sign bound (_within_signs) free again, if then none crosses its sign and the held-out blocks are
    predicted better; itself otherwise. A pin judged a model without the later effects: a Coulomb friction's contact
    damping, made negative by a breakaway above the sliding level, was pinned at zero, and beside the Stribeck
    excess it is positive (at 10 kHz: 54 +- 5 N s/m; the force balance left at 20 times its
    floor, not 52, and Fc 0.3411 N for 0.3410)."""
    result = assessment.fit
    if not any(c.pinned for c in result.candidates[:-1]):
        return assessment
    free = tuple(replace(c, pinned=()) for c in result.candidates[:-1]) + result.candidates[-1:]
    again = fit(result.data, free, base, about=result.parameters)
    if crosses_a_sign(again) or not heldout_total(again) < heldout_total(result):
        return assessment
    return judged(base, again)


def reweighted(base, assessment):
    """The assessment (of a candidate added to `base`) refitted with each equation weighed by its own residual
    where that leaves less disagreement (best_weighted); itself otherwise."""
    again = best_weighted(assessment.fit)
    return assessment if again is assessment.fit else judged(base, again)


def best_weighted(result):
    """The Fit `result`, where it leaves some equation above its floor, refitted with each equation weighed by its
    own residual (fit.self_weighted), if then none of its candidates' parameters crosses its sign and the fit leaves
    less disagreement (least_left, as _chosen compares leaders); `result` itself otherwise. The emla_sim twin of a
    Coulomb friction at 10 kHz keeps its force balance at 14 times the floor either way; weighed by its own, it
    drags L 6 % and leaves the electrical equation at 14 times too: not taken. A fit within its floors is kept as
    it is: there the weights move the estimates within the noise."""
    if all(a.adequate for a in adequacy_of(result).values()):
        return result
    again = self_weighted(result)
    if not physical(again.parameters) or crosses_a_sign(again):
        return result
    return (result, again)[least_left([adequacy_of(result), adequacy_of(again)])]
