"""An inductance that depends on the position, L(x) = L + L1 d + L2 d^2 (d = x - x_c): the coil moving in and out
of the iron (docs/physics.md §6.2).

Flux linkage psi = L(x) I + Km x, co-energy W' = L(x) I^2 / 2 + Km x I, so beside the inductance the back-EMF
gains I L'(x) v and the force I^2 L'(x) / 2 (a reluctance force, pulling towards the larger inductance).
"""
import dataclasses
from typing import ClassVar

import numpy as np

from ..candidate import CenteredCandidate, of_effect
from ..effect import Effect, Parameter, register_effect

PARAMETERS = (Parameter('inductance_slope', 'H/m', 0.05, doc='L1; the default: L 12 % higher 4 mm towards +x '
                                                                'for the Table 1 coil'),
              Parameter('inductance_curvature', 'H/m^2', 0.0, doc='L2'))
SETTINGS = (Parameter('center', 'm', 0.0, doc='x_c'),)


@dataclasses.dataclass(frozen=True)
class _Candidate(CenteredCandidate):
    """(L1, L2) in (d, d^2) dI/dt + (1, 2 d) I v and the force -(1, 2 d) I^2 / 2, x_c the record's mean position."""

    name: ClassVar[str] = 'position_inductance'
    parameters, units = of_effect(PARAMETERS)
    acts_on: ClassVar[tuple] = ('electrical', 'mechanical')
    signs: ClassVar[tuple] = (0, 0)

    def inductance(self, s):
        d = self.offset(s)
        return np.stack((d, d * d))

    def _slopes(self, s):
        """L'(x) / (L1, L2): (1, 2 d)."""
        d = self.offset(s)
        return np.stack((np.ones_like(d), 2.0 * d))

    def voltage(self, s):
        return self._slopes(s) * (s.current * s.velocity)

    def force(self, s):
        return -0.5 * self._slopes(s) * s.current ** 2


@register_effect
@dataclasses.dataclass(frozen=True)
class PositionInductance(Effect):
    """L(x) = L + L1 (x - x_c) + L2 (x - x_c)^2 in the flux linkage L(x) I."""

    name: ClassVar[str] = 'position_inductance'
    parameters: ClassVar[tuple] = PARAMETERS
    settings: ClassVar[tuple] = SETTINGS
    candidate: ClassVar[type] = _Candidate
    online_refusal: ClassVar[str] = ('an inductance term has no place in the electrical regression\'s exact '
                                     'discretisation')
    control_refusal: ClassVar[str] = 'the inverse law uses one inductance'
    inductance_slope: float = 0.05
    inductance_curvature: float = 0.0
    center: float = 0.0

    def flux_terms(self, position: float, current: float) -> tuple[float, float, float]:
        d = position - self.center
        slope = self.inductance_slope + 2.0 * self.inductance_curvature * d   # L'(x)
        return (self.inductance_slope + self.inductance_curvature * d) * d, current * slope, \
            0.5 * current * current * slope
