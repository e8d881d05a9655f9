"""Model files (emla_core.model_file) and the identification: a model from a grey-box result or from a
discrepancy diagnosis, the same model structure identified on new data, and the model as given, ready to
predict a record (emla compare).

The effects of a model are the discrepancy workflow's candidates (discrepancy/candidates.py), so a model
with effects is identified, and predicted, by its joint fit (discrepancy/fit.py); without effects the
grey-box identification (greybox.py) is the one used.
"""
import numpy as np

from emla_core.errors import InputError
from emla_core.model_file import Model, ModelEffect, provenance

from .discrepancy.candidates import CANDIDATES
from .discrepancy.data import Data
from .discrepancy.fit import ModelOnData, fit, physical
from .discrepancy.profile import profiled
from .discrepancy.rows import nominal_names
from .discrepancy.workflow import added, assess, reported_std


def from_greybox(result, data, command):
    """The Model of an `identify` result (GreyBoxResult): the nominal parameters it identified."""
    return Model(result.sample_period, {k: (v, result.std.get(k)) for k, v in result.parameters.items()}, [],
                 provenance(data, command))


def from_fit(final, names, data, command, std):
    """The Model of a joint fit (the discrepancy's final one): nominal parameters and each candidate's own
    parameters with their uncertainties (jackknife and systematic), named `names` (one per candidate).

    Parameters
    ----------
    final : Fit
        The joint fit.
    names : list of str
        The model's name of each of the fit's candidates, in order.
    data : str
        The data the fit came from (the model's provenance).
    command : str
        The command line that made it (provenance).
    std : tuple
        (nominal, added) one-sigma of the fit: discrepancy.workflow.reported_std's (Diagnosis.final_std).

    Returns
    -------
    emla_core.model_file.Model
    """
    std, added_std = std
    nominal = {k: (v, std.get(k)) for k, v in final.parameters.items() if k != 'sample_period'}
    effects = [ModelEffect(name, candidate.name,
                           {p: (float(v), float(s)) for p, v, s in zip(candidate.parameters, values, stds)},
                           candidate.settings())
               for name, (candidate, values, stds) in zip(names, final.each_added(added_std))]
    return Model(final.data.sample_period, nominal, effects, provenance(data, command))


def _candidate(effect, source):
    if effect.candidate not in CANDIDATES:
        raise InputError(f'{source}: effect {effect.effect!r}: no candidate {effect.candidate!r} is registered '
                         f'(known: {", ".join(CANDIDATES)})')
    return CANDIDATES[effect.candidate]()


def identified_structure(structure, recording, data, command, source='model file'):
    """A model file's structure identified on `recording`, as `emla identify --model-file` reports it.

    Parameters
    ----------
    structure : emla_core.model_file.Model
        The model whose nominal parameters and effects are identified (their values are not used).
    recording : Recording
        The data.
    data, command : str
        Where the data came from and the command line, for the new model's provenance.
    source : str, optional
        The model file's name, for messages.

    Returns
    -------
    tuple
        (result dict for the JSON: model, samples, sample_period, parameters, std, effects; the identified
        emla_core.model_file.Model).
    """
    raw = Data.from_recording(recording)
    final = identify_model(structure, raw, recording.source, source)
    names = [e.effect for e in structure.effects]
    identified = from_fit(final, names, data, command, reported_std(final, raw, profiled(final, raw)))
    result = {'model': 'full', 'samples': len(recording), 'sample_period': recording.sample_period,
              'parameters': {k: v for k, (v, _) in identified.parameters.items()},
              'std': {k: s for k, (_, s) in identified.parameters.items()},
              'effects': [{'effect': name, 'parameters': {p: v for p, (v, _) in effect.parameters.items()},
                           'std': {p: s for p, (_, s) in effect.parameters.items()}}
                          for name, effect in zip(names, identified.effects, strict=True)]}
    return result, identified


def identify_model(model, data, record, source='model file'):
    """The model's structure (nominal + its effects) identified on a record's `data` (a Data; `record` names it in
    errors): the joint Fit, each effect added in turn as the discrepancy workflow names one
    (discrepancy.workflow.assess and added: its variant, a delay or a time constant, searched again on these
    data, refined and polished; the settings of the effects before it searched again beside it; each equation
    weighed by its own residual where that leaves less disagreement)."""
    with np.errstate(all='ignore'):
        current = fit(data)
        for effect in model.effects:
            current = added(data, current, assess(current, _candidate(effect, source))).fit
    if not physical(current.parameters):
        raise InputError(f'{record}: the model cannot be identified from these data')
    return current


def model_on_data(model, recording, source='model file'):
    """The model as given (nothing identified) on a record's data, ready to predict it.

    Parameters
    ----------
    model : emla_core.model_file.Model
        Nominal parameters and effects; each effect's variant is the one closest to its settings.
    recording : Recording
        The record whose measured inputs drive the predictions.
    source : str
        Names the model in errors.

    Returns
    -------
    ModelOnData
        The model's regression coefficients on the record's data (discrepancy.predict.predict takes it).

    Raises
    ------
    InputError
        If the model lacks a parameter these data need or an effect lacks one of its own, or names an effect
        no candidate is registered for.
    """
    data = Data.from_recording(recording)
    values = model.values()
    missing = [k for k in nominal_names(data) if k not in values]
    if missing:
        raise InputError(f'{source}: the model lacks {", ".join(missing)} for these data')
    candidates, added = [], []
    for effect in model.effects:
        candidate = _closest_variant(_candidate(effect, source), effect.settings, data)
        candidates.append(candidate)
        given = effect.values()
        missing = [p for p in candidate.parameters if p not in given]
        if missing:
            raise InputError(f'{source}: effect {effect.effect} lacks {", ".join(missing)}')
        added += [given[p] for p in candidate.parameters]
    for candidate in candidates:   # a delay re-aligns the data the model sees
        data = candidate.realigned(data)
    nominal = {k: values[k] for k in nominal_names(data)}
    return ModelOnData(data=data, candidates=tuple(candidates), shift=np.zeros(len(nominal)),
                       added=np.array(added, dtype=float), parameters=dict(nominal, sample_period=data.sample_period),
                       linearised_about=nominal)


def _closest_variant(candidate, settings, data):
    """The variant of `candidate` on `data` whose numeric settings are closest (relatively) to `settings`; a
    candidate with a continuous setting (Candidate.scale) has it moved onto the given value (a bounded search
    between the grid's ends on the same distance, which is 0 there)."""
    def distance(variant):
        total = 0.0
        for key, wanted in settings.items():
            have = variant.settings().get(key)
            if isinstance(wanted, bool) or not isinstance(wanted, (int, float)):
                total += 0.0 if have == wanted else 1e9
            elif isinstance(have, (int, float)) and np.isfinite(wanted) and np.isfinite(have):
                total += abs(np.log((abs(have) + 1e-300) / (abs(wanted) + 1e-300)))
            else:
                total += 0.0 if have == wanted else 1e9
        return total
    variants = candidate.variants(data)
    best = min(variants, key=distance)
    if getattr(best, 'scale', None) is None or distance(best) == 0.0:
        return best
    grid = [v for v in {getattr(v, best.scale) for v in variants} if 0.0 < v < np.inf]
    if len(grid) < 2:
        return best
    from scipy.optimize import minimize_scalar
    search = minimize_scalar(lambda z: distance(best.at(data, float(np.exp(z)))),
                             bounds=(np.log(min(grid)), np.log(max(grid))), method='bounded',
                             options={'xatol': 1e-9})
    moved = best.at(data, float(np.exp(search.x)))
    return moved if distance(moved) < distance(best) else best
