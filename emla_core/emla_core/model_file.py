"""The model file: one description of an actuator's model, written by `emla identify` and `emla discrepancy`
(--model-out) and read by every command that identifies, simulates, compares or controls with it
(--model-file).

YAML, SI units:

    emla_model: 1
    sample_period: 0.0001                   # s, of the data it was identified from
    parameters:                             # the nominal model: value and one-sigma uncertainty
      resistance: {value: 4.0002, std: 0.0003}
      inductance: {value: 0.0016, std: 5.7e-07}
      ...
    effects:                                # effects added to the nominal model, in the order they were found
      - effect: coulomb_friction            # what it is (magnetic_stiffness for a negative stiffness)
        candidate: coulomb_friction         # the discrepancy workflow's candidate that models it
        parameters: {coulomb_force: {value: 1.006, std: 0.0012}}
        settings: {presliding_displacement: 2.7e-06, rigid_sticking: true}
    provenance: {data: bags/run, date: '2026-11-23T02:00:00Z', command: emla discrepancy ..., version: 0.1.0}

A solenoid's model (`emla identify --actuator solenoid --model-out`) says so with `actuator: solenoid` (a file
without the key is a moving coil's); its parameters are those of emla_core.physics.solenoid's SolenoidParameters
(resistance, leakage_inductance, gap_coefficient, gap, mass, damping, spring_stiffness, spring_preload, and the
end stops stroke_min, stroke_max), and its effects (`emla discrepancy --actuator solenoid --model-out`) those of
its SOLENOID_EFFECTS: friction (coulomb_force; setting friction_speed) and iron_saturation
(saturation_coefficient).
"""
from __future__ import annotations

import dataclasses
import datetime
import math
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

import yaml

from emla_core.errors import InputError
from emla_core.limits import MAX_NESTING, read_document
from emla_core.parameters import FAMILIES, PARAMETER_BOUNDS, PARAMETER_NAMES

if TYPE_CHECKING:
    from emla_core.physics import Effect, SolenoidParameters

FORMAT = 1


@dataclasses.dataclass
class ModelEffect:
    effect: str          # its name in the results (e.g. magnetic_stiffness)
    candidate: str       # the candidate of the discrepancy library that models it (e.g. return_spring)
    parameters: dict     # {name: (value, std)}
    settings: dict = dataclasses.field(default_factory=dict)

    def values(self) -> dict[str, float]:
        return {k: v for k, (v, _) in self.parameters.items()}


