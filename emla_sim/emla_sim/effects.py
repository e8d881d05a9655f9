"""Effects a real actuator has beyond the two-equation model (physics.md), and timed parameter changes.

An effect is a small frozen dataclass with a `name` (as in physics.md) and defaults of a strength the
Table 1 actuator could really have. The plant sees effects only through the hooks of `Effect`
(factors multiply, forces and rates add over the active effects):

    r   = R  * resistance_factor(T)      coil resistance at coil temperature T (deg C)
    l   = L  * inductance_factor(I)      incremental inductance d psi/dI (flux linkage psi(I))
    k   = Km * emf_factor(x)             force constant = back-EMF constant at position x
    u   = r I + l dI/dt + k v
    m dv/dt = k I - B v - Fl - extra_force(x, v) - friction,   |friction| <= coulomb_force()
    dT/dt = temperature_rate(T, r I^2)

Built-in effects also give `kernel_values()`: their parameters for the compiled (numba) dynamics at the
end of this module. The plant integrates an effect class without them (a user's own, added with
`register_effect`) through its hooks in plain Python, which is correct but about 100x slower.
"""
import dataclasses
import math
import numbers
from typing import ClassVar

import numba
import numpy as np

from emla_core.parameters import PARAMETER_NAMES

AMBIENT_TEMPERATURE = 20.0  # deg C; the coil temperature when no thermal model is active


# ---- the physics of the built-in effects, shared by their hooks and by the compiled dynamics ----

@numba.njit(cache=True)
def _drift_factor(temperature, coefficient, ambient):
    return 1.0 + coefficient * (temperature - ambient)


@numba.njit(cache=True)
def _thermal_rate(temperature, power, ambient, thermal_resistance, thermal_capacitance):
    # first-order coil: C dT/dt = R I^2 - (T - T_ambient) / R_th
    return (power - (temperature - ambient) / thermal_resistance) / thermal_capacitance


@numba.njit(cache=True)
def _saturation_factor(current, saturation_current):
    # incremental inductance L0 / (1 + (I/I_sat)^2), i.e. flux linkage psi = L0 I_sat atan(I/I_sat)
    ratio = current / saturation_current
    return 1.0 / (1.0 + ratio * ratio)


@numba.njit(cache=True)
def _emf_variation(position, curvature, center):
    offset = position - center
    return max(1.0 - curvature * offset * offset, 0.0)


@numba.njit(cache=True)
def _spring_force(position, stiffness, rest_position):
    return stiffness * (position - rest_position)


@numba.njit(cache=True)
def _friction(velocity, drive_force, mass, coulomb_force, relaxation_time):
    """Coulomb friction Fc sign(v) with sticking resolved in the time-stepping way.

    The friction is the force that would stop the mass within `relaxation_time` (the integration
    sub-step), limited to +-Fc, with the driving force first limited to +-Fc. So: a mass driven by less
    than Fc sticks (its velocity decays to exactly zero, no creep); a sliding mass feels Fc sign(v); a
    velocity reversal switches the friction over a band |v| < 2 Fc tau / m around zero. The right-hand
    side stays continuous, so RK4 does not chatter.
    """
    if coulomb_force <= 0.0:
        return 0.0
    drive = min(max(drive_force, -coulomb_force), coulomb_force)
    return min(max(mass * velocity / relaxation_time + drive, -coulomb_force), coulomb_force)


@numba.njit(cache=True)
def coupled_rates(current, velocity, voltage, resistance, inductance, emf_constant, mass, damping,
                  load, coulomb_force, relaxation_time):
    """(dI/dt, dv/dt) for effective parameters at the current state; load = Fl + extra forces."""
    drive = emf_constant * current - damping * velocity - load
    friction = _friction(velocity, drive, mass, coulomb_force, relaxation_time)
    return ((voltage - resistance * current - emf_constant * velocity) / inductance,
            (drive - friction) / mass)


# ---- the hook interface and the built-in effects ----

