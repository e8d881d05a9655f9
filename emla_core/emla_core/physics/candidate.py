"""Candidates: an effect's terms in the batch regression of the discrepancy workflow, and their registry.

A candidate adds terms that are linear in its parameters p (a vector of q values, physical units):

    u = R I + (L + p . inductance(s)) dI/dt + Km v + p . voltage(s)      (electrical equation)
    m dv/dt = F - B v - Fl - p . force(s)                                (mechanical; force opposes +x)

Each term method gets a state s (emla_identification.discrepancy.data: current, position, velocity, voltage,
force, time at the samples s.index; measured when regressing, predicted when simulating) and returns a (q, n)
array, or None when the candidate has no term of that kind. Terms that need a signal's history (a thermal
state, a friction direction) compute it from the measured data once per variant and read it at s.index.
A candidate may instead (or as well) re-align the data (`realigned`), as a sensor delay does. A voltage term so
steep in the current that it bends the current's path through an interval (a dead-time drop) also gives it at
the values it was last fitted with (`path_voltage`, `fitted`); so does an inductance term (`path_inductance`:
an iron saturating to half its inductance doubles the current's rate within an interval).
`variants(data)` lists the configurations to search (e.g. thermal time constants, delays); the best one
represents the candidate.

The built-in candidates live with their effects (physics/effects/, one file each) and share their names,
parameters and settings. Your own: subclass Candidate, set `name`, `parameters`, `units`, `acts_on` (and
`signs` if physics fixes them), write the term methods, and decorate the class with `@register_candidate`
(or give it to an Effect of your own as its `candidate`); the discrepancy workflow then ranks it with the
built-in ones. Example, a quadratic drag c v |v|:

    @register_candidate
    class QuadraticDrag(Candidate):
        name = 'quadratic_drag'
        parameters = ('drag_coefficient',)
        units = ('N s^2/m^2',)
        acts_on = ('mechanical', 'force')

        def force(self, s):
            return (s.velocity * np.abs(s.velocity))[None]
"""
import dataclasses
from typing import ClassVar

import numpy as np

CANDIDATES: 'dict[str, type[Candidate]]' = {}


def register_candidate(cls: 'type[Candidate]') -> 'type[Candidate]':
    """Class decorator: make a Candidate subclass part of the library under `cls.name`."""
    if not (isinstance(cls, type) and issubclass(cls, Candidate)):
        raise TypeError(f'register_candidate needs a subclass of Candidate, got {cls!r}')
    if not cls.name or len(cls.units) != len(cls.parameters):
        raise ValueError(f'{cls.__name__} needs a name and one unit per parameter')
    if CANDIDATES.get(cls.name, cls) is not cls:
        raise ValueError(f'a candidate named {cls.name!r} is already registered ({CANDIDATES[cls.name].__name__})')
    CANDIDATES[cls.name] = cls
    return cls


def of_effect(parameters):
    """(names, units) of an effect's Parameters, for a candidate's `parameters` and `units`."""
    return tuple(p.name for p in parameters), tuple(p.unit for p in parameters)


@dataclasses.dataclass(frozen=True)
class Candidate:
    """Base class: no terms, no re-alignment; subclasses override what their effect needs."""

    name: ClassVar[str] = ''
    parameters: ClassVar[tuple] = ()   # names of p's entries
    units: ClassVar[tuple] = ()
    acts_on: ClassVar[tuple] = ()      # regressions (emla_identification.regressors kinds) the terms enter
    signs: ClassVar[tuple] = ()        # per parameter: +1 / -1 when physics fixes its sign, 0 when it does not

    scale: ClassVar[str | None] = None   # a setting searched on a grid, then refined continuously (at())
    # the measured signals its terms read so steeply that their noise matters beside the rows' own (a friction
    # read through a pre-sliding band a few position-noise sigmas wide, or through tanh(v / v_s) with v_s near the
    # velocity's noise): the noise floor follows their noise through the terms (`reread`; discrepancy.adequacy)
    reads: ClassVar[tuple] = ()
    # a discrete setting that reads the signals in different ways (a velocity over a wide or a narrow cubic): its
    # variants carry different shares of the rows' noise, and the workflow chooses among them by what they leave
    reading: ClassVar[str | None] = None
    # parameters held at zero, the bound their sign allows, because the data asked for the other sign (the
    # workflow's constrained refit); kw_only, so that subclasses' fields may go without defaults
    pinned: tuple = dataclasses.field(default=(), kw_only=True, repr=False, compare=False)
    # its parameters' values in the fit this variant was last refitted in (path_voltage, path_inductance)
    fitted: tuple = dataclasses.field(default=(), kw_only=True, repr=False, compare=False)

    def free(self):
        """Per parameter: 1.0 where it is fitted, 0.0 where it is pinned (its columns are zeroed)."""
        return np.array([name not in self.pinned for name in self.parameters], dtype=float)

    def variants(self, data):
        """Configurations to search on these data (each a Candidate); default: this one."""
        return [self]

    def at(self, data, value):
        """The variant with its `scale` setting at `value` (a candidate with a continuous setting)."""
        raise NotImplementedError(f'{self.name} has no continuous setting')

    def realigned(self, data):
        return data

    def voltage(self, s):
        return None

    def inductance(self, s):
        return None

    def path_voltage(self, current):
        """(voltage, its slope d/dI) that this candidate's terms, at its `fitted` values, take from the drive at
        the currents `current`, where they are steep enough in the current to bend its path through an interval
        (a dead-time drop); None where they are not (the default)."""
        return None

    def path_inductance(self, s):
        """The inductance (H) its terms, at its `fitted` values, add to the coil's at the state s (a model's path
        through the intervals: current, position, velocity), or None: it has no inductance term or no fitted values."""
        terms = self.inductance(s) if self.fitted else None
        return None if terms is None else np.tensordot(np.asarray(self.fitted) * self.free(), terms, 1)

    def force(self, s):
        return None

    def force_between(self, data):
        """The force term between the samples, for a term that switches within an interval (a friction reversing):
        (intervals, pieces, parameters), its mean over each of `pieces` equal parts of every interval of `data`
        (the regression rows then take it exactly, through the rows' gain of each part); None to have the rows take
        `force` at the samples (a term smooth between them). `force` still gives it at the samples of a
        simulation."""
        return None

    def held(self, data):
        """Samples (boolean array) at which the effect holds the moving part still, as static friction does:
        the force balance does not apply there (the part does not accelerate whatever the other forces);
        None if it never does."""
        return None

    def reread(self, data):
        """This variant with its terms read again from `data`, the same settings (a candidate that `reads`)."""
        return self

    def settings(self):
        """Fixed settings of this variant, {name: value}, reported with the fitted parameters."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.compare}

    def effect_name(self, values):
        """The name of the effect these fitted parameter values describe (default: the candidate's)."""
        return self.name

    def reported(self, values, stds, model):
        """{name: (value, one-sigma)} of the added parameters; `model` holds the re-identified nominal ones."""
        return {n: (float(v), float(s)) for n, v, s in zip(self.parameters, values, stds)}


@dataclasses.dataclass(frozen=True)
class CenteredCandidate(Candidate):
    """A candidate whose terms are polynomials in d = x - center, the center set to the record's mean position
    (its `center` setting): about the middle of the motion the powers of d are least correlated."""

    center: float = 0.0

    def variants(self, data):
        return [dataclasses.replace(self, center=float(np.mean(data.signals['position'])))]

    def offset(self, s):
        """d = x - center at the samples of the state s."""
        return s.position - self.center
