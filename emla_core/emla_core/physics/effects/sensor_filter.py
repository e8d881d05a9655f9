"""A sensor's first-order low-pass (an anti-alias filter) in front of its sampler (docs/physics.md §7)."""
import dataclasses
import math
from typing import ClassVar

import numpy as np

from ..candidate import Candidate
from ..effect import Effect, Parameter, register_effect

SIGNALS = ('current', 'position', 'force')
SETTINGS = tuple(Parameter(f'{name}_filter_time_constant', 's', 0.0, lower=0.0,
                           doc=f'tau of the {name} sensor\'s filter, tau dy/dt = {name} - y (0: none)')
                 for name in SIGNALS)
GRID = tuple(2.0 ** np.arange(-5, 4))   # time constants tried, Ts/32 .. 8 Ts; then refined (Candidate.scale)


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """One sensed signal, or all of them (one anti-alias filter per channel), behind a first-order low-pass of time
    constant tau (searched from Ts/32 to 8 Ts, then refined): the data are re-aligned (data.Data.unfiltered) by
    passing the other signals through the same filter, so that the equations hold between filtered signals and the
    filtered signal's noise stays as it is.

    No regression term: like a delay it changes which samples belong together, not the actuator's physics. At
    low frequencies it is a delay of tau; its gain falls as 1 / sqrt(1 + (2 pi f tau)^2) where a delay's does
    not, which is what tells the two apart."""

    name: ClassVar[str] = 'sensor_filter'
    acts_on: ClassVar[tuple] = ('electrical', 'mechanical', 'force')
    scale: ClassVar[str] = 'time_constant'
    location: ClassVar[str] = 'the sensor'
    filtered: tuple = ('current',)   # the signals behind the filter
    sensed: tuple = ('current',)     # every sensed signal of the data (the settings list each)
    time_constant: float = 0.0       # s

    def variants(self, data):
        ts, sensed = data.sample_period, tuple(data.sensed)
        patterns = [(name,) for name in sensed]
        if data.electrical:   # every channel: the voltage alone has not passed the filter
            patterns.append(sensed)
        return [dataclasses.replace(self, filtered=filtered, sensed=sensed, time_constant=float(ts * f))
                for filtered in patterns for f in GRID]

    def at(self, data, value):
        return dataclasses.replace(self, time_constant=float(value))

    def realigned(self, data):
        return data.unfiltered(self.filtered, self.time_constant)

    def settings(self):
        return {f'{name}_filter_time_constant': self.time_constant if name in self.filtered else 0.0
                for name in self.sensed}

    def reported(self, values, stds, model):
        """`<signal>_filter_time_constant` (s) and `<signal>_filter_cutoff` 1 / (2 pi tau) (Hz) of each signal
        behind the filter."""
        tau = self.time_constant
        out = {}
        for name in self.filtered:
            out[f'{name}_filter_time_constant'] = (tau, 0.0)
            if tau > 0:
                out[f'{name}_filter_cutoff'] = (1.0 / (2.0 * math.pi * tau), 0.0)
        return out


@register_effect
@dataclasses.dataclass(frozen=True)
class SensorFilter(Effect):
    """A sensor's first-order low-pass: it changes what the recorded signals mean, no equation of the actuator."""

    name: ClassVar[str] = 'sensor_filter'
    settings: ClassVar[tuple] = SETTINGS
    candidate: ClassVar[type] = _Candidate
    online_refusal: ClassVar[str] = 'a sensor filter re-aligns the signals; its time constant is not a linear parameter'
    control_refusal: ClassVar[str] = 'a sensor\'s filter, not the actuator\'s physics'
    simulation_refusal: ClassVar[str] = 'a sensor\'s filter, not the actuator\'s physics'
    current_filter_time_constant: float = 0.0
    position_filter_time_constant: float = 0.0
    force_filter_time_constant: float = 0.0