class Effect:
    """Base class of plant effects: every hook returns its neutral value; subclasses override some.

    Subclasses are frozen dataclasses with a class attribute `name`. Numeric fields must not be NaN and
    are finite unless listed in `_positive` (> 0, where +inf switches that part of the effect off);
    fields in `_non_negative` must be >= 0.
    """

    name: ClassVar[str] = ''
    ambient_temperature = None  # deg C, for an effect that models the coil temperature
    _positive: ClassVar[tuple] = ()
    _non_negative: ClassVar[tuple] = ()

    def __post_init__(self):
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if not isinstance(value, numbers.Real) or isinstance(value, bool):
                continue
            label = f'{type(self).__name__}.{field.name}'
            if math.isnan(value) or (math.isinf(value) and field.name not in self._positive):
                raise ValueError(f'{label} must be finite, got {value!r}')
            if field.name in self._positive and value <= 0.0:
                raise ValueError(f'{label} must be positive, got {value!r}')
            if field.name in self._non_negative and value < 0.0:
                raise ValueError(f'{label} must be >= 0, got {value!r}')
            object.__setattr__(self, field.name, float(value))

    def resistance_factor(self, temperature):
        """R(T) / R."""
        return 1.0

    def temperature_rate(self, temperature, joule_power):
        """dT/dt (K/s) of the coil given its Joule heating R(T) I^2 (W)."""
        return 0.0

    def inductance_factor(self, current):
        """Incremental inductance d psi/dI at this current, over L."""
        return 1.0

    def emf_factor(self, position):
        """Km(x) / Km, applied to both the coil force and the back-EMF."""
        return 1.0

    def extra_force(self, position, velocity):
        """Extra force on the moving part (N), counted like Fl: positive opposes motion towards +x."""
        return 0.0

    def coulomb_force(self):
        """Coulomb friction level Fc (N); the plant applies it as Fc sign(v) with sticking."""
        return 0.0

    def kernel_values(self):
        """{kernel slot: value} for the compiled dynamics, or None to be integrated through the hooks."""
        return None


EFFECTS = {}


def register_effect(cls):
    """Class decorator: make an Effect subclass available to `make_effect` under `cls.name`."""
    if not (isinstance(cls, type) and issubclass(cls, Effect)):
        raise TypeError(f'register_effect needs a subclass of Effect, got {cls!r}')
    if not cls.name:
        raise ValueError(f'{cls.__name__} has no name')
    if EFFECTS.get(cls.name, cls) is not cls:
        raise ValueError(f'an effect named {cls.name!r} is already registered ({EFFECTS[cls.name].__name__})')
    EFFECTS[cls.name] = cls
    return cls


def make_effect(name, **parameters):
    """An effect by its registered name, e.g. make_effect('return_spring', stiffness=500.0)."""
    if name not in EFFECTS:
        raise ValueError(f'unknown effect {name!r}; known: {sorted(EFFECTS)}')
    try:
        return EFFECTS[name](**parameters)
    except TypeError as error:
        raise ValueError(f'bad parameters for effect {name!r}: {error}') from None


@register_effect
@dataclasses.dataclass(frozen=True)
class CoulombFriction(Effect):
    """Dry friction Fc sign(v), sticking below breakaway (see `_friction`); 1 N is ~1.5 % of peak force."""

    name: ClassVar[str] = 'coulomb_friction'
    _non_negative: ClassVar[tuple] = ('force',)
    force: float = 1.0

    def coulomb_force(self):
        return self.force

    def kernel_values(self):
        return {'coulomb_force': self.force}


@register_effect
@dataclasses.dataclass(frozen=True)
class ReturnSpring(Effect):
    """Spring force k (x - x0) (N/m, m), as in valve actuators; 2000 N/m gives 10 N at 5 mm. A negative k is
    a magnetic (reluctance) stiffness: a force growing toward the pole, as in solenoids."""

    name: ClassVar[str] = 'return_spring'
    stiffness: float = 2000.0
    rest_position: float = 0.0

    def extra_force(self, position, velocity):
        return _spring_force(position, self.stiffness, self.rest_position)

    def kernel_values(self):
        return {'spring_stiffness': self.stiffness, 'spring_rest': self.rest_position}


