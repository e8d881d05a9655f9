"""Timed changes of the actuator's parameters, for the plant (the effects live in emla_core.physics)."""
import dataclasses
import math

from emla_core.parameters import PARAMETER_NAMES, ActuatorParameters


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

    def apply(self, params: ActuatorParameters) -> ActuatorParameters:
        """The ActuatorParameters after this change (they validate the result)."""
        if self.factor is not None:
            return params.scaled(**{self.parameter: self.factor})
        assert self.value is not None  # __post_init__: exactly one of factor and value
        return params.replace(**{self.parameter: self.value})
