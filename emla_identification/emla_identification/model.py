"""Model files (emla_core.model_file) and the identification: a model from a grey-box result or from a
discrepancy diagnosis, the same model structure identified on new data, and the model as given, ready to
predict a record (emla compare).

The effects of a model are the discrepancy workflow's candidates (discrepancy/candidates.py), so a model
with effects is identified, and predicted, by its joint fit (discrepancy/fit.py); without effects the
grey-box identification (greybox.py) is the one used.
"""
import dataclasses

import numpy as np
from scipy.optimize import minimize_scalar

from emla_core.errors import InputError
from emla_core.model_file import Model, ModelEffect, provenance
from emla_core.parameters import PARAMETER_NAMES
from emla_core.physics import EFFECTS

from .discrepancy.candidates import CANDIDATES
from .discrepancy.data import Data
from .discrepancy.diagnosis import reported_std
from .discrepancy.fit import ModelOnData, fit, nominal_fit, physical
from .discrepancy.profile import profiled
from .discrepancy.rank import assess
from .discrepancy.refine import added
from .discrepancy.rows import nominal_names
from .discrepancy.start import rescue_starts
from .greybox import UNRESOLVED


def from_greybox(result, data, command):
    """The Model of an `identify` result (GreyBoxResult): the nominal parameters it identified, and each effect it
    estimated beside them by its online column (a return spring's k: the effect's entry at its settings'
    defaults, the spring's centre at x = 0, about which the result's load force is the total)."""
    nominal = {k: (v, result.std.get(k)) for k, v in result.parameters.items() if k in PARAMETER_NAMES}
    effects = []
    for name, value in result.parameters.items():
        if name in PARAMETER_NAMES:
            continue
        (effect,) = [e for e in EFFECTS.values() if e.online is not None and e.online.parameter == name]
        effects.append(ModelEffect(effect.candidate().effect_name([value]), effect.name,
                                   {name: (value, result.std.get(name))},
                                   {setting.name: setting.default for setting in effect.settings}))
    return Model(result.sample_period, nominal, effects, provenance(data, command))


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
        (nominal, added) one-sigma of the fit: discrepancy.diagnosis.reported_std's (Diagnosis.final_std).

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
        (result dict for the JSON: model, samples, sample_period, parameters, std, effects, unresolved; the
        identified emla_core.model_file.Model).
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
                          for name, effect in zip(names, identified.effects, strict=True)],
              'unresolved': unresolved(identified)}
    return result, identified


def unresolved(model):
    """The parameters of a Model (nominal and its effects') that its data do not resolve, as greybox reports them: a
    one-sigma above UNRESOLVED of the value (the load force, often near zero, and a parameter held at zero, which
    is no estimate, aside)."""
    pairs = [*model.parameters.items(), *(item for effect in model.effects for item in effect.parameters.items())]
    return [name for name, (value, std) in pairs
            if name != 'load_force' and std is not None and (value, std) != (0.0, 0.0)
            and not std < UNRESOLVED * abs(value)]


def identify_model(model, data, record, source='model file'):
    """The model's structure (nominal + its effects) identified on a record's `data` (a Data; `record` names it in
    errors): the joint Fit, each effect added in turn as the discrepancy workflow names one
    (discrepancy.rank.assess and refine.added: its variant, a delay or a time constant, searched again on these
    data, refined and polished; the settings of the effects before it searched again beside it; each equation
    weighed by its own residual where that leaves less disagreement). An effect without a continuous setting keeps
    the model's settings (a spring's centre: the load force identified is the total there, as in the model).

    The effects are added to the nominal model fitted as the workflow fits it (_nominal_fits): the grey-box
    identification's where that is a possible actuator; where it is not (a strong spring or a late sensor drives
    it impossible), about the start each of the model's effects gives (discrepancy.start) and about the model's
    own nominal parameters. Of the structures identified from those, the one that predicts the held-out blocks
    best is kept."""
    candidates = [_candidate(effect, source) for effect in model.effects]
    with np.errstate(all='ignore'):
        identified = []
        for base in _nominal_fits(model, data, candidates):
            current = base
            for effect, candidate in zip(model.effects, candidates):
                kept = [_closest_variant(candidate, effect.settings, data)] if candidate.scale is None else None
                current = added(data, current, assess(current, candidate, kept)).fit
            if physical(current.parameters):
                identified.append(current)
    if not identified:
        raise InputError(f'{record}: the model cannot be identified from these data')
    return _best_predicting(identified)


def _nominal_fits(model, data, candidates):
    """The nominal Fits the model's effects are added to (identify_model): the grey-box start's alone where it is a
    possible actuator, else those about each start the `candidates` give (discrepancy.start.rescue_starts) and about
    the model's own nominal parameters (where it gives those of these data); the grey-box identification's
    InputError where there is none."""
    try:
        nominal, failure = fit(data), None
    except InputError as error:
        nominal, failure = None, error
    if nominal is not None and physical(nominal.parameters):
        return [nominal]
    starts = [start for _, start, _ in rescue_starts(data, candidates)]
    given = model.values()
    if all(name in given for name in nominal_names(data)):
        starts.append({name: given[name] for name in nominal_names(data)})
    bases = [nominal_fit(data, start) for start in starts if physical(start)]
    if not bases and failure is not None:
        raise failure
    return bases


def _best_predicting(fits):
    """Of Fits of one structure linearised about different starts, the one whose held-out errors are least: each
    equation's residual sums of squares in its own units (each Fit's are in its reference's), over the least any of
    them leaves, summed over the equations."""
    errors = np.array([f.heldout.sum(axis=0) * np.array([f.sigma[kind] ** 2 for kind in f.data.kinds])
                       for f in fits])
    least = np.maximum(errors.min(axis=0), 1e-300)
    return fits[int(np.argmin(np.sum(errors / least, axis=1)))]


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


def _number(value):
    """Is `value` a finite number (not a bool)?"""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and bool(np.isfinite(value))


def _closest_variant(candidate, settings, data):
    """The variant of `candidate` on `data` as the model's `settings` give it: the one whose numeric settings are
    closest (relatively) to them. A candidate without a continuous setting takes the given values of the numeric
    settings that are its fields: a spring's or a force constant's centre, which the workflow sets to its record's mean
    position, is where the model's load force or Km holds, on any record. One with a continuous setting
    (Candidate.scale) has it moved onto the given value: a bounded search on the same distance, which is 0 there,
    between the ends of the grid and of the values given (the grid is this record's: a friction's pre-sliding
    bands start at its position noise)."""
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
    if best.scale is None:
        fields = {field.name for field in dataclasses.fields(best)}
        return dataclasses.replace(best, **{k: float(v) for k, v in settings.items()
                                            if k in fields and k in best.settings() and _number(v)
                                            and _number(getattr(best, k))})
    if distance(best) == 0.0:
        return best
    grid = [v for v in {getattr(v, best.scale) for v in variants} if 0.0 < v < np.inf]
    if len(grid) < 2:
        return best
    ends = grid + [v for v in settings.values() if _number(v) and 0.0 < v < np.inf]
    search = minimize_scalar(lambda z: distance(best.at(data, float(np.exp(z)))),
                             bounds=(np.log(min(ends)), np.log(max(ends))), method='bounded',
                             options={'xatol': 1e-9})
    moved = best.at(data, float(np.exp(search.x)))
    return moved if distance(moved) < distance(best) else best
