"""The model-discrepancy workflow: is the nominal model adequate? If not, name the missing effects one by one
(rank the candidates, add the best, re-identify), until the model is adequate or no candidate explains what
is left; report the gap between model and measurement before and after, and where what is left lies.

Adequacy (adequacy.py): each equation's held-out one-step residual against the floor the sensor noise
alone would leave in it. The verdict: `adequate` (the nominal model fits to the noise floor), `explained`
(the named effects leave nothing), `unexplained` (a disagreement remains that no candidate explains). What
is left is located (dependence.py) on the signals it is a smooth function of.

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
import functools
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike
from scipy.ndimage import uniform_filter1d
from scipy.optimize import minimize_scalar

from emla_core.data import as_recording
from emla_core.errors import InputError
from emla_core.physics import Candidate
from emla_core.recording import Recording

from ..checks import check_magnitudes, numerical_failures
from ..plausibility import plausibility_warnings
from .adequacy import EQUATION, assess_adequacy, heldout_noise, noise_gains, rows_adequacy, sensor_noise
from .candidates import library
from .data import Data, regression_rows
from .dependence import dependence, signals_of
from .fit import FOLDS, STUDENT, Fit, design, fit, greybox_start, nominal_fit, physical, self_weighted, with_systematic
from .predict import MECHANICAL_TIME, predict
from .profile import finer, profiled, realigned
from .residuals import binned, cross_correlation, whiteness
from .rows import nominal_names
from .start import rescue_starts

MIN_BLOCKS = 9
SHOWN_BLOCKS = 7   # better in this many held-out blocks and resolved: the data show it, named or not (shown)
MIN_SCORE = 0.05
MIN_T = 3.0
MIN_SHARE = 0.7
MOST = 0.5         # a significant candidate removing this share of the held-out one-step error is named
REFINE_TOLERANCE = 1e-3   # of a continuous setting's logarithm: its relative precision after the grid
POLISH = 0.005     # relative step either side of a refined setting, for its parabola (_polished)
POLISHES = 4       # parabola steps at most (polished)
MAX_EFFECTS = 4
TRIES = 3          # significant candidates tried in turn for a name when the best is only a partial match
RIVAL = 2.0        # a significant candidate this many times better on some equation than the one named: rivals
SMOOTHING = 1e-3   # s, of the residuals binned against the signals
# The parameters whose terms an equation's residual is judged beside (the exact rows of both coil equations
# depend on all of them, but the voltage's and current's own terms would take what an effect leaves correlated
# with them: a drag ~ v|v| moves into the voltage that the loop turns the velocity error into)
OWN_TERMS = {'electrical': ('resistance', 'inductance', 'emf_constant'),
             'mechanical': ('emf_constant', 'mass', 'damping', 'load_force')}


def method(data):
    """How the gap is measured and the candidates ranked, in one sentence (the JSON's `method`)."""
    electrical = ('current from the measured voltage and the back-EMF velocity of the measured position '
                  '(horizon 5 L/R, a free run in effect), ' if data.electrical else '')
    return (f'k-step-ahead prediction of each subsystem from its measured inputs: {electrical}position from '
            f'the measured {data.drive} (horizon {MECHANICAL_TIME * 1e3:g} ms, started from the measured '
            'position and a model-based local velocity estimate); candidates ranked by the fraction of the '
            f'held-out one-step residual they remove ({FOLDS} contiguous blocks, leave-one-block-out)')


@dataclass
class Assessment:
    """One candidate, at its best variant, judged against a base model."""

    name: str                   # the effect's name (a candidate may name its result by the sign found)
    fit: object                 # base + this candidate, fitted
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
        settings = ', '.join(f'{k} {_setting(v)}' for k, v in self.settings.items() if isinstance(v, (int, float)))
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


def _setting(value):
    """A setting in a line of text: 'unbounded' for an infinite one (a saturation current of a pure quadratic)."""
    return f'{value:.3g}' if np.isfinite(value) else 'unbounded'


@dataclass
class Stage:
    """An effect named and added: the model with it (and those before), how adequate it is, its predictions."""

    assessment: Assessment
    adequacy: dict          # equation -> adequacy.Adequacy of the model with the effect
    predictions: dict       # signal -> Prediction of the model with the effect
    rivals: list = field(default_factory=list)   # significant Assessments the data do not tell from it (rivals)


@dataclass
class Diagnosis:
    data: Data
    nominal: object                  # Fit
    candidates: list                 # Assessments against the nominal model, best first
    nominal_adequacy: dict           # equation -> Adequacy
    before: dict                     # signal -> Prediction of the nominal model
    stages: list = field(default_factory=list)   # Stages, in the order the effects were named
    partial: object = None           # the best candidate after the last stage when it is only a partial match
    remaining: list = field(default_factory=list)   # Assessments of the candidates not named against the final model
    warnings: list = field(default_factory=list)  # the nominal model's implausible values and their likely causes

    @property
    def final(self) -> Fit:
        """The final model: the nominal one with every named effect, re-identified jointly."""
        return self.stages[-1].assessment.fit if self.stages else self.nominal

    @property
    def final_adequacy(self) -> dict:
        return self.stages[-1].adequacy if self.stages else self.nominal_adequacy

    @property
    def after(self) -> dict:
        return self.stages[-1].predictions if self.stages else self.before

    @property
    def main(self) -> Assessment | None:
        """The first effect named, or None."""
        return self.stages[0].assessment if self.stages else None

    @property
    def verdict(self) -> str:
        if not self.stages and all(a.adequate for a in self.nominal_adequacy.values()):
            return 'adequate'
        return 'explained' if all(a.adequate for a in self.final_adequacy.values()) else 'unexplained'

    @functools.cached_property
    def profile(self):
        """profile.profiled of the final model: its sigmas with every continuous setting profiled, or None."""
        return profiled(self.final, self.data)

    @property
    def unnamed(self) -> list:
        """The candidates not named that the data show beside the final model (Assessment.shown): too small to
        name, or a partial match; either may still move the nominal parameters by many sigmas (a dead-time drop of
        5 mV fading over 46 mA, 1.3 times the floor in power: R 0.06 % = 15 sigma, the drop better in 9 of 10
        held-out blocks)."""
        return [a for a in self.remaining if a.shown]

    @functools.cached_property
    def final_std(self):
        """(one-sigma of the final model's nominal parameters, of its added ones): jackknife (every continuous
        setting profiled: profile.py) and systematic (the prefilter's, and a re-alignment's interpolation:
        fit.with_systematic, profile.finer), scaled by the square root of the final model's low-band power
        ratio where it exceeds 1 (a Birge ratio: the parameters take their information from the low band, and a
        model that leaves there more than the noise's power, a form close but not exact, is that much less certain
        than its scatter over the blocks says; against the floor of the noise through the rows alone, rows_adequacy:
        the noise a friction's terms read, which the verdict's floor holds, biases its level as errors in a
        regressor do, 1.3 % on sweep case 210, 4.4 sigma unscaled); and in quadrature the largest difference a
        rival of a named effect (`rivals`) or a candidate the data show but that is not named (`unnamed`) makes to
        each nominal parameter: whether the effect is in the model is a choice the parameters depend on."""
        nominal, added = reported_std(self.final, self.data, self.profile)
        others = [(r, stage.assessment.fit) for stage in self.stages for r in stage.rivals]
        others += [(a, self.final) for a in self.unnamed]
        choice = {k: max([0.0] + [abs(a.fit.parameters[k] - fit.parameters[k]) for a, fit in others])
                  for k in nominal}
        return {k: float(np.hypot(s, choice[k])) for k, s in nominal.items()}, added

    def added_parameters(self) -> dict[str, tuple[float, float]]:
        """{name: (value, one-sigma)} of every named effect's parameters, from the final joint fit."""
        final, added_std = self.final, self.final_std[1]
        settings = self.profile[2] if self.profile else {}
        out = {}
        for i, (candidate, values, stds) in enumerate(final.each_added(added_std)):
            reported = candidate.reported(values, stds, final.parameters)
            if i in settings:   # a figure of the setting alone (a delay, a cutoff) takes its relative sigma
                relative = STUDENT * settings[i] / getattr(candidate, candidate.scale)
                reported = {k: (v, s if s else abs(v) * relative) for k, (v, s) in reported.items()}
            out.update(reported)
        return out

    def held_at_zero(self) -> list[str]:
        """The named effects' parameters held at zero in the final fit (the data asked for a sign physics forbids):
        their value is the bound, their std 0 as no figure of them is estimated."""
        return [name for c in self.final.candidates for name in c.pinned]

    def disagreement(self, model: str = 'final') -> dict[str, dict]:
        """{equation: size against the noise floor and the signals it depends on} of the final (or nominal)
        model."""
        fit, adequacy = (self.final, self.final_adequacy) if model == 'final' else (self.nominal,
                                                                                   self.nominal_adequacy)
        index = regression_rows(fit.data)
        out = {}
        for kind, (nominal, _, extra) in design(fit.data, fit.linearised_about, fit.candidates, rho=None).items():
            a = adequacy[EQUATION[kind]]
            out[a.equation] = a.to_dict()
            if not a.adequate:   # what is left, and what it depends on (beside what the equation's terms explain)
                own = [nominal_names(fit.data).index(name) for name in OWN_TERMS.get(kind, ())] or slice(None)
                singles, pairs = dependence(a.residual, signals_of(fit.data, index),
                                            np.hstack((nominal[:, own], extra)), fit.data.sample_period)
                out[a.equation].update(depends_on=singles[:5], jointly=pairs[:3])
        return out

    def to_dict(self) -> dict:
        verdict = self.verdict
        added = self.added_parameters()
        final = self.final
        effects = []
        for stage in self.stages:
            a = stage.assessment
            effects.append({'effect': a.name,
                            'parameters': {k: v for k, (v, _) in added.items() if k in a.parameters},
                            'std': {k: s for k, (_, s) in added.items() if k in a.parameters},
                            'score': round(a.score, 6), 'share': round(a.share, 4),
                            'gap_after': {s: round(p.nrmse, 6) for s, p in stage.predictions.items()}})
        return {
            'verdict': verdict,
            'missing_effect': self.main.name if self.main else ('none' if verdict == 'adequate' else 'unexplained'),
            'effects': effects,
            'disagreement': self.disagreement('final'),
            'disagreement_nominal': self.disagreement('nominal'),
            'candidates': [a.to_dict() for a in self.candidates],
            'gap_before': {s: round(p.nrmse, 6) for s, p in self.before.items()},
            'gap_after': {s: round(p.nrmse, 6) for s, p in self.after.items()},
            'added_parameters': {k: v for k, (v, _) in added.items()},
            'added_parameters_std': {k: s for k, (_, s) in added.items()},
            'held_at_zero': self.held_at_zero(),
            'nominal_parameters': _rounded(self.nominal.parameters),
            'reidentified_parameters': _rounded(final.parameters),
            'reidentified_parameters_std': _rounded(self.final_std[0]),
            'method': method(self.data),
            'warnings': list(self.warnings) + [
                f'the data do not tell {stage.assessment.name} from {r.name} (each predicts some equation at least '
                f'{RIVAL:g} times better than the other): the re-identified parameters\' uncertainty includes the '
                'difference between the two' for stage in self.stages for r in stage.rivals] + [
                f'the data show {a.name}, not named (better in {a.blocks_improved} of {FOLDS} held-out blocks, it '
                f'removes {100 * a.score:.2g} % of the one-step error): the re-identified parameters\' uncertainty '
                'includes what adding it changes' for a in self.unnamed],
        }


def reported_std(final, raw, profile):
    """(one-sigma of the nominal parameters of the Fit `final`, of its added ones) as reported for a model fitted to
    the recorded data `raw`: the jackknife with every continuous setting profiled (`profile`, profile.profiled of
    the fit, or None), its systematic part (fit.with_systematic: the prefilter's, and a re-alignment's
    interpolation, profile.finer), all scaled by the Birge ratio of the fit's low band (Diagnosis.final_std)."""
    interpolated = finer(final, raw)
    nominal, added = with_systematic(final, *(profile[:2] if profile else ()),
                                     others=(interpolated,) if interpolated else ())
    scale = np.sqrt(max([1.0] + [a.ratio for a in _adequacy(final).values() if np.isfinite(a.ratio)]))
    return {k: s * scale for k, s in nominal.items()}, added * scale


def _rounded(parameters):
    return {k: float(f'{v:.6g}') for k, v in parameters.items()}


def diagnose(data: Recording | Path | str | None = None, names: Sequence[str] | None = None, *,
             sample_period: float | None = None, voltage: ArrayLike | None = None, current: ArrayLike | None = None,
             position: ArrayLike | None = None, force: ArrayLike | None = None) -> Diagnosis:
    """Find what the two-equation actuator model is missing in a record: say whether it is adequate, name the
    missing effects, add them and show the gap shrink, or say where an unexplained disagreement lies.

    The nominal model is identified and its held-out residuals compared with the sensor-noise floor. If it
    does not fit to that floor, each candidate effect (those of the physics layer, emla_core.physics, and any
    added with `register_candidate`) is judged by the share of the held-out
    prediction error it removes; the best one is named when that is significant and removes most of the
    disagreement, added, and the search repeats (up to four effects).

    Parameters
    ----------
    data : Recording, str or Path, optional
        The record (a Recording, or a CSV file or ROS 2 bag to load); leave it out to pass arrays instead.
    names : sequence of str, optional
        The registered candidates to consider (default: all).
    sample_period : float, optional
        Sample period in s of the arrays.
    voltage, current, position, force : array_like, optional
        Uniformly sampled signals in V, A, m and N: voltage, current and position, or force and position.

    Returns
    -------
    Diagnosis
        `verdict` ('adequate', 'explained' or 'unexplained'); `to_dict()` gives the `emla discrepancy` JSON
        (verdict, missing_effect, effects, disagreement, candidates, gap before and after, parameters);
        `write_report(diagnosis, directory)` writes the Markdown report with plots.

    Raises
    ------
    InputError
        Unusable data, or data from which the nominal model cannot be identified.

    Examples
    --------
    >>> from emla_identification.discrepancy import diagnose
    >>> diagnosis = diagnose('bags/example_discrepancy')            # doctest: +SKIP
    >>> diagnosis.verdict, diagnosis.to_dict()['missing_effect']    # doctest: +SKIP
    ('explained', 'coulomb_friction')
    """
    recording = as_recording(data, sample_period=sample_period, voltage=voltage, current=current, position=position,
                             force=force)
    data = Data.from_recording(recording)
    check_magnitudes(recording)
    with numerical_failures(data.source, 'the model cannot be diagnosed'):   # degenerate data show up as
        nominal, warnings = _nominal(data, recording, names)                # non-finite or unphysical estimates
        adequacy = _adequacy(nominal)   # (no candidate reads a signal: the rows' floor is the whole floor)
        ranked = rank(nominal, library(data, names))
        diagnosis = Diagnosis(data, nominal, ranked, adequacy, predict(nominal), warnings=warnings)
        _name_effects(diagnosis, names, nominal, adequacy, ranked)
        return _other_form(diagnosis, names) if diagnosis.verdict == 'unexplained' else diagnosis


def _name_effects(diagnosis, names, current, adequacy, left):
    """Name effects in turn after `diagnosis.stages` (the model `current` with them, its `adequacy`; `left` the
    other candidates ranked against it) until the model is adequate, none is named or MAX_EFFECTS are; sets the
    diagnosis's stages, partial and remaining."""
    data = diagnosis.data
    while len(diagnosis.stages) < MAX_EFFECTS:
        best = _chosen(left)
        # an equation within MAX_RATIO of its noise floor may still hold an effect that most of its held-out
        # error is (a current sensor's 50 mA offset: 2.5 times the floor, 78 % of the error, 10 of 10 blocks)
        if best is None or (all(a.adequate for a in adequacy.values()) and best.score < MOST):
            break
        best, partial = _named(data, current, _adequacy(current), best, left)
        if best is None:
            diagnosis.partial = partial
            break
        after = assess_adequacy(best.fit)   # the verdict's floor: the noise through the terms too
        others = [a for a in left if a.name != best.name]
        diagnosis.stages.append(Stage(best, after, predict(best.fit), rivals(best, others)))
        current, adequacy = best.fit, after
        left = rank(current, _not_named(diagnosis, names))
    diagnosis.remaining = left


def _not_named(diagnosis, names):
    """The library's candidates (of `names`) not named in the diagnosis's stages."""
    named = {stage.assessment.fit.candidates[-1].name for stage in diagnosis.stages}
    return [c for c in library(diagnosis.data, names) if c.name not in named]


def _other_form(diagnosis, names):
    """The unexplained `diagnosis`, or where a re-alignment it named has another form (another pattern of late or
    filtered signals) that is named in its place too, the diagnosis named again from there with that form if its
    final model explains the record or leaves less disagreement (_least_left), with a warning saying so. Where an
    effect that the re-alignment does not explain is still missing, the data may not tell its forms apart: a
    current sensor a sample late at 20 kHz beside a Stribeck friction (the sweep's case 40) was named as both
    sensors late (the electrical equation closes either way, and a position a sample late changes only the force
    balance, there at 95 times its floor from the friction); a spring named next left it at 41 times, and with the
    current alone late a Coulomb friction is named second and the record is explained."""
    for j, stage in enumerate(diagnosis.stages):
        named = stage.assessment.fit.candidates[-1]
        if not _realigns(named) or named.scale is None:
            continue
        base = diagnosis.stages[j - 1].assessment.fit if j else diagnosis.nominal
        forms = {}
        for variant in named.variants(base.data):
            forms.setdefault(_form(variant), []).append(variant)
        forms.pop(_form(named), None)
        tried = [_tried(diagnosis.data, base, _adequacy(base), assess(base, named, variants))
                 for variants in forms.values()]
        tried = [a for a in tried if a is not None and a.named]
        if not tried:
            continue
        alternative = max(tried, key=lambda a: a.score)
        after = assess_adequacy(alternative.fit)
        again = replace(diagnosis, stages=diagnosis.stages[:j] + [replace(stage, assessment=alternative,
                        adequacy=after, predictions=predict(alternative.fit))], partial=None, remaining=[])
        _name_effects(again, names, alternative.fit, after, rank(alternative.fit, _not_named(again, names)))
        if again.verdict == 'explained' or _least_left([diagnosis.final_adequacy, again.final_adequacy]) == 1:
            closes = 'explains the record' if again.verdict == 'explained' else 'leaves less disagreement'
            again.warnings = diagnosis.warnings + [
                f'{stage.assessment.name} is named as {_described(again.final.candidates[j])}, not as '
                f'{_described(diagnosis.final.candidates[j])}: where it is named the data do not tell the two '
                f'apart, and with the effects named after it the model with the first {closes}']
            return again
    return diagnosis


def _form(candidate):
    """A candidate's form: itself without its continuous setting (the pattern of a re-alignment's signals)."""
    return replace(candidate, pinned=(), **{candidate.scale: 0.0})


def _described(candidate):
    """A candidate's non-zero settings in a few words ('current_delay_samples 0.917')."""
    return ', '.join(f'{k} {_setting(v)}' for k, v in candidate.settings().items()
                     if isinstance(v, (int, float)) and v)


def _named(data, base, adequacy, chosen, ranked):
    """(the assessment to name, or None; the first significant partial match tried, or None): `chosen` (_chosen)
    tried first, then while none is named the other evident ones in `ranked` (best score first), up to TRIES in
    all (_tried). The best score need not be the effect that leaves least: a current sensor 0.165 samples late
    beside a 0.147 A offset at 20 kHz, the mechanical equation within its floor, the electrical one 456 times it;
    a current filter scored 0.46 (18 % electrical, 28 % mechanical: the lag's), a drive offset 0.39 (38 %
    electrical: the offset's, 0.147 +- 0.0003 A), and the filter, added, left more disagreement than it found."""
    partial = None
    for assessment in ([chosen] + [a for a in ranked if a is not chosen and a.evident])[:TRIES]:
        tried = _tried(data, base, adequacy, assessment)
        if tried is None:
            continue
        if tried.named:
            return tried, partial
        if partial is None and tried.significant:
            partial = tried
    return None, partial


def _tried(data, base, adequacy, assessment):
    """The assessment of a candidate added to `base` (whose adequacy is `adequacy`) polished, backfitted and with
    the share of the disagreement it removes (Assessment.share) set; None where it is not significant (a score
    below MIN_SCORE matters only if it removes most of the disagreement: seen unpolished first)."""
    if assessment.score < MIN_SCORE:
        assessment.share = removed_share(_disagreement(adequacy), _disagreement(_adequacy(assessment.fit)))
        if not assessment.significant:
            return None
    tried = added(data, base, assessment)
    tried.share = removed_share(_disagreement(adequacy), _disagreement(_adequacy(tried.fit)))
    return tried


def added(raw, base, assessment):
    """The assessment (`assess`) of a candidate added to the Fit `base`, the data `raw` as recorded, as the workflow
    names it: its setting polished, the settings of the effects before it searched again (backfitted), their pins
    released where it frees them, each equation weighed by its own residual where that leaves less (reweighted)."""
    return reweighted(base, released(base, backfitted(raw, base, polished(base, assessment))))


def _nominal(data, recording, names):
    """(the nominal Fit, its warnings). When the nominal model alone cannot be identified (no estimate, or an
    impossible one), it is fitted about the start some effect gives (start.py) where one does: the best such fit
    of the raw data, with a warning saying so; otherwise an InputError says why not."""
    try:
        nominal, failure = fit(data), None
    except InputError as error:
        nominal, failure = None, error
    if nominal is not None and physical(nominal.parameters):
        return nominal, plausibility_warnings(_physical_only(nominal.parameters), nominal.std, recording)
    rescued = []   # (held-out residual sums of squares per equation, in its units; label, nominal fit)
    for label, start, givers in rescue_starts(data, library(data, names)):
        base = nominal_fit(data, start)
        for giver in givers:   # a re-alignment as it is (its start came from it), another effect at its best
            trial = fit(giver.realigned(data), (giver,), base) if giver.realigned(data) is not data else \
                assess(base, giver).fit
            errors = trial.heldout.sum(axis=0) * np.array([trial.sigma[kind] ** 2 for kind in data.kinds])
            if np.all(np.isfinite(errors)) and physical(trial.parameters):
                rescued.append((errors, label, base))
    if rescued:   # the start whose model explains the raw data best, each equation's error against its least
        least = np.min([errors for errors, *_ in rescued], axis=0)
        _, label, best = min(rescued, key=lambda r: float(np.sum(r[0] / np.maximum(least, 1e-300))))
        return best, [f'the nominal model alone cannot be identified from these data; it is fitted about the '
                      f'estimate {label} gives']
    if failure is not None:
        raise failure
    warnings = plausibility_warnings(_physical_only(nominal.parameters), nominal.std, recording)
    found = (', '.join(f'{k} = {v:.4g}' for k, v in nominal.parameters.items())
             if all(np.isfinite(list(nominal.parameters.values()))) else 'no finite estimate')
    raise InputError(f'{data.source}: the nominal model cannot be identified from these data: ' +
                     ('; '.join(warnings) or f'{found}; does the recording excite the actuator?'))


def _chosen(ranked):
    """The assessment to name next among `ranked` (best score first): the first if it is evident (else None); but
    where several evident ones remove most (MOST) of the held-out one-step error, the one whose fit leaves the
    least disagreement (the adequacy test's low band, _least_left: in the lowest floor among them, as each fit's own
    is fitted to its residual and rises with its misfit; docs/physics.md 7). Near 1 per equation the scores differ by
    the noise: behind a 2 kHz position filter at 10 kHz a delay of about tau scored 1.014 and the filter 1.013,
    and the delay left the force balance at 38 times its floor, the filter at 1.3."""
    leaders = [a for a in ranked if a.evident and a.score >= MOST]
    if len(leaders) > 1:
        bands = [_adequacy(a.fit) for a in leaders]
        return leaders[_least_left(bands)]
    return ranked[0] if ranked and ranked[0].evident else None


def rivals(best, others):
    """The significant assessments among `others` that predict some equation's held-out blocks at least RIVAL
    times better than `best` does, though `best` removes more in all: the data prefer neither form (a current
    sensor half a sample late or behind a filter: one closes the electrical equation, the other the mechanical
    one), and the nominal parameters' difference between the two is an uncertainty of the choice."""
    own = best.fit.heldout.sum(axis=0)
    return [a for a in others if a.significant and physical(a.fit.parameters)
            and np.any(a.fit.heldout.sum(axis=0) * RIVAL < own)]


def _physical_only(parameters):
    """The fit's physical parameters, without its sample period."""
    return {k: v for k, v in parameters.items() if k != 'sample_period'}


def removed_share(before, after):
    """The share of the disagreement `before` that a candidate removes, leaving `after`: 1 when it removes all,
    0 when none, down to -1 when it doubles it or worse (bounded both ways, whatever the sizes)."""
    if not after < np.inf:   # a fit that failed (or diverged) on the held-out data
        return -1.0
    largest = max(before, after)
    return float((before - after) / largest) if largest > 0 else 0.0


def _disagreement(adequacy):
    """The low-band residual power above the noise floor, in floor units, summed over the equations."""
    return sum(max(a.ratio - 1.0, 0.0) for a in adequacy.values())


def _least_left(bands):
    """The index of the adequacy among `bands` (of fits to the same data) that leaves the least disagreement: _left
    in the lowest floor among them, per equation (each fit's own floor rises with its misfit); the first of equals."""
    unit = {equation: min(b[equation].floor for b in bands) for equation in bands[0]}
    return min(range(len(bands)), key=lambda i: _left(bands[i], unit))


def _left(adequacy, unit):
    """The log of the product over the equations of the low-band residual power in `unit` ({equation: floor}),
    the floor added: a factor gained in either equation counts alike, whatever their units."""
    return sum(np.log1p((a.size / unit[e]) ** 2) if unit[e] > 0 else np.inf for e, a in adequacy.items())


def rank(base, candidates):
    """Assessments of `candidates` added to the model `base` (a Fit), best score first."""
    return sorted((assess(base, c) for c in candidates), key=lambda a: -a.score)


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
                                   _heldout_total(result) <= (1.0 - MOST) * base.heldout.sum()):
        start = _realigned_start(moved)
        if start is not None:
            again = _best_reading(base, variants, start)[0]
            result = min((result, fit(again.realigned(base.data), base.candidates + (again,), base, about=start)),
                         key=_heldout_total)
    return _within_signs(base, _judged(base, result))


