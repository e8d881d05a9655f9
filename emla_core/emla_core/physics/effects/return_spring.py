"""A return spring k (x - x_c), or with k < 0 a magnetic (reluctance) stiffness (docs/physics.md §6.2)."""
import dataclasses
from typing import ClassVar

import numba
import numpy as np

from ..candidate import Candidate, of_effect
from ..effect import Effect, Parameter, register_effect
from ..online import StiffnessColumn

PARAMETERS = (Parameter('spring_stiffness', 'N/m', 2000.0,
                        doc='k; negative: a magnetic stiffness, a force growing toward the pole'),)
SETTINGS = (Parameter('spring_center', 'm', 0.0, doc='x_c, where the spring force is zero'),)


@numba.njit(cache=True)
def spring_force(position, stiffness, center):
    return stiffness * (position - center)


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """k (x - x_c) with x_c the record's mean position: the spring's true rest position merges with the load
    force (only k is separable), so the nominal Fl is the total force at x = x_c."""

    name: ClassVar[str] = 'return_spring'
    parameters, units = of_effect(PARAMETERS)
    acts_on: ClassVar[tuple] = ('mechanical', 'force')
    signs: ClassVar[tuple] = (0,)
    spring_center: float = 0.0

    def variants(self, data):
        return [dataclasses.replace(self, spring_center=float(np.mean(data.signals['position'])))]

    def force(self, s):
        return (s.position - self.spring_center)[None]

    def effect_name(self, values):
        return 'magnetic_stiffness' if values[0] < 0 else self.name


@register_effect
@dataclasses.dataclass(frozen=True)
class ReturnSpring(Effect):
    """Spring force k (x - x_c) (N/m, m), as in valve actuators; 2000 N/m gives 10 N at 5 mm."""

    name: ClassVar[str] = 'return_spring'
    parameters: ClassVar[tuple] = PARAMETERS
    settings: ClassVar[tuple] = SETTINGS
    candidate: ClassVar[type] = _Candidate
    # online the centre's -k x_c merges with the load force: the load force is the total at x = 0
    online: ClassVar[object] = StiffnessColumn('spring_stiffness')
    spring_stiffness: float = 2000.0
    spring_center: float = 0.0

    def extra_force(self, position: float, velocity: float) -> float:
        return spring_force(position, self.spring_stiffness, self.spring_center)

    def kernel_values(self) -> dict[str, float] | None:
        return {'spring_stiffness': self.spring_stiffness, 'spring_center': self.spring_center}

    def compensation(self) -> dict[str, float]:
        return {'spring_stiffness': self.spring_stiffness, 'spring_center': self.spring_center}
