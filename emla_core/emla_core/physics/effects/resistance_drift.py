"""The coil resistance drifting with the coil's temperature (docs/physics.md §6.2).

The plant heats a first-order coil: C_th dT/dt = R(T) I^2 - (T - T_amb) / R_th, R(T) = R (1 + alpha (T - T_amb)).
The batch regression sees only the resistance: R(t) = R + dR q(t), q the coil's heating (I^2 low-passed with
the thermal time constant R_th C_th, scaled to peak at 1), so dR is the rise at the record's hottest point; the
coil's thermal resistance and capacitance are not separable from electrical data alone.
"""
import dataclasses
from typing import ClassVar, Self

import numba
import numpy as np

from ..candidate import Candidate
from ..effect import AMBIENT_TEMPERATURE, Effect, Parameter, register_effect

SETTINGS = (Parameter('temperature_coefficient', '1/K', 0.0039, lower=0.0, doc='alpha (copper 0.39 %/K)'),
            Parameter('thermal_resistance', 'K/W', 3.0, lower=1e-300, infinite=True, doc='R_th, coil to ambient'),
            Parameter('thermal_capacitance', 'J/K', 15.0, lower=1e-300, infinite=True, doc='C_th'),
            Parameter('ambient_temperature', 'deg C', AMBIENT_TEMPERATURE, lower=-273.15,
                      doc='T_amb; the nominal R is R at this temperature'))


@numba.njit(cache=True)
def drift_factor(temperature, coefficient, ambient):
    return 1.0 + coefficient * (temperature - ambient)


@numba.njit(cache=True)
def thermal_rate(temperature, power, ambient, thermal_resistance, thermal_capacitance):
    """dT/dt of a first-order coil: C dT/dt = R I^2 - (T - T_ambient) / R_th."""
    return (power - (temperature - ambient) / thermal_resistance) / thermal_capacitance


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """dR q(t) I in the voltage; the thermal time constant is searched on a grid (a long one gives a ramp)."""

    name: ClassVar[str] = 'resistance_drift'
    parameters: ClassVar[tuple] = ('resistance_rise',)
    units: ClassVar[tuple] = ('ohm',)
    acts_on: ClassVar[tuple] = ('electrical',)
    signs: ClassVar[tuple] = (1,)
    thermal_time_constant: float = 0.0   # s
    heating: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)

    scale: ClassVar[str] = 'thermal_time_constant'

    def variants(self, data):
        span = len(data) * data.sample_period
        return [self.at(data, tau) for tau in span * np.geomspace(0.01, 10.0, 13)]

    def at(self, data, value):
        from scipy.signal import lfilter  # here: the nodes that load the physics need no scipy
        a = np.exp(-data.sample_period / value)
        heating = lfilter([1.0 - a], [1.0, -a], data.signals['current'] ** 2)
        return dataclasses.replace(self, thermal_time_constant=float(value),
                                   heating=heating / max(heating.max(), np.finfo(float).tiny))

    def voltage(self, s):
        return (self.heating[s.index] * s.current)[None]


@register_effect
@dataclasses.dataclass(frozen=True)
class ResistanceDrift(Effect):
    """R = R_ambient (1 + alpha (T - T_ambient)), T from a first-order coil thermal model.

    Copper alpha = 0.39 %/K; R_th = 3 K/W and C_th = 15 J/K (a coil of some 40 g) give a 45 s thermal
    time constant and about +19 % resistance at 16 W (4 ohm, 2 A rms). `fast()` shrinks the time constant
    for tests and short scenarios.
    """

    name: ClassVar[str] = 'resistance_drift'
    settings: ClassVar[tuple] = SETTINGS
    candidate: ClassVar[type] = _Candidate
    online_by_forgetting: ClassVar[bool] = True
    control_refusal: ClassVar[str] = 'it enters the law only through the adapted resistance'
    temperature_coefficient: float = 0.0039
    thermal_resistance: float = 3.0
    thermal_capacitance: float = 15.0
    ambient_temperature: float = AMBIENT_TEMPERATURE

    @classmethod
    def fast(cls, time_constant: float = 0.05, **fields: float) -> Self:
        """Same steady temperature rise, thermal time constant R_th C_th = time_constant (s)."""
        thermal_resistance = fields.pop('thermal_resistance', cls.thermal_resistance)
        return cls(thermal_resistance=thermal_resistance,
                   thermal_capacitance=time_constant / thermal_resistance, **fields)

    @classmethod
    def from_model(cls, values: dict[str, float], settings: dict[str, float]) -> Self:
        raise ValueError('resistance_drift: a model file holds the rise over its own record; the plant needs the '
                         'coil\'s thermal resistance and capacitance')

    def resistance_factor(self, temperature: float) -> float:
        return drift_factor(temperature, self.temperature_coefficient, self.ambient_temperature)

    def temperature_rate(self, temperature: float, joule_power: float) -> float:
        return thermal_rate(temperature, joule_power, self.ambient_temperature,
                            self.thermal_resistance, self.thermal_capacitance)

    def kernel_values(self) -> dict[str, float] | None:
        return {'temperature_coefficient': self.temperature_coefficient,
                'ambient_temperature': self.ambient_temperature,
                'thermal_resistance': self.thermal_resistance,
                'thermal_capacitance': self.thermal_capacitance}