def _within_signs(base, assessment):
    """The assessment refitted with the parameters it resolves at a sign physics forbids held at zero (pinned), the
    bound they cross, while some are and others stay free; itself when none are. The constrained optimum lies on
    the bound: a dead-time drop made negative to take up a force constant's variation in the back-EMF is no dead
    time, and the offset beside it may still be one; a friction's contact damping made negative by a breakaway
    above the sliding level leaves the Coulomb level, then the Stribeck candidate, to explain it."""
    while not assessment.plausible:
        result = assessment.fit
        best, part = result.candidates[-1], result.added_slices()[-1][1]
        wrong = _forbidden(best, result.added[part], result.added_std[part])
        if not wrong or len(best.pinned) + len(wrong) >= len(best.parameters):
            break
        pinned = replace(best, pinned=best.pinned + wrong)
        assessment = _judged(base, fit(pinned.realigned(base.data), base.candidates + (pinned,), base))
    return assessment


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
        assessment = _judged(base, fit(best.realigned(base.data), base.candidates + (best,), base,
                                       about=result.parameters))
        if not _whole_step(variant, best):
            break
    return assessment


def _whole_step(variant, best):
    """Did _polished move the continuous setting a whole POLISH step (its parabola's vertex lay beyond)?"""
    before, after = getattr(variant, variant.scale), getattr(best, best.scale)
    return bool(before) and abs(after / before - 1.0) >= (1.0 - 1e-6) * POLISH


