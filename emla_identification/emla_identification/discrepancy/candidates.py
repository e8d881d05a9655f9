"""Candidate effects: augmentations of the nominal model, each with its own parameters, and their registry.

A candidate adds terms that are linear in its parameters p (a vector of q values, physical units):

    u = R I + (L + p . inductance(s)) dI/dt + Km v + p . voltage(s)      (electrical equation)
    m dv/dt = F - B v - Fl - p . force(s)                                (mechanical; force opposes +x)

Each term method gets a `State` s (data.py: current, position, velocity, voltage, force, time at the
samples s.index; measured when regressing, predicted when simulating) and returns a (q, n) array, or None
when the candidate has no term of that kind. Terms that need a signal's history (a thermal state, a
friction direction) compute it from the measured data once per variant and read it at s.index.
A candidate may instead (or as well) re-align the data (`realigned`), as a sensor delay does.
`variants(data)` lists the configurations to search (e.g. thermal time constants, delays); the best one
represents the candidate.

Your own effect: subclass Candidate, set `name`, `parameters`, `units`, `acts_on` (and `signs` if physics
fixes them), write the term methods, and decorate the class with `@register_candidate`; `diagnose` and
`emla discrepancy` then rank it with the built-in ones. Example, a quadratic drag c v |v|:

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
from scipy.signal import lfilter

from .data import MAX_DELAY

CANDIDATES = {}


def register_candidate(cls):
    """Class decorator: make a Candidate subclass part of the library under `cls.name`."""
    if not (isinstance(cls, type) and issubclass(cls, Candidate)):
        raise TypeError(f'register_candidate needs a subclass of Candidate, got {cls!r}')
    if not cls.name or len(cls.units) != len(cls.parameters):
        raise ValueError(f'{cls.__name__} needs a name and one unit per parameter')
    if CANDIDATES.get(cls.name, cls) is not cls:
        raise ValueError(f'a candidate named {cls.name!r} is already registered ({CANDIDATES[cls.name].__name__})')
    CANDIDATES[cls.name] = cls
    return cls


def library(data, names=None):
    """Instances of the registered candidates (or of `names`) that can act on `data`'s equations."""
    chosen = [CANDIDATES[n]() for n in (names or CANDIDATES)]
    return [c for c in chosen if set(c.acts_on) & set(data.kinds)]


@dataclasses.dataclass(frozen=True)
class Candidate:
    """Base class: no terms, no re-alignment; subclasses override what their effect needs."""

    name: ClassVar[str] = ''
    parameters: ClassVar[tuple] = ()   # names of p's entries
    units: ClassVar[tuple] = ()
    acts_on: ClassVar[tuple] = ()      # regressions (regressors.py kinds) the terms enter
    signs: ClassVar[tuple] = ()        # per parameter: +1 / -1 when physics fixes its sign, 0 when it does not

    def variants(self, data):
        """Configurations to search on these data (each a Candidate); default: this one."""
        return [self]

    def realigned(self, data):
        return data

    def voltage(self, s):
        return None

    def inductance(self, s):
        return None

    def force(self, s):
        return None

    def held(self, data):
        """Samples (boolean array) at which the effect holds the moving part still, as static friction does:
        the force balance does not apply there (the part does not accelerate whatever the other forces);
        None if it never does."""
        return None

    def settings(self):
        """Fixed settings of this variant, {name: value}, reported with the fitted parameters."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def effect_name(self, values):
        """The name of the effect these fitted parameter values describe (default: the candidate's)."""
        return self.name

    def reported(self, values, stds, model):
        """{name: (value, one-sigma)} of the added parameters; `model` holds the re-identified nominal ones."""
        return {n: (float(v), float(s)) for n, v, s in zip(self.parameters, values, stds)}


@register_candidate
@dataclasses.dataclass(frozen=True)
class CoulombFriction(Candidate):
    """Fc d(t): dry friction whose direction d follows the measured motion with a pre-sliding band.

    d = (x - y) / delta, y the play (backlash) operator of width delta on the measured position: d is
    +-1 while sliding. Where the measured position stays within the band the part sticks, in one of two
    ways searched as variants: rigidly (static friction balances whatever else acts, so the force balance
    says only that it does not accelerate: `held`), or elastically (the friction Fc d pulls it back within
    the band: the elasto-plastic limit of the Dahl model, a pre-sliding stiffness Fc / delta). delta is
    searched on a grid from a few times the position noise; the friction therefore reads the measured
    motion, in simulation too.
    """

    name: ClassVar[str] = 'coulomb_friction'
    parameters: ClassVar[tuple] = ('coulomb_force',)
    units: ClassVar[tuple] = ('N',)
    acts_on: ClassVar[tuple] = ('mechanical', 'force')
    signs: ClassVar[tuple] = (1,)
    presliding: float = 0.0   # m
    direction: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)
    stuck: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)

    def variants(self, data):
        x = data.signals['position']
        # white position noise has third differences of variance 20 sigma^2 (MAD for robustness)
        noise = max(1.4826 * np.median(np.abs(np.diff(x, 3))) / np.sqrt(20.0), 1e-6 * np.ptp(x))
        variants = []
        for delta in 3.0 * noise * np.array([1.0, 2.0, 4.0, 8.0]):
            play = _play(x, delta)
            # stuck parts either held still (rigid sticking) or pulled back elastically within the band
            variants += [dataclasses.replace(self, presliding=float(delta), **play),
                         dataclasses.replace(self, presliding=float(delta), direction=play['direction'])]
        return variants

    def force(self, s):
        return self.direction[s.index][None]

    def held(self, data):
        return self.stuck

    def settings(self):
        return {'presliding_displacement': self.presliding, 'rigid_sticking': self.stuck is not None}


