"""The uncertainty a candidate's continuous setting adds to every estimate (a delay, a filter's time constant, a
fade current, a thermal time constant: Candidate.scale).

The workflow searches such a setting, then fits the linear parameters with it held. The fit's jackknife (fit.py)
then treats it as known, yet the nominal parameters can hang on it steeply: after a 3-sample sensor delay at
5 kHz, 0.003 samples of it move the inductance 0.25 %, fifty of its jackknife sigmas. So the setting is profiled
in every leave-one-block-out fit: each such fit's residual sum of squares on the blocks it kept is taken at the
setting and STEP either side (one linearised pass each, about the model the fit was linearised about), the
parabola's vertex is that fit's own setting, and its estimates are moved to it along their slope. The jackknife
of those moved estimates carries the setting's share; the spread of the vertices is the setting's own sigma.
"""
from dataclasses import replace

import numpy as np

from .fit import jackknife_std, solve

STEP = 0.02    # relative step of a setting either side of its estimate
REACH = 3.0    # steps: a vertex further out than this is taken at it (the parabola is a local fit)


def realigned(raw, candidates):
    """The data `candidates` re-align, in order, from the recorded `raw` data (what the workflow's stages did)."""
    data = raw
    for candidate in candidates:
        data = candidate.realigned(data)
    return data


def finer(fit, raw):
    """The Fit `fit` solved again, about the same model and weighted alike, on the data its candidates re-align
    from the recorded `raw` with finer interpolators (Data.finer); None where they interpolate nothing
    (no fractional shift of the position, no position filter undone). The estimates' change bounds what the
    interpolation leaves in them (fit.with_systematic): a position 0.637 samples late at 2 kHz beside a
    position-dependent inductance left Km and m 0.26 % low, 3.7 jackknife sigmas (docs/physics.md 3.5)."""
    data = realigned(replace(raw, finer=True), fit.candidates)
    if np.array_equal(data.signals['position'], fit.data.signals['position']):
        return None
    return solve(data, fit.candidates, fit.linearised_about, fit.sigma, added=fit.linearised_added,
                 weights=fit.weights)


def profiled(fit, raw):
    """(nominal parameters' one-sigma {name: value}, added ones' one-sigma array, {candidate index: its setting's
    one-sigma}) of a Fit with every continuous setting profiled (module doc); None when it has none."""
    scaled = [i for i, c in enumerate(fit.candidates)
              if c.scale is not None and 0.0 < getattr(c, c.scale) < np.inf]
    if not scaled:
        return None
    moved = fit.left_out.copy()
    setting_std = {}
    for i in scaled:
        candidate = fit.candidates[i]
        value = getattr(candidate, candidate.scale)
        sides = []
        for factor in (1.0 - STEP, 1.0 + STEP):
            candidates = fit.candidates[:i] + (candidate.at(raw, value * factor),) + fit.candidates[i + 1:]
            sides.append(solve(realigned(raw, candidates), candidates, fit.linearised_about, fit.sigma,
                               added=fit.linearised_added, weights=fit.weights))
        low, high = sides
        slope = (high.kept - low.kept) / 2.0
        curvature = (high.kept + low.kept) / 2.0 - fit.kept
        # each left-out fit's own setting, in steps from the estimate (REACH where its parabola has no minimum)
        vertex = np.where(curvature > 0, -slope / (2.0 * np.where(curvature > 0, curvature, 1.0)),
                          -np.sign(slope) * REACH)
        vertex = np.clip(vertex, -REACH, REACH)
        moved += vertex[:, None] * (high.left_out - low.left_out) / 2.0
        setting_std[i] = float(value * STEP * jackknife_std(vertex[:, None])[0])
    width = len(fit.shift)
    spread = jackknife_std(moved)
    return dict(zip(fit.std, map(float, spread[:width]))), spread[width:], setting_std