def backfitted(raw, base, assessment):
    """The assessment (of a candidate added to `base`, the data `raw` as recorded) with the continuous setting of
    each effect named before it searched again with it in the model, and refitted; itself when none moves, when the
    refit puts a parameter at a sign physics forbids, or when it does not predict the held-out blocks better (a
    re-alignment's less the sensor noise: _noise_free). An effect named first takes up some of the misfit of one not
    yet in the model: a position sensor 0.637 samples late beside a position-dependent inductance was named at 0.5
    samples (20 sigma off; _searched_again); a Coulomb friction's pre-sliding band named before a magnetic stiffness
    at 6.9 um for 2.1 um, its level held at zero and the force balance left at 16 times its floor (2.1 with the band
    searched again: the sweep's case 161; _chosen_again)."""
    result = assessment.fit
    candidates = result.candidates
    for i, earlier in enumerate(candidates[:-1]):
        if earlier.scale is not None and 0.0 < getattr(earlier, earlier.scale) < np.inf:
            again = (_searched_again if _realigns(earlier) else _chosen_again)(raw, base, result, candidates, i)
            candidates = candidates[:i] + (again,) + candidates[i + 1:]
    if candidates == result.candidates:
        return assessment
    again = _judged(base, fit(realigned(raw, candidates), candidates, base, about=result.parameters))
    if _crosses_a_sign(again.fit):
        return assessment
    changed = [c for c, old in zip(candidates, result.candidates) if c is not old and _realigns(c)]
    if not changed:
        return again if _heldout_total(again.fit) < _heldout_total(result) else assessment
    noise_free = _noise_free(result, changed[0])
    better = _noise_free_error(again.fit, noise_free, changed[0]) < _noise_free_error(result, noise_free, changed[0])
    return again if better else assessment


