"""The result of a diagnosis: the nominal model, the effects named in stages, what is left, and its JSON."""
import functools
from dataclasses import dataclass, field

import numpy as np

from ..dependence import dependence, signals_of
from .adequacy import EQUATION
from .data import Data, regression_rows
from .fit import FOLDS, STUDENT, Fit, design, with_systematic
from .judge import RIVAL, Assessment
from .measures import adequacy_of
from .predict import MECHANICAL_TIME
from .profile import finer, profiled
from .rows import nominal_names

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
class Stage:
    """An effect named and added: the model with it (and those before), how adequate it is, its predictions."""

    assessment: Assessment
    adequacy: dict          # equation -> adequacy.Adequacy of the model with the effect
    predictions: dict       # signal -> Prediction of the model with the effect
    rivals: list = field(default_factory=list)   # significant Assessments the data do not tell from it (rivals)


@dataclass
class Diagnosis:
    data: Data
    nominal: Fit
    candidates: list                 # Assessments against the nominal model, best first
    nominal_adequacy: dict           # equation -> Adequacy
    before: dict                     # signal -> Prediction of the nominal model
    stages: list = field(default_factory=list)   # Stages, in the order the effects were named
    partial: Assessment | None = None   # the best candidate after the last stage when it is only a partial match
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
        regressor do, 1.3 % on a sweep record, 4.4 sigma unscaled); and in quadrature the largest difference a
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
    scale = np.sqrt(max([1.0] + [a.ratio for a in adequacy_of(final).values() if np.isfinite(a.ratio)]))
    return {k: s * scale for k, s in nominal.items()}, added * scale


def _rounded(parameters):
    return {k: float(f'{v:.6g}') for k, v in parameters.items()}
