"""Friction smooth through zero speed, Fc tanh(v / v_s): no sticking, a viscous-like slope Fc / v_s at rest
(docs/physics.md §6.2)."""
import dataclasses
import math
from typing import ClassVar

import numpy as np

from ..candidate import Candidate, of_effect
from ..effect import Effect, Parameter, register_effect

PARAMETERS = (Parameter('friction_force', 'N', 1.0, lower=0.0, doc='Fc, the level at speeds well above v_s'),)
SETTINGS = (Parameter('smoothing_speed', 'm/s', 1e-3, lower=1e-300, doc='v_s, over which the friction reverses'),)
GRID = np.geomspace(1e-4, 0.1, 10)   # v_s tried, times the record's peak speed; then refined (Candidate.scale)
SPAN = 5                             # samples each side of the local cubic that estimates the velocity
PIECES = 8                           # parts of each interval the term is given on between the samples


def measured_velocity(data):
    """The velocity the friction terms read: the slope of a local cubic through the measured position over
    +-SPAN samples (Savitzky-Golay). The five-point difference of data.velocity() carries about ten times the
    quantisation noise (a 1 um step at 10 kHz: 3 mm/s rms), which would smear a friction that changes over a few
    mm/s; the cubic follows the fast strokes' jerk."""
    from scipy.signal import savgol_filter  # here: the nodes that load the physics need no scipy
    x = data.signals['position']
    window = min(2 * SPAN + 1, len(x) // 2 * 2 - 1)
    return savgol_filter(x, window, 3, deriv=1, delta=data.sample_period)


def at_pieces(values, pieces):
    """(intervals, pieces): `values` given at the samples, linear over each interval, at the middle of each of its
    `pieces` equal parts."""
    share = (np.arange(pieces) + 0.5) / pieces
    return (1.0 - share) * values[:-1, None] + share * values[1:, None]


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """Fc tanh(v / v_s) as a force term, v the measured velocity (measured_velocity), in simulation too; v_s
    searched over 1e-4 .. 0.1 times the record's peak speed, then refined. Between the samples (force_between) v
    goes linearly over each interval: a friction steep in v turns within the interval where v crosses zero."""

    name: ClassVar[str] = 'smooth_friction'
    parameters, units = of_effect(PARAMETERS)
    acts_on: ClassVar[tuple] = ('mechanical', 'force')
    signs: ClassVar[tuple] = (1,)
    scale: ClassVar[str] = 'smoothing_speed'
    smoothing_speed: float = 0.0   # m/s
    shape: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)
    between: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)
    velocity: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)

    def variants(self, data):
        velocity = measured_velocity(data)
        peak = max(float(np.max(np.abs(velocity))), np.finfo(float).tiny)
        with_velocity = dataclasses.replace(self, velocity=velocity)
        return [with_velocity.at(data, peak * f) for f in GRID]

    def at(self, data, value):
        velocity = self.velocity if self.velocity is not None else measured_velocity(data)
        return dataclasses.replace(self, smoothing_speed=float(value), velocity=velocity,
                                   shape=np.tanh(velocity / float(value)),
                                   between=np.tanh(at_pieces(velocity, PIECES) / float(value))[..., None])

    def force(self, s):
        return self.shape[s.index][None]

    def force_between(self, data):
        return self.between


@register_effect
@dataclasses.dataclass(frozen=True)
class SmoothFriction(Effect):
    """Friction Fc tanh(v / v_s), opposing the motion: a lubricated contact, or the smooth friction many
    simulators write. It never sticks; below v_s it acts as a damping Fc / v_s."""

    name: ClassVar[str] = 'smooth_friction'
    parameters: ClassVar[tuple] = PARAMETERS
    settings: ClassVar[tuple] = SETTINGS
    candidate: ClassVar[type] = _Candidate
    online_refusal: ClassVar[str] = ('its smoothing speed is not a linear parameter (searched over whole records); '
                                     'coulomb_friction\'s column estimates its level')
    friction_force: float = 1.0
    smoothing_speed: float = 1e-3

    def extra_force(self, position: float, velocity: float) -> float:
        return self.friction_force * math.tanh(velocity / self.smoothing_speed)

    def compensation(self) -> dict[str, float]:
        """The inverse law's friction Fc tanh(v / 1 mm/s) at this level (its own smoothing speed)."""
        return {'coulomb_force': self.friction_force}
