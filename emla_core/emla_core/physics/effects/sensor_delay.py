"""Sensed signals delivered late, by whole samples or a fraction of one: a logger's or ADC's lag (docs/physics.md §7).
"""
import dataclasses
from typing import ClassVar

from ..candidate import Candidate
from ..effect import Effect, register_effect

# delays tried (samples), each searched again between its neighbours (Candidate.scale); up to data.max_delay
GRID = (0.25, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0)


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """One sensed signal `delay` samples late (0 < delay <= data.max_delay, fractional too), or all by the same.

    The data are re-aligned (data.Data.realigned): the drive signal (current or force) moves by whole samples
    only; the fraction is applied to the voltage (its held value's interval mean) and the position (cubic
    interpolation) instead. With a measured force nothing is applied, so only a delay between the two sensors
    can show."""

    name: ClassVar[str] = 'sensor_delay'
    acts_on: ClassVar[tuple] = ('electrical', 'mechanical', 'force')
    scale: ClassVar[str] = 'delay'
    location: ClassVar[str] = 'the sensor'
    late: tuple = ()      # names of the signals delivered late
    sensed: tuple = ()    # every sensed signal of the data (the settings list each)
    delay: float = 0.0    # samples

    def variants(self, data):
        sensed = tuple(data.sensed)
        patterns = [(late,) for late in sensed]
        if data.electrical:
            patterns.append(sensed)
        return [dataclasses.replace(self, late=late, sensed=sensed, delay=d)
                for late in patterns for d in GRID if d <= data.max_delay]

    def at(self, data, value):
        return dataclasses.replace(self, delay=float(value))

    @property
    def delays(self):
        """((signal, samples), ...) of every sensed signal."""
        return tuple((name, self.delay if name in self.late else 0.0) for name in self.sensed)

    def realigned(self, data):
        return data.realigned(dict(self.delays))

    def settings(self):
        return {f'{name}_delay_samples': d for name, d in self.delays}

    def reported(self, values, stds, model):
        return {f'{name}_delay': (d * model['sample_period'], 0.0) for name, d in self.delays if name in self.late}


@register_effect
@dataclasses.dataclass(frozen=True)
class SensorDelay(Effect):
    """A sensor's delay: it re-aligns the recorded signals and changes no equation of the actuator."""

    name: ClassVar[str] = 'sensor_delay'
    candidate: ClassVar[type] = _Candidate
    online_refusal: ClassVar[str] = 'a delay re-aligns the signals; it is not a linear parameter'
    control_refusal: ClassVar[str] = 'a sensor\'s delay, not the actuator\'s physics'
    simulation_refusal: ClassVar[str] = 'a sensor\'s delay, not the actuator\'s physics (the sensor model adds delays)'