def released(base, assessment):
    """The assessment (of a candidate added to `base`) refitted with the parameters the candidates before it had
    pinned at a sign bound (_within_signs) free again, if then none crosses its sign and the held-out blocks are
    predicted better; itself otherwise. A pin judged a model without the later effects: a Coulomb friction's contact
    damping, made negative by a breakaway above the sliding level, was pinned at zero, and beside the Stribeck
    excess it is positive (the sweep's case 119 at 10 kHz: 54 +- 5 N s/m; the force balance left at 20 times its
    floor, not 52, and Fc 0.3411 N for 0.3410)."""
    result = assessment.fit
    if not any(c.pinned for c in result.candidates[:-1]):
        return assessment
    free = tuple(replace(c, pinned=()) for c in result.candidates[:-1]) + result.candidates[-1:]
    again = fit(result.data, free, base, about=result.parameters)
    if _crosses_a_sign(again) or not _heldout_total(again) < _heldout_total(result):
        return assessment
    return _judged(base, again)


def reweighted(base, assessment):
    """The assessment (of a candidate added to `base`) refitted with each equation weighed by its own residual
    where that leaves less disagreement (best_weighted); itself otherwise."""
    again = best_weighted(assessment.fit)
    return assessment if again is assessment.fit else _judged(base, again)