@register_effect
@dataclasses.dataclass(frozen=True)
class ResistanceDrift(Effect):
    """R = R_ambient (1 + alpha (T - T_ambient)), T from a first-order coil thermal model.

    Copper alpha = 0.39 %/K; R_th = 3 K/W and C_th = 15 J/K (a coil of some 40 g) give a 45 s thermal
    time constant and about +19 % resistance at 16 W (4 ohm, 2 A rms). `fast()` shrinks the time constant
    for tests and short scenarios.
    """

    name: ClassVar[str] = 'resistance_drift'
    _positive: ClassVar[tuple] = ('thermal_resistance', 'thermal_capacitance')
    _non_negative: ClassVar[tuple] = ('temperature_coefficient',)
    temperature_coefficient: float = 0.0039  # 1/K
    thermal_resistance: float = 3.0  # K/W, coil to ambient
    thermal_capacitance: float = 15.0  # J/K
    ambient_temperature: float = AMBIENT_TEMPERATURE  # deg C; R of ActuatorParameters is R at this temperature

    @classmethod
    def fast(cls, time_constant=0.05, **fields):
        """Same steady temperature rise, thermal time constant R_th C_th = time_constant (s)."""
        thermal_resistance = fields.pop('thermal_resistance', cls.thermal_resistance)
        return cls(thermal_resistance=thermal_resistance,
                   thermal_capacitance=time_constant / thermal_resistance, **fields)

    def resistance_factor(self, temperature):
        return _drift_factor(temperature, self.temperature_coefficient, self.ambient_temperature)

    def temperature_rate(self, temperature, joule_power):
        return _thermal_rate(temperature, joule_power, self.ambient_temperature,
                             self.thermal_resistance, self.thermal_capacitance)

    def kernel_values(self):
        return {'temperature_coefficient': self.temperature_coefficient,
                'ambient_temperature': self.ambient_temperature,
                'thermal_resistance': self.thermal_resistance,
                'thermal_capacitance': self.thermal_capacitance}


@register_effect
@dataclasses.dataclass(frozen=True)
class InductanceSaturation(Effect):
    """Incremental inductance L / (1 + (I/I_sat)^2): 64 % of L at 6 A (24 V / 4 ohm) with I_sat = 8 A.

    The electrical equation becomes u = R I + d psi(I)/dt + Km v with d psi/dI the incremental inductance.
    """

    name: ClassVar[str] = 'inductance_saturation'
    _positive: ClassVar[tuple] = ('saturation_current',)
    saturation_current: float = 8.0  # A

    def inductance_factor(self, current):
        return _saturation_factor(current, self.saturation_current)

    def kernel_values(self):
        return {'saturation_current': self.saturation_current}


@register_effect
@dataclasses.dataclass(frozen=True)
class ForceConstantVariation(Effect):
    """Km(x) = Km (1 - c (x - x_c)^2) (floored at 0), in force and back-EMF alike.

    c = 4000 1/m^2: Km 10 % lower 5 mm away from the centre x_c, as field fringing at the stroke ends.
    """

    name: ClassVar[str] = 'force_constant_variation'
    _non_negative: ClassVar[tuple] = ('curvature',)
    curvature: float = 4000.0  # 1/m^2
    center: float = 0.0  # m

    def emf_factor(self, position):
        return _emf_variation(position, self.curvature, self.center)

    def kernel_values(self):
        return {'km_curvature': self.curvature, 'km_center': self.center}


@dataclasses.dataclass(frozen=True)
class ParameterChange:
    """A step change of one physical parameter at `time` (s): multiplied by `factor` or set to `value`.

    E.g. ParameterChange(0.5, 'resistance', 1.5) (R +50 %), ParameterChange(0.2, 'load_force', value=10.0).
    """

    time: float
    parameter: str
    factor: float | None = None
    value: float | None = None

    def __post_init__(self):
        if self.parameter not in PARAMETER_NAMES:
            raise ValueError(f'ParameterChange.parameter must be one of {PARAMETER_NAMES}, got {self.parameter!r}')
        if (self.factor is None) == (self.value is None):
            raise ValueError('ParameterChange needs exactly one of factor and value')
        if not (math.isfinite(self.time) and self.time >= 0.0):
            raise ValueError(f'ParameterChange.time must be finite and >= 0, got {self.time!r}')

    def apply(self, params):
        """The ActuatorParameters after this change (they validate the result)."""
        if self.factor is not None:
            return params.scaled(**{self.parameter: self.factor})
        return params.replace(**{self.parameter: self.value})