@dataclasses.dataclass
class Model:
    """An actuator model: nominal parameters {name: (value, std)}, effects, and where it came from."""
    sample_period: float
    parameters: dict
    effects: list = dataclasses.field(default_factory=list)
    provenance: dict = dataclasses.field(default_factory=dict)
    actuator: str = 'moving_coil'   # the family (emla_core.parameters.FAMILIES)

    def values(self) -> dict[str, float]:
        """{name: value} of the nominal parameters."""
        return {k: v for k, (v, _) in self.parameters.items()}

    def solenoid(self) -> SolenoidParameters:
        """The solenoid a solenoid's model describes, with its effects (ValueError for another family's)."""
        from emla_core.physics.solenoid import SOLENOID_EFFECTS, SolenoidParameters
        if self.actuator != 'solenoid':
            raise ValueError(f'a {self.actuator} model, not a solenoid\'s')
        fields = self.values()
        for effect in self.effects:
            names, settings = SOLENOID_EFFECTS[effect.candidate]
            fields.update({names[name]: value for name, value in effect.values().items()})
            fields.update({name: effect.settings[name] for name in settings if name in effect.settings})
        return SolenoidParameters(**fields)

    def require(self, actuator: str, source: str = 'model file', whole: bool = False) -> Model:
        """This model if it is of the family `actuator` (and with `whole`, gives every parameter: a plant is
        simulated from it); an InputError in one line naming what is wrong otherwise."""
        if self.actuator != actuator:
            raise InputError(f'{source}: a {self.actuator} model; this needs a {actuator} model'
                             + (' (--actuator solenoid)' if self.actuator == 'solenoid' else ''))
        if whole and self.missing(whole=True):
            raise InputError(f'{source}: gives one equation of the actuator; simulating it needs every parameter, '
                             f'and it lacks {", ".join(self.missing(whole=True))}')
        return self

    def plant_effects(self, source: str = 'model file') -> tuple[Effect, ...]:
        """The physics layer's effects of this model, for the plant; InputError naming one it cannot simulate."""
        from emla_core.physics import EFFECTS
        out = []
        for effect in self.effects:
            spec = EFFECTS.get(effect.candidate)
            if spec is None:
                raise InputError(f'{source}: the plant cannot simulate {effect.effect}: no such effect in the physics '
                                 f'layer (known: {", ".join(EFFECTS)})')
            try:
                out.append(spec.from_model(effect.values(), effect.settings))
            except ValueError as exc:
                raise InputError(f'{source}: {exc}') from None
        return tuple(out)

    def missing(self, whole: bool = False) -> list[str]:
        """The nominal parameters this model lacks to be complete ([] if it is): every one of its family's, or of
        one equation of a moving coil (what `identify --model electrical|mechanical` writes) unless `whole`."""
        lacking = [name for name in _names(self.actuator) if name not in self.parameters]
        if whole or self.actuator != 'moving_coil':
            return lacking
        return min(([n for n in names if n not in self.parameters] for names in (lacking, *EQUATIONS.values())),
                   key=len)

    def to_yaml(self) -> str:
        def pair(value, std):
            return {'value': float(value), 'std': None if std is None or not math.isfinite(std) else float(std)}
        family = {} if self.actuator == 'moving_coil' else {'actuator': self.actuator}
        return yaml.safe_dump({
            'emla_model': FORMAT, **family, 'sample_period': float(self.sample_period),
            'parameters': {k: pair(*self.parameters[k]) for k in _names(self.actuator) if k in self.parameters},
            'effects': [{'effect': e.effect, 'candidate': e.candidate,
                         'parameters': {k: pair(*v) for k, v in e.parameters.items()},
                         'settings': {k: _plain(v) for k, v in e.settings.items()}} for e in self.effects],
            'provenance': {k: str(v) for k, v in self.provenance.items()},
        }, sort_keys=False)


def _names(actuator):
    """The nominal parameters of a family's model, in their order."""
    if actuator == 'moving_coil':
        return PARAMETER_NAMES
    from emla_core.physics.solenoid import SOLENOID_PARAMETER_NAMES
    return SOLENOID_PARAMETER_NAMES + ('stroke_min', 'stroke_max')


def _plain(value):
    if isinstance(value, bool):
        return value
    if isinstance(value, (int, float)):
        return None if math.isnan(value) else float(value)   # YAML writes inf as .inf
    return str(value)