def best_weighted(result):
    """The Fit `result`, where it leaves some equation above its floor, refitted with each equation weighed by its
    own residual (fit.self_weighted), if then none of its candidates' parameters crosses its sign and the fit leaves
    less disagreement (_least_left, as _chosen compares leaders); `result` itself otherwise. The emla_sim twin of a
    Coulomb friction at 10 kHz keeps its force balance at 14 times the floor either way; weighed by its own, it
    drags L 6 % and leaves the electrical equation at 14 times too: not taken. A fit within its floors is kept as
    it is: there the weights move the estimates within the noise."""
    if all(a.adequate for a in _adequacy(result).values()):
        return result
    again = self_weighted(result)
    if not physical(again.parameters) or _crosses_a_sign(again):
        return result
    return (result, again)[_least_left([_adequacy(result), _adequacy(again)])]


def _searched_again(raw, base, model, candidates, i):
    """Re-alignment candidates[i] at the lowest held-out error less the noise (_noise_free, at the levels of the
    Fit `model`) of one-pass fits of all `candidates` about `model`, its setting searched within a factor 2
    (bounded Brent search in the logarithm, to REFINE_TOLERANCE); itself where no setting does better."""
    earlier = candidates[i]
    value = getattr(earlier, earlier.scale)
    noise_free = _noise_free(model, earlier)
    seen = realigned(raw, candidates[:i])   # the data as it was named on

    def error(setting):
        trial = candidates[:i] + (earlier.at(seen, setting),) + candidates[i + 1:]
        return _noise_free_error(fit(realigned(raw, trial), trial, base, relinearise=False, about=model.parameters),
                                 noise_free, earlier)
    search = minimize_scalar(lambda z: error(np.exp(z)), bounds=(np.log(value / 2.0), np.log(value * 2.0)),
                             method='bounded', options={'xatol': REFINE_TOLERANCE})
    found = float(np.exp(search.x))
    return earlier.at(seen, found) if error(found) < error(value) else earlier


