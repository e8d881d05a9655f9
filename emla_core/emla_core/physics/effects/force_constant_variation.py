"""The force constant varying with position, Km(x) = Km + K1 d + K2 d^2 (d = x - x_c), in the coil force and the
back-EMF alike: field fringing at the ends of the stroke (docs/physics.md §6.2)."""
import dataclasses
from typing import ClassVar

import numba
import numpy as np

from ..candidate import CenteredCandidate, of_effect
from ..effect import Effect, Parameter, register_effect

PARAMETERS = (Parameter('emf_constant_slope', 'N/(A m)', 0.0, doc='K1'),
              Parameter('emf_constant_curvature', 'N/(A m^2)', -43200.0,
                        doc='K2; the default: Km 10 % lower 5 mm from the centre for the Table 1 actuator'))
SETTINGS = (Parameter('center', 'm', 0.0, doc='x_c'),)


@numba.njit(cache=True)
def emf_change(position, slope, curvature, center):
    """Km(x) - Km (N/A = V s/m)."""
    d = position - center
    return (slope + curvature * d) * d


@dataclasses.dataclass(frozen=True)
class _Candidate(CenteredCandidate):
    """(K1 d + K2 d^2) v in the voltage and -(K1 d + K2 d^2) I in the force, x_c the record's mean position."""

    name: ClassVar[str] = 'force_constant_variation'
    parameters, units = of_effect(PARAMETERS)
    acts_on: ClassVar[tuple] = ('electrical', 'mechanical')
    signs: ClassVar[tuple] = (0, 0)

    def _powers(self, s):
        d = self.offset(s)
        return np.stack((d, d * d))

    def voltage(self, s):
        return self._powers(s) * s.velocity

    def force(self, s):
        return -self._powers(s) * s.current


@register_effect
@dataclasses.dataclass(frozen=True)
class ForceConstantVariation(Effect):
    """Km(x) = Km + K1 (x - x_c) + K2 (x - x_c)^2: flux linkage psi = L I + integral of Km(x) dx."""

    name: ClassVar[str] = 'force_constant_variation'
    parameters: ClassVar[tuple] = PARAMETERS
    settings: ClassVar[tuple] = SETTINGS
    candidate: ClassVar[type] = _Candidate
    online_refusal: ClassVar[str] = ('it multiplies the coil current in both equations; the electrical regression\'s '
                                     'exact discretisation has no place for it')
    control_refusal: ClassVar[str] = 'the inverse law uses one force constant'
    emf_constant_slope: float = 0.0
    emf_constant_curvature: float = -43200.0
    center: float = 0.0

    def flux_terms(self, position: float, current: float) -> tuple[float, float, float]:
        change = emf_change(position, self.emf_constant_slope, self.emf_constant_curvature, self.center)
        return 0.0, change, change * current

    def kernel_values(self) -> dict[str, float] | None:
        return {'emf_constant_slope': self.emf_constant_slope, 'emf_constant_curvature': self.emf_constant_curvature,
                'emf_constant_center': self.center}
