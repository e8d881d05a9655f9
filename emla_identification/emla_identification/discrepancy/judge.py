"""How a candidate effect is judged against a base model: the Assessment and the thresholds it is held to.

Ranking and significance. Every candidate is fitted together with the nominal parameters (fit.py) and
judged on held-out data: the record is cut into FOLDS contiguous blocks, each block is predicted by the
model fitted to the others, and

    score = sum over the equations of (held-out residual sum of squares the candidate removes)
            / (the base model's held-out residual sum of squares),

i.e. the fraction of the base model's out-of-sample one-step error the effect explains (the mechanical
equation's error after the noise-whitening prefilter of fit.py). The best-scoring candidate is named if it
is significant, which it is when
  1. it improves the held-out error in at least MIN_BLOCKS of the FOLDS blocks: a sign test on whole
     blocks, valid however coloured the residuals are inside a block (9 of 10 by chance: p = 0.011); one
     block fewer (8 of 10, p = 0.055) where it removes most (MOST) of the held-out error, which no term that
     fits noise comes near: an effect that grows over the record (a coil warming) barely shows in its first
     blocks, where its gain is the noise's,
  2. its score is at least MIN_SCORE: with N ~ 1e4..1e5 samples any term correlated with a tiny structural
     misfit would pass a test of "different from zero", so an effect has to matter (noise-only data give
     scores below 0.2 %, the effects of physics.md at realistic strengths 39 % and more); or, added, it
     removes at least MIN_SHARE of the disagreement left, which matters however small a share of the one-step
     error it is (a current sensor's 25 mA offset: 27 times the floor in the electrical equation's mean, 4.6 %
     of its one-step error),
  3. its parameters are resolved: some parameter is at least MIN_T jackknife sigmas from zero (block
     jackknife, again robust to coloured residuals; a delay has no continuous parameter), and
  4. those it resolves (MIN_T sigmas from zero) have the sign physics gives them (Candidate.signs: friction
     opposes motion, heating raises R, saturation lowers L; a stiffness may have either sign): a wrong sign
     means the term is patching some other misfit, so such a parameter is held at zero, the bound it crosses
     (Candidate.pinned), and the rest refitted and judged again (_within_signs); freed again where a later
     effect, added, leaves it at the right sign (released).
Fitting noise cannot pass 1 and 2 together: a term that only fits noise predicts held-out blocks worse.
Where several significant candidates remove most (MOST) of it, their scores saturate and the one whose fit leaves
the least disagreement (below) is the one considered (_chosen).
A significant candidate is named if it removes most (MOST) of the held-out one-step error, or if, added, it
removes at least MIN_SHARE of the disagreement left (the low-band residual power above the noise floor, in floor
units, summed over the equations; the share is bounded to [-1, 1], removed_share); otherwise it is a partial
match, and the next evident candidates by score are tried the same way (up to TRIES in all: _named); where none
is named, the verdict stays `unexplained`. A named effect whose form is close but not exact leaves a
disagreement: the verdict is then `unexplained` with the effect named. Up to MAX_EFFECTS effects are named in turn;
the final model is the nominal one with all of them, re-identified jointly. Where it leaves the record unexplained,
a named re-alignment's other forms (which signals are late or filtered) are tried from its stage (_other_form).
"""
from dataclasses import dataclass

import numpy as np

from .adequacy import EQUATION
from .fit import FOLDS, Fit, physical
from .measures import removed_share
from .noise import excess_noise

MIN_BLOCKS = 9


SHOWN_BLOCKS = 7   # better in this many held-out blocks and resolved: the data show it, named or not (shown)


MIN_SCORE = 0.05


MIN_T = 3.0


MIN_SHARE = 0.7


MOST = 0.5         # a significant candidate removing this share of the held-out one-step error is named


RIVAL = 2.0        # a significant candidate this many times better on some equation than the one named: rivals


