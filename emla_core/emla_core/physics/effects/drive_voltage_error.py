"""The drive applies less than the voltage recorded: an H-bridge's dead-time drop and an offset (docs/physics.md §7)."""
import dataclasses
from typing import ClassVar

import numpy as np

from ..candidate import Candidate, of_effect
from ..effect import Effect, Parameter, register_effect

PARAMETERS = (Parameter('dead_time_drop', 'V', 0.6, lower=0.0, doc='V_d, the drop against the current'),
              Parameter('voltage_offset', 'V', 0.0, doc='V_0'))
SETTINGS = (Parameter('current_scale', 'A', 0.05, lower=1e-300, doc='I_eps, the current over which the drop fades'),)


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """V_d tanh(I / I_eps) + V_0 in the voltage; I_eps searched from 0.1 % to 30 % of the peak current.

    A constant current-sensor offset I0 leaves exactly the signature of V0 = -R I0 (its mechanical part merges
    with the load force), so the two cannot be told apart; the report gives both readings of the offset."""

    name: ClassVar[str] = 'drive_voltage_error'
    parameters, units = of_effect(PARAMETERS)
    acts_on: ClassVar[tuple] = ('electrical',)
    signs: ClassVar[tuple] = (1, 0)
    scale: ClassVar[str] = 'current_scale'
    current_scale: float = 0.0   # A: I_eps

    def variants(self, data):
        peak = max(np.max(np.abs(data.signals['current'])), np.finfo(float).tiny)
        return [self.at(data, scale) for scale in peak * np.geomspace(1e-3, 0.3, 11)]

    def at(self, data, value):
        return dataclasses.replace(self, current_scale=float(value))

    def voltage(self, s):
        return np.stack((np.tanh(s.current / self.current_scale), np.ones_like(s.current)))

    def path_voltage(self, current):
        """About zero current the drop acts as a resistance V_d / I_eps, up to tens of times R."""
        if not self.fitted:
            return None
        drop, offset = self.fitted
        shape = np.tanh(current / self.current_scale)
        return drop * shape + offset, drop * (1.0 - shape * shape) / self.current_scale

    def reported(self, values, stds, model):
        out = super().reported(values, stds, model)
        out['equivalent_current_offset'] = (float(-values[1] / model['resistance']),
                                             float(stds[1] / model['resistance']))
        return out


@register_effect
@dataclasses.dataclass(frozen=True)
class DriveVoltageError(Effect):
    """u_applied = u_recorded - V_d tanh(I / I_eps) - V_0: dead time drops about V_d against the current, fading
    as the current (and so the time the bridge's diodes conduct) goes to zero."""

    name: ClassVar[str] = 'drive_voltage_error'
    parameters: ClassVar[tuple] = PARAMETERS
    settings: ClassVar[tuple] = SETTINGS
    candidate: ClassVar[type] = _Candidate
    online_refusal: ClassVar[str] = 'its current scale is not a linear parameter (searched over whole records)'
    control_refusal: ClassVar[str] = 'the drive\'s error, not the actuator\'s physics'
    simulation_refusal: ClassVar[str] = 'the drive\'s error, not the actuator\'s physics'
    dead_time_drop: float = 0.6
    voltage_offset: float = 0.0
    current_scale: float = 0.05
