"""Sensed signals delivered some samples late: a logger's or ADC's lag (docs/physics.md §7)."""
import dataclasses
from typing import ClassVar

from ..candidate import Candidate
from ..effect import Effect, register_effect


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """One sensed signal d samples late (1 <= d <= data.max_delay), or all by the same d.

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
                for pattern in patterns for d in range(1, data.max_delay + 1)]

    def realigned(self, data):
        return data.realigned(dict(self.delays))

    def settings(self):
        return {f'{name}_delay_samples': d for name, d in self.delays}

    def reported(self, values, stds, model):
        return {f'{name}_delay': (d * model['sample_period'], 0.0) for name, d in self.delays}


@register_effect
@dataclasses.dataclass(frozen=True)
class SensorDelay(Effect):
    """A sensor's delay: it re-aligns the recorded signals and changes no equation of the actuator."""

    name: ClassVar[str] = 'sensor_delay'
    candidate: ClassVar[type] = _Candidate
    online_refusal: ClassVar[str] = 'a delay re-aligns the signals; it is not a linear parameter'
    control_refusal: ClassVar[str] = 'a sensor\'s delay, not the actuator\'s physics'
    simulation_refusal: ClassVar[str] = 'a sensor\'s delay, not the actuator\'s physics (the sensor model adds delays)'