def _chosen_again(raw, base, model, candidates, i):
    """Effect candidates[i] (one that does not re-align the data) at the variant, over its whole grid and refined
    between the neighbours of the best (_refined), whose one-pass fit of all `candidates` about the Fit `model`
    predicts the held-out blocks best; free of the pins its first fit set (a level held at zero beside a misfit
    the later effect explains: released would free it, but only at the setting that misfit chose); itself where no
    variant does better."""
    earlier = candidates[i]
    seen = realigned(raw, candidates[:i])
    moved = realigned(raw, candidates)   # the same for every variant: this effect re-aligns nothing

    def error(variant):
        trial = candidates[:i] + (variant,) + candidates[i + 1:]
        return _heldout_total(fit(moved, trial, base, relinearise=False, about=model.parameters))
    variants = earlier.variants(seen)
    best = _refined(min(variants, key=error), variants, error, seen)
    return best if error(best) < error(earlier) else earlier


def _judged(base, result):
    """The Assessment of `result`, the fit of `base` with one more candidate (its last). It is plausible when no
    candidate of the fit, the effects named before it included, has a parameter it resolves at a sign physics
    forbids: on the bench's default record (emla_sim, a 1 N Coulomb friction at 10 kHz) a smooth friction of 1.89 N
    beside it made the Coulomb level -0.90 +- 0.19 N and its contact damping negative, and was named."""
    best = result.candidates[-1]
    heldout = np.maximum(np.nan_to_num(result.heldout, nan=np.inf) - _excess_noise(base, result), 0.0)
    gain = base.heldout - heldout   # per block and equation; each equation's share removed, bounded:
    per_equation = [removed_share(b, a) for b, a in zip(base.heldout.sum(axis=0), heldout.sum(axis=0))]
    kinds = result.data.kinds
    _, values, stds = result.each_added(result.added_std)[-1]
    parameters = best.reported(values, stds, result.parameters)
    resolved = not len(values) or bool(np.any((np.abs(values) >= MIN_T * stds)[best.free() > 0]))
    return Assessment(best.effect_name(values), result, float(sum(per_equation)),
                      dict(zip(kinds, map(float, per_equation))), int(np.sum(gain.sum(axis=1) > 0)),
                      parameters, best.settings(), resolved, not _crosses_a_sign(result))