def _play(x, width):
    """{'direction': (x - y) / width, 'stuck': y did not move into sample k} with y the play operator:
    y_k = clip(y_k-1, x_k - width, x_k + width). While the measured position stays within the band, the
    part is taken to stick."""
    y = np.empty_like(x)
    last = float(x[0])
    for k, xk in enumerate(x.tolist()):
        last = min(max(last, xk - width), xk + width)
        y[k] = last
    return {'direction': (x - y) / width, 'stuck': np.concatenate(([False], np.diff(y) == 0.0))}


@register_candidate
@dataclasses.dataclass(frozen=True)
class ReturnSpring(Candidate):
    """k (x - x_mean); the spring's rest position merges with the load force (only k is separable).

    k may have either sign: k > 0 is a return spring (valve actuators); k < 0 a magnetic (reluctance)
    stiffness, a force growing toward the pole (solenoids, moving-magnet actuators), named
    `magnetic_stiffness` with the negative spring_stiffness."""

    name: ClassVar[str] = 'return_spring'
    parameters: ClassVar[tuple] = ('spring_stiffness',)
    units: ClassVar[tuple] = ('N/m',)
    acts_on: ClassVar[tuple] = ('mechanical', 'force')
    signs: ClassVar[tuple] = (0,)
    center: float = 0.0

    def variants(self, data):
        return [dataclasses.replace(self, center=float(np.mean(data.signals['position'])))]

    def force(self, s):
        return (s.position - self.center)[None]

    def effect_name(self, values):
        return 'magnetic_stiffness' if values[0] < 0 else self.name


@register_candidate
@dataclasses.dataclass(frozen=True)
class ResistanceDrift(Candidate):
    """R(t) = R0 + dR q(t), q the coil's heating: I^2 low-passed with the thermal time constant, scaled
    to peak at 1 (a first-order coil: temperature rise = R_th * low-passed Joule power). dR is the rise at
    the hottest point of the record; the time constant is searched on a grid (a long one gives a ramp)."""

    name: ClassVar[str] = 'resistance_drift'
    parameters: ClassVar[tuple] = ('resistance_rise',)
    units: ClassVar[tuple] = ('ohm',)
    acts_on: ClassVar[tuple] = ('electrical',)
    signs: ClassVar[tuple] = (1,)
    thermal_time_constant: float = 0.0   # s
    heating: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)

    def variants(self, data):
        span = len(data) * data.sample_period
        power = data.signals['current'] ** 2
        variants = []
        for tau in span * np.geomspace(0.01, 10.0, 13):
            a = np.exp(-data.sample_period / tau)
            heating = lfilter([1.0 - a], [1.0, -a], power)
            variants.append(dataclasses.replace(self, thermal_time_constant=float(tau),
                                                heating=heating / max(heating.max(), np.finfo(float).tiny)))
        return variants

    def voltage(self, s):
        return (self.heating[s.index] * s.current)[None]

    def settings(self):
        return {'thermal_time_constant': self.thermal_time_constant}