def provenance(data: Path | str, command: str) -> dict[str, str]:
    """Where a model came from: the data, the time, the command line, the suite's version."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        suite = version('emla_core')
    except PackageNotFoundError:
        suite = 'unknown'
    return {'data': str(data), 'date': datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds'),
            'command': command, 'version': suite}


def write(model: Model, path: Path | str) -> None:
    """Write `model` to `path` (complete or not at all); InputError for a model that lacks a nominal parameter of
    its family, which no command would read (see read)."""
    path = Path(path)
    if model.missing():
        raise InputError(f'{path.name}: a {model.actuator} model file gives every parameter of its actuator or of '
                         f'one equation (no command reads one that does not); this model lacks '
                         f'{", ".join(model.missing())}')
    temporary = path.with_name(f'.{path.name}.{os.getpid()}')
    try:
        temporary.write_text(model.to_yaml())
        os.replace(temporary, path)
    except OSError as exc:
        temporary.unlink(missing_ok=True)
        raise InputError(f'{path}: cannot write: {exc.strerror or exc}') from None


def read(path: Path | str) -> Model:
    """The Model in a model file, or InputError naming the file and what is wrong with it.

    The one reader of model files: every command that takes one (simulate, launch, compare, identify, trend, the
    nodes) accepts or refuses a file alike. A file is refused if it is larger than limits.MAX_DOCUMENT_BYTES, not
    YAML, gives a key twice, writes a number otherwise than as a plain decimal (YAML 1.1 reads 1:30 as 90, 010 as
    8), or is not complete (Model.missing: no value is filled in from Table 1)."""
    path = Path(path)
    document = load_yaml(read_document(path, 'model file'), path, 'model file')
    if not isinstance(document, dict) or 'emla_model' not in document:
        raise InputError(f'{path}: not an emla model file (it must start with `emla_model: {FORMAT}`)')
    version = document['emla_model']
    if type(version) is not int or version != FORMAT:   # (True == 1 in Python: a bool is no version)
        raise InputError(f'{path}: emla_model must be the format version {FORMAT}, got {version!r}')
    unknown = sorted(map(str, set(document) - {'emla_model', 'actuator', 'sample_period', 'parameters', 'effects',
                                               'provenance'}))
    if unknown:
        raise InputError(f'{path}: unknown key(s) {", ".join(unknown)}')
    actuator = document.get('actuator', 'moving_coil')
    if not isinstance(actuator, str) or actuator not in FAMILIES:
        raise InputError(f'{path}: actuator must be one of {", ".join(FAMILIES)}, got {actuator!r}')
    period = _number(document.get('sample_period'), path, 'sample_period')
    if not 0 < period <= 10.0:
        raise InputError(f'{path}: sample_period must be within (0, 10] s, got {period}')
    parameters = _pairs(document.get('parameters'), path, 'parameters')
    names = _names(actuator)
    unknown = sorted(set(parameters) - set(names))
    if unknown:
        raise InputError(f'{path}: unknown parameter(s) {", ".join(unknown)}; known: {", ".join(names)}')
    if actuator == 'solenoid':
        return _solenoid_model(document, path, period, parameters)
    for name, (value, _) in parameters.items():
        low, high = PARAMETER_BOUNDS[name]
        if not low <= value <= high:
            raise InputError(f'{path}: parameters.{name} {value:g} is outside [{low:g}, {high:g}]')
    provenance = document.get('provenance') or {}
    return _complete(Model(period, parameters, _effects(document, path, _check_effect),
                           provenance if isinstance(provenance, dict) else {}), path)


# A moving coil's model file may give one equation alone (identified from its signals only).
EQUATIONS = {'electrical': ('resistance', 'inductance', 'emf_constant'),
             'mechanical': ('mass', 'damping', 'load_force')}


def _complete(model, path):
    """`model` if it is complete (Model.missing); InputError naming what it lacks otherwise."""
    missing = model.missing()
    if missing:
        raise InputError(f'{path}: a {model.actuator} model needs {", ".join(missing)} (a model file gives every '
                         f'parameter of its actuator, or of one of its equations; none is filled in)')
    return model


MAX_DIGITS = 300   # characters of a number in a model file: more than any float's 17 significant digits need


class StrictLoader(yaml.CSafeLoader):
    """libyaml's safe loader, refusing what YAML 1.1 reads otherwise than a person means: a key given twice (the
    last value silently won), numbers in base 60 (1:30 is 90), octal (010 is 8), hexadecimal or binary, with
    underscores, or of more digits than any float holds; a date that does not exist (a ValueError otherwise).
    Each refusal is a yaml.MarkedYAMLError with the line."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = {}
            for key_node, _ in node.value:
                if key_node.tag == 'tag:yaml.org,2002:merge':
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    first = seen.setdefault(key, key_node)
                except TypeError:   # unhashable: the base class says so
                    continue
                if first is not key_node:
                    raise yaml.constructor.ConstructorError(
                        None, None, f'{key!r} is given twice (first on line {first.start_mark.line + 1})',
                        key_node.start_mark)
        return super().construct_mapping(node, deep)

    def _plain_number(self, node, pattern, kind):
        text = self.construct_scalar(node)
        if not re.fullmatch(pattern, text):
            try:
                meant = f' (YAML 1.1 reads it as {getattr(super(), f"construct_yaml_{kind}")(node)!r})'
            except (ValueError, OverflowError):
                meant = ''
            raise yaml.constructor.ConstructorError(
                None, None, f'{text[:40]!r} is not a plain decimal number{meant}: write numbers as 90 or 1.5e-3',
                node.start_mark)
        if len(text) > MAX_DIGITS:
            raise yaml.constructor.ConstructorError(
                None, None, f'a number of {len(text)} characters ({text[:12]}...) is longer than any the suite '
                f'reads ({MAX_DIGITS})', node.start_mark)
        return text

    def construct_yaml_int(self, node):
        return int(self._plain_number(node, r'[-+]?(0|[1-9][0-9]*)', 'int'))

    def construct_yaml_float(self, node):
        self._plain_number(node, r'[-+]?([0-9]+\.[0-9]*|\.[0-9]+)([eE][-+][0-9]+)?|[-+]?\.(inf|Inf|INF)'
                                 r'|\.(nan|NaN|NAN)', 'float')
        return super().construct_yaml_float(node)

    def construct_yaml_timestamp(self, node):
        try:
            return super().construct_yaml_timestamp(node)
        except (ValueError, OverflowError) as exc:
            raise yaml.constructor.ConstructorError(None, None, f'not a date: {exc}', node.start_mark) from None


