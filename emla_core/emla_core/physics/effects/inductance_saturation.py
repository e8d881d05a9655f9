"""Saturation of the magnetic circuit: an incremental inductance falling with the current (docs/physics.md §6.2).

l(I) = L + L2 g(I), g(I) = I^2 / (1 + (I/I_s)^2). With L2 = -L / I_s^2 this is L / (1 + (I/I_s)^2), the usual
saturation curve (flux linkage L I_s atan(I/I_s)); with I_s = inf the quadratic L + L2 I^2 of small currents.
"""
import dataclasses
from typing import ClassVar, Self

import numba
import numpy as np

from ..candidate import Candidate, of_effect
from ..effect import Effect, Parameter, register_effect

PARAMETERS = (Parameter('inductance_quadratic', 'H/A^2', -2.5e-5, upper=0.0,
                        doc='L2; the default with I_s = 8 A is L / (1 + (I/8 A)^2) for the Table 1 coil'),)
SETTINGS = (Parameter('saturation_current', 'A', 8.0, lower=0.0, infinite=True, doc='I_s; inf: a pure quadratic'),)


@numba.njit(cache=True)
def inductance_change(current, quadratic, saturation_current):
    """l(I) - L (H)."""
    ratio = current / saturation_current
    return quadratic * current * current / (1.0 + ratio * ratio)


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """L2 g(I) as an inductance term, I_s searched: inf, or the record's peak current times 0.4 .. 4."""

    name: ClassVar[str] = 'inductance_saturation'
    parameters, units = of_effect(PARAMETERS)
    acts_on: ClassVar[tuple] = ('electrical',)
    signs: ClassVar[tuple] = (-1,)
    scale: ClassVar[str] = 'saturation_current'
    saturation_current: float = np.inf

    def variants(self, data):
        peak = np.max(np.abs(data.signals['current']))
        return [self] + [self.at(data, peak * f) for f in np.geomspace(0.4, 4.0, 15)]

    def at(self, data, value):
        return dataclasses.replace(self, saturation_current=float(value))

    def inductance(self, s):
        return inductance_change(s.current, 1.0, self.saturation_current)[None]

    def reported(self, values, stds, model):
        """Adds `equivalent_saturation_current` sqrt(-L/L2): the I_s of the curve L / (1 + (I/I_s)^2) whose
        quadratic start L (1 - I^2/I_s^2) has the fitted L2."""
        out = super().reported(values, stds, model)
        l0, l2 = model['inductance'], values[0]
        if l2 < 0:
            current = np.sqrt(-l0 / l2)
            out['equivalent_saturation_current'] = (float(current), float(0.5 * current * stds[0] / abs(l2)))
        return out


@register_effect
@dataclasses.dataclass(frozen=True)
class InductanceSaturation(Effect):
    """l(I) = L + L2 I^2 / (1 + (I/I_s)^2); the electrical equation becomes u = R I + l(I) dI/dt + Km v."""

    name: ClassVar[str] = 'inductance_saturation'
    parameters: ClassVar[tuple] = PARAMETERS
    settings: ClassVar[tuple] = SETTINGS
    candidate: ClassVar[type] = _Candidate
    online_refusal: ClassVar[str] = ('its saturation current is not a linear parameter, and an inductance term has no '
                                     'place in the electrical regression\'s exact discretisation')
    control_refusal: ClassVar[str] = 'the inverse law uses one inductance'
    inductance_quadratic: float = -2.5e-5
    saturation_current: float = 8.0

    @classmethod
    def curve(cls, inductance: float, saturation_current: float) -> Self:
        """The effect whose l(I) is inductance / (1 + (I / saturation_current)^2)."""
        return cls(inductance_quadratic=-inductance / saturation_current ** 2, saturation_current=saturation_current)

    def flux_terms(self, position: float, current: float) -> tuple[float, float, float]:
        return inductance_change(current, self.inductance_quadratic, self.saturation_current), 0.0, 0.0

    def kernel_values(self) -> dict[str, float] | None:
        return {'inductance_quadratic': self.inductance_quadratic, 'saturation_current': self.saturation_current}