@register_candidate
@dataclasses.dataclass(frozen=True)
class InductanceSaturation(Candidate):
    """Incremental inductance L(I) = L0 + L2 g(I), g = I^2 / (1 + (I/I_s)^2) (L2 < 0 when the iron saturates).

    With L2 = -L0 / I_s^2 this is L0 / (1 + (I/I_s)^2), the usual saturation curve; for small currents
    (I_s -> infinity, also searched) it is the quadratic L0 + L2 I^2. I_s is searched on a grid of the
    record's peak current."""

    name: ClassVar[str] = 'inductance_saturation'
    parameters: ClassVar[tuple] = ('inductance_quadratic',)
    units: ClassVar[tuple] = ('H/A^2',)
    acts_on: ClassVar[tuple] = ('electrical',)
    signs: ClassVar[tuple] = (-1,)
    saturation_scale: float = np.inf   # A: I_s

    def variants(self, data):
        peak = np.max(np.abs(data.signals['current']))
        return [self] + [dataclasses.replace(self, saturation_scale=float(peak * f))
                         for f in np.geomspace(0.4, 4.0, 15)]

    def inductance(self, s):
        return (s.current ** 2 / (1.0 + (s.current / self.saturation_scale) ** 2))[None]

    def reported(self, values, stds, model):
        out = super().reported(values, stds, model)
        l0, l2 = model['inductance'], values[0]
        if l2 < 0:   # L0 / (1 + (I/I_sat)^2) ~ L0 (1 - I^2 / I_sat^2)
            current = np.sqrt(-l0 / l2)
            out['saturation_current'] = (float(current), float(0.5 * current * stds[0] / abs(l2)))
        return out


@register_candidate
@dataclasses.dataclass(frozen=True)
class ForceConstantVariation(Candidate):
    """Km(x) = Km + K1 (x - x_mean) + K2 (x - x_mean)^2, in the coil force and the back-EMF alike."""

    name: ClassVar[str] = 'force_constant_variation'
    parameters: ClassVar[tuple] = ('emf_constant_slope', 'emf_constant_curvature')
    units: ClassVar[tuple] = ('N/(A m)', 'N/(A m^2)')
    acts_on: ClassVar[tuple] = ('electrical', 'mechanical')
    signs: ClassVar[tuple] = (0, 0)
    center: float = 0.0

    def variants(self, data):
        return [dataclasses.replace(self, center=float(np.mean(data.signals['position'])))]

    def _powers(self, s):
        offset = s.position - self.center
        return np.stack((offset, offset * offset))

    def voltage(self, s):
        return self._powers(s) * s.velocity

    def force(self, s):
        return -self._powers(s) * s.current


@register_candidate
@dataclasses.dataclass(frozen=True)
class SensorDelay(Candidate):
    """Sensed signals delivered d samples late (1 <= d <= data.MAX_DELAY): one of them, or all by the same d.

    With a measured force nothing is applied, so only a delay between the two sensors can show."""

    name: ClassVar[str] = 'sensor_delay'
    acts_on: ClassVar[tuple] = ('electrical', 'mechanical', 'force')
    delays: tuple = ()   # ((signal, samples), ...)

    def variants(self, data):
        sensed = data.sensed
        patterns = [tuple(int(s == late) for s in sensed) for late in sensed]
        if data.electrical:
            patterns.append((1,) * len(sensed))
        return [dataclasses.replace(self, delays=tuple(zip(sensed, (d * p for p in pattern))))
                for pattern in patterns for d in range(1, MAX_DELAY + 1)]

    def realigned(self, data):
        return data.realigned(dict(self.delays))

    def settings(self):
        return {f'{name}_delay_samples': d for name, d in self.delays}

    def reported(self, values, stds, model):
        return {f'{name}_delay': (d * model['sample_period'], 0.0) for name, d in self.delays}


@register_candidate
@dataclasses.dataclass(frozen=True)
class DriveVoltageError(Candidate):
    """The drive applies less than the voltage recorded: Vd sign(I) (an H-bridge's dead time drops about that
    much, against the current) plus a constant offset V0; the record holds the commanded voltage.

    sign(I) is smoothed as tanh(I / I_eps) (the drop fades as the current, and so the time the bridge's
    diodes conduct, goes to zero); I_eps is searched on a grid from 0.1 % to 30 % of the peak current. A constant
    current-sensor offset I0 leaves exactly the signature of V0 = -R I0 (its mechanical part merges with the
    load force), so the two cannot be told apart; the report gives both readings of the offset.
    """

    name: ClassVar[str] = 'drive_voltage_error'
    parameters: ClassVar[tuple] = ('dead_time_drop', 'voltage_offset')
    units: ClassVar[tuple] = ('V', 'V')
    acts_on: ClassVar[tuple] = ('electrical',)
    signs: ClassVar[tuple] = (1, 0)
    current_scale: float = 0.0   # A: I_eps

    def variants(self, data):
        peak = max(np.max(np.abs(data.signals['current'])), np.finfo(float).tiny)
        return [dataclasses.replace(self, current_scale=float(scale)) for scale in peak * np.geomspace(1e-3, 0.3, 11)]

    def voltage(self, s):
        return np.stack((np.tanh(s.current / self.current_scale), np.ones_like(s.current)))

    def settings(self):
        return {'current_scale': self.current_scale}

    def reported(self, values, stds, model):
        out = super().reported(values, stds, model)
        out['equivalent_current_offset'] = (float(-values[1] / model['resistance']),
                                             float(stds[1] / model['resistance']))
        return out