StrictLoader.add_constructor('tag:yaml.org,2002:int', StrictLoader.construct_yaml_int)
StrictLoader.add_constructor('tag:yaml.org,2002:float', StrictLoader.construct_yaml_float)
StrictLoader.add_constructor('tag:yaml.org,2002:timestamp', StrictLoader.construct_yaml_timestamp)


def load_yaml(text: str, path: Path | str, what: str = 'model file'):
    """The YAML document `text` of the file `path` (a `what`) read with StrictLoader; InputError in one line,
    naming the line, if it is not YAML, is nested more than MAX_NESTING levels deep (libyaml's loader would
    overflow the C stack) or has what StrictLoader refuses."""
    try:
        depth = 0
        for event in yaml.parse(text, Loader=yaml.CSafeLoader):
            depth += isinstance(event, yaml.CollectionStartEvent) - isinstance(event, yaml.CollectionEndEvent)
            if depth > MAX_NESTING:
                # the stubs make an event's start_mark Optional; the parser's events always have one
                line = event.start_mark.line + 1  # type: ignore[union-attr]
                raise InputError(f'{path}: nested too deeply to be a {what} (more than {MAX_NESTING} levels, line '
                                 f'{line})')
        return yaml.load(text, Loader=StrictLoader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f'line {mark.line + 1}: ' if mark else ''
        if isinstance(exc, yaml.constructor.ConstructorError) and exc.problem and exc.context is None:
            raise InputError(f'{path}: {where}{exc.problem}') from None
        raise InputError(f'{path}: not YAML: {where}{" ".join(str(exc.problem or exc.context).split())}') from None
    except yaml.YAMLError as exc:
        raise InputError(f'{path}: not YAML: {" ".join(str(exc).split())}') from None
    except RecursionError:
        raise InputError(f'{path}: nested too deeply to be a {what}') from None
    except (ValueError, OverflowError) as exc:   # a value a constructor cannot build
        raise InputError(f'{path}: not a {what}: {" ".join(str(exc).split())[:200]}') from None


def _effects(document, path, check):
    """The effects a document lists, each checked by `check(effect, path, where)` (which returns it)."""
    effects = []
    listed = document.get('effects') or []
    if not isinstance(listed, list):
        raise InputError(f'{path}: effects must be a list of {{effect, parameters, settings}}')
    for j, item in enumerate(listed):
        where = f'effects[{j}]'
        if not isinstance(item, dict) or not isinstance(item.get('effect'), str):
            raise InputError(f'{path}: {where} needs an `effect` name')
        settings = item.get('settings') or {}
        if not isinstance(settings, dict):
            raise InputError(f'{path}: {where}.settings must be a mapping')
        effect = ModelEffect(item['effect'], str(item.get('candidate', item['effect'])),
                             _pairs(item.get('parameters'), path, f'{where}.parameters'), settings)
        if any(e.candidate == effect.candidate for e in effects):
            raise InputError(f'{path}: {where}: {effect.candidate} is given twice')
        effects.append(check(effect, path, where))
    return effects


def _solenoid_model(document, path, period, parameters):
    """A solenoid's Model from its checked document: every parameter given, its effects, a possible solenoid."""
    _complete(Model(period, parameters, actuator='solenoid'), path)
    provenance = document.get('provenance') or {}
    model = Model(period, parameters, _effects(document, path, _check_solenoid_effect),
                  provenance if isinstance(provenance, dict) else {}, actuator='solenoid')
    try:
        model.solenoid()
    except ValueError as exc:
        raise InputError(f'{path}: {exc}') from None
    return model


def _check_solenoid_effect(effect, path, where):
    """A solenoid's effect (physics.solenoid.SOLENOID_EFFECTS) with its parameters and no other settings."""
    from emla_core.physics.solenoid import SOLENOID_EFFECTS
    if effect.candidate not in SOLENOID_EFFECTS:
        raise InputError(f'{path}: {where}: a solenoid\'s effects are {", ".join(SOLENOID_EFFECTS)}, not '
                         f'{effect.candidate}')
    names, settings = SOLENOID_EFFECTS[effect.candidate]
    if set(effect.parameters) != set(names) or set(effect.settings) - set(settings):
        raise InputError(f'{path}: {where} ({effect.candidate}) needs the parameters {", ".join(names)} and takes '
                         f'the settings {", ".join(settings) or "none"}')
    return effect


def _check_effect(effect, path, where):
    """An effect of the physics layer checked against its parameters and settings (names, bounds), returned with
    any parameter a file written before it existed left out at its default (no uncertainty); an effect the layer
    does not know (a user's candidate, registered when it is used) is left to its user."""
    from emla_core.physics import CANDIDATES, EFFECTS
    candidate = CANDIDATES.get(effect.candidate)
    if candidate is None:
        return effect
    spec = EFFECTS.get(effect.candidate)
    specs = spec.specs() if spec else {}
    given, wanted = set(effect.parameters), set(candidate.parameters)
    missing = wanted - given
    if given - wanted or (missing and (missing == wanted or not all(name in specs for name in missing))):
        raise InputError(f'{path}: {where} ({effect.candidate}) has parameters {", ".join(sorted(given)) or "none"}; '
                         f'it needs {", ".join(sorted(wanted)) or "none"}')
    effect = dataclasses.replace(effect, parameters={name: effect.parameters.get(name, (specs.get(name).default, None))
                                                     for name in candidate.parameters})
    unknown = sorted(set(effect.settings) - set(candidate().settings()) - set(specs))
    if unknown:
        raise InputError(f'{path}: {where} ({effect.candidate}) has unknown setting(s) {", ".join(unknown)}')
    checked = {**{k: v for k, (v, _) in effect.parameters.items()},
               **{k: v for k, v in effect.settings.items() if v is not None and not isinstance(v, bool)}}
    for name, value in checked.items():
        if name in specs:
            try:
                specs[name].checked(value, where)
            except ValueError as exc:
                raise InputError(f'{path}: {exc}') from None
    return effect


def _number(value, path, where):
    if isinstance(value, str) and len(value) <= MAX_DIGITS and _DECIMAL.fullmatch(value):
        value = float(value)   # YAML 1.1 reads 1e-4 (no dot) as a string
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        shown = f'{value[:40]!r}' if isinstance(value, str) else repr(value)
        raise InputError(f'{path}: {where} must be a finite number, got {shown}')
    return float(value)


_DECIMAL = re.compile(r'[-+]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][-+]?[0-9]+)?')   # a number YAML 1.1 left a string


def _pairs(section, path, where):
    """{name: (value, std or None)} of a mapping of {name: {value, std}} (or name: value)."""
    if section is None:
        return {}
    if not isinstance(section, dict):
        raise InputError(f'{path}: {where} must be a mapping of name: {{value, std}}')
    out = {}
    for name, entry in section.items():
        if isinstance(entry, dict):
            std = entry.get('std')
            std = None if std is None else _number(std, path, f'{where}.{name}.std')
            if std is not None and std < 0:
                raise InputError(f'{path}: {where}.{name}.std must be >= 0, got {std:g}')
            out[str(name)] = (_number(entry.get('value'), path, f'{where}.{name}.value'), std)
        else:
            out[str(name)] = (_number(entry, path, f'{where}.{name}'), None)
    return out