def _crosses_a_sign(result):
    """Does some candidate of the Fit `result` have a parameter it resolves at a sign physics forbids (_forbidden)?"""
    return any(_forbidden(c, result.added[part], result.added_std[part]) for c, part in result.added_slices())


def _forbidden(candidate, values, stds):
    """The candidate's parameters the data resolve (MIN_T sigmas from zero) at a sign physics forbids (an
    unresolved one's sign is the noise's)."""
    return tuple(name for name, sign, value, std in zip(candidate.parameters, candidate.signs, values, stds)
                 if not (sign * value >= 0 or abs(value) < MIN_T * std))   # (a NaN is forbidden too)


def _best_reading(base, variants, about):
    """(_best_variant, None); where the candidate reads the signals in several ways (Candidate.reading),
    _best_variant of each, and of those the one whose fit leaves the least disagreement (_least_left, as _chosen),
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
    best = _least_left([_adequacy(result) for result in fits])
    return bests[best], fits[best]


def _best_variant(base, variants, about):
    """The variant whose one-pass fit, linearised about `about` ({name: value}), predicts the held-out blocks best
    (a continuous setting refined between its grid's neighbours); a re-alignment's on its held-out error less the
    sensor noise it passes into it (_noise_free, the noise levels fitted to the variant best before that)."""
    def heldout_fit(variant):
        return fit(variant.realigned(base.data), base.candidates + (variant,), base, relinearise=False, about=about)
    if len(variants) == 1:
        return variants[0]
    fits = []   # (variant, each equation's held-out error, noise gains where it re-aligns); the fit of the lowest
    first = None
    for variant in variants:
        result = heldout_fit(variant)
        errors = _heldout_errors(result)
        fits.append((variant, errors, _gains(result, errors, variants[0])))
        if first is None or np.sum(errors) < _heldout_total(first):
            first = result
    noise_free = _noise_free(first, variants[0])
    best = min(fits, key=lambda f: noise_free(f[2], f[1]))[0]
    if best.scale is not None:
        best = _refined(best, variants, lambda v: _noise_free_error(heldout_fit(v), noise_free, v), base.data)
    return best


def _realigns(candidate):
    """Does the candidate re-align the data (a sensor's delay or filter: Candidate.realigned)?"""
    return type(candidate).realigned is not Candidate.realigned


def _gains(result, errors, candidate):
    """adequacy.noise_gains of a finite fit where `candidate` re-aligns the data (_noise_free reads them), else {}."""
    return _noise_gains(result) if _realigns(candidate) and np.all(np.isfinite(errors)) else {}


def _noise_free_error(result, noise_free, candidate, errors=None):
    """A Fit's held-out errors (or `errors`, each equation's) through `noise_free` (_noise_free of `candidate`)."""
    errors = _heldout_errors(result) if errors is None else errors
    return noise_free(_gains(result, errors, candidate), errors)


def _noise_free(model, candidate):
    """(noise gains of a fit (adequacy.noise_gains), each equation's error) -> where `candidate` re-aligns the
    data, the sum over the equations of the error less the sensor noise the fit's rows carry into it, in units of
    the noise the Fit `model`'s rows carry into that equation, at the noise levels fitted to the residuals of
    `model` (adequacy.sensor_noise: a fit with a re-alignment of that kind, whose residual's high band is the
    noise; the misaligned model's is not: behind a 1 kHz current filter at 10 kHz it gave 28 mA for the plant's
    5); the errors' sum otherwise.

    A re-alignment filters the signals (undoing a position filter, x = y + tau dy/dt, amplifies the position's
    noise by about (tau / Ts)^2; a current filter passes the position through the filter, which smooths it), so
    its variants carry different shares of the noise, and the held-out error rewards the one that carries least:
    behind a 2 kHz position filter at 10 kHz it took tau 1-4 % short (R 5 sigma off), less the noise within
    1.1 %. The fitted noise levels are within 5 % of the independent plant's. Each equation in its noise's units:
    the rows are weighted by the residual of the model before the re-alignment, which a misaligned position
    leaves huge in the force balance (805000 times its floor, 2 samples late at 5 kHz), and in those weights the
    electrical equation's noise, not the force balance, set the delay (2.007 samples, the force balance left at
    10 times its floor, where 2 leaves it at 1)."""
    if not _realigns(candidate) or not _noise_known(model):
        return lambda gains, errors: float(np.sum(errors))
    variances = _variances(model)
    own = heldout_noise(_noise_gains(model), variances)
    kinds = model.data.kinds
    scale = [own[kind] if own[kind] > 0 else 1.0 for kind in kinds]

    def noise_free(gains, errors):
        noise = heldout_noise(gains, variances)   # {} where the fit failed: its errors are infinite
        return float(sum((error - noise.get(kind, 0.0)) / unit for kind, error, unit in zip(kinds, errors, scale)))
    return noise_free


def _noise_known(model):
    """Are the sensor noise levels fitted to a finite Fit's residuals (adequacy.sensor_noise) its noise: do they
    put no more into each equation's held-out error than it holds (within 3 sqrt(2 / n), the spread of a sum of n
    squares of white noise)? Where the residual is misfit, not white noise, the levels fitted to its high band
    can predict more than all of it (a 1-sample current delay named 2.84 samples beside a missing spring at
    3 kHz: 1.4 and 2 times, 235 mA for 5), and taking that off its held-out error made the worst candidate
    perfect; the right re-alignments here predict their held-out error within 1 %."""
    if not np.isfinite(_heldout_total(model)):
        return False
    noise = heldout_noise(_noise_gains(model), _variances(model))
    errors = model.heldout.sum(axis=0)
    spread = 1.0 + 3.0 * np.sqrt(2.0 / model.degrees_of_freedom)
    return all(noise[kind] <= spread * error for kind, error in zip(model.data.kinds, errors))


def _variances(model):
    """adequacy.sensor_noise of a Fit, kept (a polish, a backfit and the score ask again)."""
    return _kept(model, sensor_noise)


def _adequacy(model):
    """rows_adequacy of a Fit, kept (the candidates' comparisons ask for it again and again)."""
    return _kept(model, rows_adequacy)


def _noise_gains(model):
    """adequacy.noise_gains of a Fit, kept (each re-aligning candidate judged against it asks again)."""
    return _kept(model, noise_gains)


def _kept(model, measure):
    """measure(model), computed once per Fit and kept in its __dict__ under the measure's name."""
    key = '_' + measure.__name__
    if key not in model.__dict__:
        model.__dict__[key] = measure(model)
    return model.__dict__[key]


def _excess_noise(base, result):
    """(FOLDS, kinds): the sensor noise a Fit `result` whose last candidate re-aligns the data carries into each
    equation's held-out blocks beyond what the rows of `base` carry there (at the noise levels fitted to `result`,
    shared among the blocks by their rows); 0 for any other candidate. Taken off its held-out error, its score is
    the misfit it removes, not the noise it passes: undoing a 2 kHz position filter at 10 kHz amplifies the
    position's noise by about 1 + 0.26 (tau / Ts)^2, a delay of about tau (an all-pass) does not, and the delay
    was named for the filter."""
    if not _realigns(result.candidates[-1]) or not _noise_known(result):
        return 0.0
    variances = _variances(result)
    own, theirs = (heldout_noise(_noise_gains(f), variances) for f in (result, base))
    rows = np.diff(result.bounds) / (result.bounds[-1] - result.bounds[0])
    return rows[:, None] * np.array([own[kind] - theirs[kind] for kind in result.data.kinds])


def _polished(base, variant, variants, model):
    """`variant` with its continuous setting s at the lowest residual sum of squares (one-pass fits about the Fit
    `model`, which has it) of:
    s, the vertex of the parabola through s and s (1 +- POLISH) (at most POLISH s away), and the grid points of
    `variants` within POLISH s (a whole-sample delay, where the sum's curvature differs either side). The held-out
    search stops at REFINE_TOLERANCE of s, and a delay 0.003 samples off moves an inductance by many sigmas. A
    re-alignment's sums are taken less the sensor noise (_noise_free)."""
    if variant.scale is None:
        return variant
    value = getattr(variant, variant.scale)
    grid = [getattr(v, variant.scale) for v in variants]
    if not min(grid) <= value * (1.0 - POLISH) < value * (1.0 + POLISH) <= max(grid) < np.inf:
        return variant
    noise_free = _noise_free(model, variant)

    def chi_square(setting):
        trial = variant.at(base.data, setting)
        result = fit(trial.realigned(base.data), base.candidates + (trial,), base, relinearise=False,
                     about=model.parameters)
        return _noise_free_error(result, noise_free, variant, _chi_squares(result))
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


def _chi_squares(result):
    """Each equation's weighted residual sum of squares on all its rows (in the Fit's own weights, data.kinds
    order); infinite for an impossible actuator."""
    return _possible(result, [result.degrees_of_freedom * (result.rms[kind] / result.sigma[kind]) ** 2
                              for kind in result.data.kinds])


def _heldout_errors(result):
    """Each equation's held-out residual sum of squares (data.kinds order); infinite for an impossible actuator or
    a failed fit."""
    return _possible(result, result.heldout.sum(axis=0))


def _possible(result, errors):
    errors = np.asarray(errors, dtype=float)
    return errors if np.all(np.isfinite(errors)) and physical(result.parameters) else np.full(errors.shape, np.inf)


def _heldout_total(result):
    """A Fit's held-out residual sum of squares; infinite for an impossible actuator or a failed fit."""
    return float(np.sum(_heldout_errors(result)))


def _realigned_start(moved):
    """The grey-box estimate of re-aligned data `moved`, or None (no physical estimate)."""
    try:
        start = greybox_start(moved)
    except InputError:
        return None
    start = {name: float(start[name]) for name in nominal_names(moved)}
    return start if physical(start) else None


def _refined(best, variants, error, data):
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


@dataclass
class Localisation:
    """One equation's one-step residual in physical units, and what it correlates with."""

    equation: str               # 'electrical' or 'mechanical'
    quantity: str               # 'voltage' (V) or 'force' (N)
    whiteness: object           # residuals.Correlation
    input_name: str
    cross: object               # residuals.Correlation with the input
    bins: dict                  # signal name -> residuals.Binned of the residual smoothed over SMOOTHING


def localise(result):
    """{equation: Localisation} of a Fit's residuals against time, velocity, position, the drive and its rate."""
    data, p = result.data, result.parameters
    ts = data.sample_period
    k = regression_rows(data)
    against = {'time': data.time[k], 'velocity': data.velocity()[k], 'position': data.signals['position'][k]}
    drive = data.drive
    against[drive] = data.signals[drive][k]
    against[f'{drive} rate'] = np.gradient(data.signals[drive], ts)[k]
    out = {}
    for kind, residual in result.residuals().items():
        if kind == 'electrical':
            h = p['resistance'] * ts / p['inductance']
            scale, quantity, input_name = p['resistance'] / -np.expm1(-h), 'voltage', 'voltage'   # 1 / beta
        else:
            scale, quantity, input_name = p['mass'], 'force', drive
        e = residual * scale
        # the sensor noise in a one-step residual is mostly high-frequency: a centred 1 ms mean leaves
        # the effects (which vary more slowly) for the binned plots
        smooth = uniform_filter1d(e, max(1, int(round(SMOOTHING / ts))), mode='nearest')
        out[EQUATION[kind]] = Localisation(EQUATION[kind], quantity, whiteness(e), input_name,
                                           cross_correlation(e, data.signals[input_name][k]),
                                           {name: binned(smooth, z) for name, z in against.items()})
    return out