# ---- compiled dynamics of the built-in effects ----
# The kernel vector holds the six physical parameters (PARAMETER_NAMES order), then these effect slots,
# each at the value that switches its part of the physics off.
_NEUTRAL = {
    'coulomb_force': 0.0, 'spring_stiffness': 0.0, 'spring_rest': 0.0,
    'temperature_coefficient': 0.0, 'ambient_temperature': AMBIENT_TEMPERATURE,
    'thermal_resistance': math.inf, 'thermal_capacitance': math.inf,
    'saturation_current': math.inf, 'km_curvature': 0.0, 'km_center': 0.0,
}
_SLOTS = PARAMETER_NAMES + tuple(_NEUTRAL)
(_R, _L, _KM, _M, _B, _FL, _FC, _K, _X0, _ALPHA, _TAMB, _RTH, _CTH, _ISAT, _CURV, _XC) = range(len(_SLOTS))


def kernel_vector(params, effects):
    """The compiled dynamics' parameter vector, or None if some effect has no kernel values."""
    values = dict(_NEUTRAL, **params.physical())
    for effect in effects:
        contribution = effect.kernel_values()
        if contribution is None:
            return None
        unknown = set(contribution) - set(_NEUTRAL)
        if unknown:
            raise ValueError(f'{type(effect).__name__}.kernel_values() has unknown slots {sorted(unknown)}')
        values.update(contribution)
    return np.array([values[slot] for slot in _SLOTS])


@numba.njit(cache=True)
def _derivatives(i, x, v, temp, u, p, h):
    r = p[_R] * _drift_factor(temp, p[_ALPHA], p[_TAMB])
    km = p[_KM] * _emf_variation(x, p[_CURV], p[_XC])
    inductance = p[_L] * _saturation_factor(i, p[_ISAT])
    load = p[_FL] + _spring_force(x, p[_K], p[_X0])
    di, dv = coupled_rates(i, v, u, r, inductance, km, p[_M], p[_B], load, p[_FC], h)
    return di, v, dv, _thermal_rate(temp, r * i * i, p[_TAMB], p[_RTH], p[_CTH])


@numba.njit(cache=True)
def integrate_interval(i, x, v, temp, u, dt, substeps, p):
    """(I, x, v, T) after dt at constant voltage u: `substeps` classical RK4 steps."""
    h = dt / substeps
    for _ in range(substeps):
        a0, a1, a2, a3 = _derivatives(i, x, v, temp, u, p, h)
        b0, b1, b2, b3 = _derivatives(i + 0.5 * h * a0, x + 0.5 * h * a1, v + 0.5 * h * a2,
                                      temp + 0.5 * h * a3, u, p, h)
        c0, c1, c2, c3 = _derivatives(i + 0.5 * h * b0, x + 0.5 * h * b1, v + 0.5 * h * b2,
                                      temp + 0.5 * h * b3, u, p, h)
        d0, d1, d2, d3 = _derivatives(i + h * c0, x + h * c1, v + h * c2, temp + h * c3, u, p, h)
        i += h / 6.0 * (a0 + 2.0 * (b0 + c0) + d0)
        x += h / 6.0 * (a1 + 2.0 * (b1 + c1) + d1)
        v += h / 6.0 * (a2 + 2.0 * (b2 + c2) + d2)
        temp += h / 6.0 * (a3 + 2.0 * (b3 + c3) + d3)
    return i, x, v, temp


@numba.njit(cache=True)
def integrate_sequence(state, voltages, dt, substeps, p):
    """Rows (I, x, v, T, coil force) at the end of each ZOH interval, from state (I, x, v, T)."""
    out = np.empty((voltages.size, 5))
    i, x, v, temp = state[0], state[1], state[2], state[3]
    for k in range(voltages.size):
        i, x, v, temp = integrate_interval(i, x, v, temp, voltages[k], dt, substeps, p)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = i, x, v, temp
        out[k, 4] = p[_KM] * _emf_variation(x, p[_CURV], p[_XC]) * i
    return out
