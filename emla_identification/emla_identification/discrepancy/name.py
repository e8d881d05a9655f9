"""Name the missing effects one by one: the best candidate named when it is significant and removes most of
the disagreement, added (refine.py) and the rest ranked again, until the model is adequate or none is named."""
from dataclasses import replace

import numpy as np

from .adequacy import assess_adequacy
from .candidates import library
from .diagnosis import Stage
from .fit import physical
from .judge import MIN_SCORE, MOST, RIVAL, setting_text
from .measures import adequacy_of, disagreement_of, least_left, removed_share
from .noise import realigns
from .predict import predict
from .rank import assess, rank
from .refine import added

MAX_EFFECTS = 4


TRIES = 3          # significant candidates tried in turn for a name when the best is only a partial match


def name_effects(diagnosis, names, current, adequacy, left, progress=None):
    """Name effects in turn after `diagnosis.stages` (the model `current` with them, its `adequacy`; `left` the
    other candidates ranked against it) until the model is adequate, none is named or MAX_EFFECTS are; sets the
    diagnosis's stages, partial and remaining. `progress` as rank's."""
    data = diagnosis.data
    while len(diagnosis.stages) < MAX_EFFECTS:
        best = _chosen(left)
        # an equation within MAX_RATIO of its noise floor may still hold an effect that most of its held-out
        # error is (a current sensor's 50 mA offset: 2.5 times the floor, 78 % of the error, 10 of 10 blocks)
        if best is None or (all(a.adequate for a in adequacy.values()) and best.score < MOST):
            break
        if progress is not None:
            progress('naming', 0, 1, best.name)
        best, partial = _named(data, current, adequacy_of(current), best, left)
        if best is None:
            diagnosis.partial = partial
            break
        after = assess_adequacy(best.fit)   # the verdict's floor: the noise through the terms too
        others = [a for a in left if a.name != best.name]
        diagnosis.stages.append(Stage(best, after, predict(best.fit), rivals(best, others)))
        current, adequacy = best.fit, after
        left = rank(current, _not_named(diagnosis, names), progress,
                    'ranking after ' + ', '.join(s.assessment.name for s in diagnosis.stages))
    diagnosis.remaining = left


def _not_named(diagnosis, names):
    """The library's candidates (of `names`) not named in the diagnosis's stages."""
    named = {stage.assessment.fit.candidates[-1].name for stage in diagnosis.stages}
    return [c for c in library(diagnosis.data, names) if c.name not in named]


def other_form(diagnosis, names, progress=None):
    """The unexplained `diagnosis`, or where a re-alignment it named has another form (another pattern of late or
    filtered signals) that is named in its place too, the diagnosis named again from there with that form if its
    final model explains the record or leaves less disagreement (least_left), with a warning saying so. Where an
    effect that the re-alignment does not explain is still missing, the data may not tell its forms apart: a
    current sensor a sample late at 20 kHz beside a Stribeck friction was named as both
    sensors late (the electrical equation closes either way, and a position a sample late changes only the force
    balance, there at 95 times its floor from the friction); a spring named next left it at 41 times, and with the
    current alone late a Coulomb friction is named second and the record is explained. `progress` as rank's."""
    for j, stage in enumerate(diagnosis.stages):
        named = stage.assessment.fit.candidates[-1]
        if not realigns(named) or named.scale is None:
            continue
        base = diagnosis.stages[j - 1].assessment.fit if j else diagnosis.nominal
        forms = {}
        for variant in named.variants(base.data):
            forms.setdefault(_form(variant), []).append(variant)
        forms.pop(_form(named), None)
        if progress is not None and forms:
            progress('other forms', 0, 1, stage.assessment.name)
        tried = [_tried(diagnosis.data, base, adequacy_of(base), assess(base, named, variants))
                 for variants in forms.values()]
        tried = [a for a in tried if a is not None and a.named]
        if not tried:
            continue
        alternative = max(tried, key=lambda a: a.score)
        after = assess_adequacy(alternative.fit)
        again = replace(diagnosis, stages=diagnosis.stages[:j] + [replace(stage, assessment=alternative,
                        adequacy=after, predictions=predict(alternative.fit))], partial=None, remaining=[])
        left = rank(alternative.fit, _not_named(again, names), progress, f'ranking after {alternative.name}')
        name_effects(again, names, alternative.fit, after, left, progress)
        if again.verdict == 'explained' or least_left([diagnosis.final_adequacy, again.final_adequacy]) == 1:
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
    return ', '.join(f'{k} {setting_text(v)}' for k, v in candidate.settings().items()
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
        assessment.share = removed_share(disagreement_of(adequacy), disagreement_of(adequacy_of(assessment.fit)))
        if not assessment.significant:
            return None
    tried = added(data, base, assessment)
    tried.share = removed_share(disagreement_of(adequacy), disagreement_of(adequacy_of(tried.fit)))
    return tried


def _chosen(ranked):
    """The assessment to name next among `ranked` (best score first): the first if it is evident (else None); but
    where several evident ones remove most (MOST) of the held-out one-step error, the one whose fit leaves the
    least disagreement (the adequacy test's low band, least_left: in the lowest floor among them, as each fit's own
    is fitted to its residual and rises with its misfit; docs/physics.md 7). Near 1 per equation the scores differ by
    the noise: behind a 2 kHz position filter at 10 kHz a delay of about tau scored 1.014 and the filter 1.013,
    and the delay left the force balance at 38 times its floor, the filter at 1.3."""
    leaders = [a for a in ranked if a.evident and a.score >= MOST]
    if len(leaders) > 1:
        bands = [adequacy_of(a.fit) for a in leaders]
        return leaders[least_left(bands)]
    return ranked[0] if ranked and ranked[0].evident else None


def rivals(best, others):
    """The significant assessments among `others` that predict some equation's held-out blocks at least RIVAL
    times better than `best` does, though `best` removes more in all: the data prefer neither form (a current
    sensor half a sample late or behind a filter: one closes the electrical equation, the other the mechanical
    one), and the nominal parameters' difference between the two is an uncertainty of the choice."""
    own = best.fit.heldout.sum(axis=0)
    return [a for a in others if a.significant and physical(a.fit.parameters)
            and np.any(a.fit.heldout.sum(axis=0) * RIVAL < own)]