@dataclass
class Assessment:
    """One candidate, at its best variant, judged against a base model."""

    name: str                   # the effect's name (a candidate may name its result by the sign found)
    fit: Fit                    # base + this candidate, fitted
    score: float
    per_equation: dict          # kind -> fraction of that equation's held-out error removed
    blocks_improved: int
    parameters: dict            # {name: (value, one-sigma)}
    settings: dict
    resolved: bool
    plausible: bool
    share: float = float('nan')  # of the disagreement left that it removes (set when it is the best)

    @property
    def evident(self):
        """Better in enough held-out blocks, resolved, of a possible sign: significant if it also matters."""
        blocks = MIN_BLOCKS - 1 if self.score >= MOST else MIN_BLOCKS
        return self.blocks_improved >= blocks and self.resolved and self.plausible

    @property
    def significant(self):
        return self.evident and (self.score >= MIN_SCORE or self.share >= MIN_SHARE)

    @property
    def shown(self):
        """Better in most held-out blocks (SHOWN_BLOCKS), resolved, of a possible sign and physical: the data show
        the effect, named or not (too small to matter, a score below MIN_SCORE, or a partial match)."""
        return (self.blocks_improved >= SHOWN_BLOCKS and self.score > 0 and self.resolved and self.plausible
                and physical(self.fit.parameters))

    @property
    def named(self):
        """Significant, and it removes most of the held-out one-step error or MIN_SHARE of the disagreement."""
        return self.significant and (self.score >= MOST or self.share >= MIN_SHARE)

    @property
    def evidence(self):
        held = self.fit.candidates[-1].pinned
        params = '; '.join(f'{k} held at 0 (the data asked for a sign physics forbids)' if k in held else
                           f'{k} = {_format(v, s)}' for k, (v, s) in self.parameters.items())
        settings = ', '.join(f'{k} {setting_text(v)}' for k, v in self.settings.items() if isinstance(v, (int, float)))
        equations = ', '.join(f'{EQUATION[k]} {100 * v:.1f} %' for k, v in self.per_equation.items())
        partial = (f'; a partial match: removes only {100 * self.share:.0f} % of the disagreement'
                   if self.significant and not self.named and np.isfinite(self.share) else '')
        return (f'{params or "no parameters"}{f" ({settings})" if settings else ""}; removes {equations} of the '
                f'held-out one-step error; better in {self.blocks_improved}/{FOLDS} held-out blocks'
                f'{"" if self.plausible else "; a parameter of the wrong sign"}{partial}')

    def to_dict(self):
        return {'effect': self.name, 'score': round(self.score, 6), 'significant': bool(self.significant),
                'evidence': self.evidence}


def _format(value, sigma):
    """value +- sigma; 'undefined' for a figure these data do not give (a derived one of the wrong sign)."""
    if not np.isfinite(value):
        return 'undefined'
    return f'{value:.4g} +- {sigma:.2g}' if sigma and np.isfinite(sigma) else f'{value:.4g}'


def setting_text(value):
    """A setting in a line of text: 'unbounded' for an infinite one (a saturation current of a pure quadratic)."""
    return f'{value:.3g}' if np.isfinite(value) else 'unbounded'


def judged(base, result):
    """The Assessment of `result`, the fit of `base` with one more candidate (its last). It is plausible when no
    candidate of the fit, the effects named before it included, has a parameter it resolves at a sign physics
    forbids: on the bench's default record (emla_sim, a 1 N Coulomb friction at 10 kHz) a smooth friction of 1.89 N
    beside it made the Coulomb level -0.90 +- 0.19 N and its contact damping negative, and was named."""
    best = result.candidates[-1]
    heldout = np.maximum(np.nan_to_num(result.heldout, nan=np.inf) - excess_noise(base, result), 0.0)
    gain = base.heldout - heldout   # per block and equation; each equation's share removed, bounded:
    per_equation = [removed_share(b, a) for b, a in zip(base.heldout.sum(axis=0), heldout.sum(axis=0))]
    kinds = result.data.kinds
    _, values, stds = result.each_added(result.added_std)[-1]
    parameters = best.reported(values, stds, result.parameters)
    resolved = not len(values) or bool(np.any((np.abs(values) >= MIN_T * stds)[best.free() > 0]))
    return Assessment(best.effect_name(values), result, float(sum(per_equation)),
                      dict(zip(kinds, map(float, per_equation))), int(np.sum(gain.sum(axis=1) > 0)),
                      parameters, best.settings(), resolved, not crosses_a_sign(result))


def crosses_a_sign(result):
    """Does some candidate of the Fit `result` have a parameter it resolves at a sign physics forbids (forbidden)?"""
    return any(forbidden(c, result.added[part], result.added_std[part]) for c, part in result.added_slices())


def forbidden(candidate, values, stds):
    """The candidate's parameters the data resolve (MIN_T sigmas from zero) at a sign physics forbids (an
    unresolved one's sign is the noise's)."""
    return tuple(name for name, sign, value, std in zip(candidate.parameters, candidate.signs, values, stds)
                 if not (sign * value >= 0 or abs(value) < MIN_T * std))   # (a NaN is forbidden too)
