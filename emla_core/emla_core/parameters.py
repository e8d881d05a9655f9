"""Physical parameters of the electromagnetic linear actuator (SI units).

    electrical:  u = R I + L dI/dt + Km v
    mechanical:  m dv/dt = Km I - B v - Fl,   dx/dt = v
"""
from __future__ import annotations

import dataclasses
import math
import numbers

# The actuator families (`--actuator`): a moving coil (this module), a solenoid (physics/solenoid.py).
FAMILIES = ('moving_coil', 'solenoid')
# The six physical parameters, in the order used across the suite (identification, messages, reports).
PARAMETER_NAMES = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping', 'load_force')
# SI units of the ActuatorParameters fields.
PARAMETER_UNITS = {'resistance': 'ohm', 'inductance': 'H', 'emf_constant': 'V s/m (= N/A)', 'mass': 'kg',
                   'damping': 'N s/m', 'load_force': 'N (opposes +x)', 'supply_voltage': 'V'}
# Closed bounds a model's parameters must lie in: physics (R, L, Km, m > 0, B >= 0) and a span wider than any
# electromagnetic actuator's (a coil of a megaohm or a moving part of a thousand tonnes is a unit slip).
PARAMETER_BOUNDS = {'resistance': (1e-9, 1e6), 'inductance': (1e-12, 1e2), 'emf_constant': (1e-9, 1e5),
                    'mass': (1e-9, 1e6), 'damping': (0.0, 1e9), 'load_force': (-1e9, 1e9)}


@dataclasses.dataclass(frozen=True)
class ActuatorParameters:
    """R (ohm), L (H), Km (N/A = V s/m), m (kg), B (N s/m), Fl (N, opposing +x) and the supply voltage (V)."""

    resistance: float = 4.0
    inductance: float = 1.6e-3
    emf_constant: float = 10.8
    mass: float = 0.036
    damping: float = 2.0
    load_force: float = 0.0
    supply_voltage: float = 24.0

    def __post_init__(self):
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
                raise ValueError(f'ActuatorParameters.{field.name} must be a finite number, got {value!r}')
            object.__setattr__(self, field.name, float(value))
        for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'supply_voltage'):
            if getattr(self, name) <= 0.0:
                raise ValueError(f'ActuatorParameters.{name} must be positive, got {getattr(self, name)!r}')
        if self.damping < 0.0:
            raise ValueError(f'ActuatorParameters.damping must be >= 0, got {self.damping!r}')

    def physical(self) -> dict[str, float]:
        """The six physical parameters as {name: value} (PARAMETER_NAMES order)."""
        return {name: getattr(self, name) for name in PARAMETER_NAMES}

    def replace(self, **values: float) -> ActuatorParameters:
        """A copy with some fields set to new values."""
        self._check_names(values)
        return dataclasses.replace(self, **values)

    def scaled(self, **factors: float) -> ActuatorParameters:
        """A copy with some fields multiplied by factors, e.g. scaled(resistance=1.5)."""
        self._check_names(factors)
        return dataclasses.replace(self, **{name: getattr(self, name) * f for name, f in factors.items()})

    def _check_names(self, names):
        known = [field.name for field in dataclasses.fields(self)]
        unknown = sorted(set(names) - set(known))
        if unknown:
            raise ValueError(f'unknown actuator parameter(s) {unknown}; known: {known}')


TABLE1 = ActuatorParameters()
