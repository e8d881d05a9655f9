"""The Stribeck effect: dry friction higher at rest than at speed (docs/physics.md §6.2).

With coulomb_friction (level Fc) it makes the Stribeck curve (Fc + dF exp(-(v / v_s)^2)) sign(v), breakaway at
Fs = Fc + dF; alone, a friction dF exp(-(v / v_s)^2) sign(v) that vanishes at speed. This effect is the excess
dF over the Coulomb level, so the discrepancy workflow names coulomb_friction first and this one after it, when
the data show the friction falling with speed.
"""
import dataclasses
import math
from typing import ClassVar

import numpy as np

from ..candidate import Candidate, of_effect
from ..effect import Effect, Parameter, register_effect
from .coulomb_friction import contact, position_noise
from .smooth_friction import SPANS, measured_velocities, peak_speed

PARAMETERS = (Parameter('stribeck_force', 'N', 0.5, lower=0.0, doc='dF = Fs - Fc, the excess of the breakaway force'),)
SETTINGS = (Parameter('stribeck_speed', 'm/s', 0.01, lower=1e-300, doc='v_s, over which the excess fades'),)
GRID = np.geomspace(1e-3, 0.05, 8)    # v_s tried, times the record's peak speed; then refined (Candidate.scale)
BAND = 6.0                           # the direction's pre-sliding band, in position-noise sigmas


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """dF d(t) exp(-(v / v_s)^2) as a force term: d the friction direction of coulomb_friction (the play
    operator on the measured position, band BAND position-noise sigmas: +-1 while sliding; followed between the
    samples, coulomb_friction.contact), v the measured velocity (smooth_friction.measured_velocities: each span a
    variant); v_s searched over 1e-3 .. 0.05 times the peak speed (above, it would be a Coulomb friction), then
    refined."""

    name: ClassVar[str] = 'stribeck_friction'
    parameters, units = of_effect(PARAMETERS)
    acts_on: ClassVar[tuple] = ('mechanical', 'force')
    reads: ClassVar[tuple] = ('position',)
    signs: ClassVar[tuple] = (1,)
    reading: ClassVar[str] = 'velocity_span'
    scale: ClassVar[str] = 'stribeck_speed'
    stribeck_speed: float = 0.0   # m/s
    velocity_span: int = SPANS[0]  # samples (smooth_friction.measured_velocities)
    shape: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)      # at the samples
    between: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)    # per piece of interval
    velocity: tuple | None = dataclasses.field(default=None, repr=False, compare=False)   # (at the samples, between)
    direction: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)
    between_direction: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)
    band: float = dataclasses.field(default=0.0, repr=False, compare=False)   # the direction's pre-sliding band (m)

    def variants(self, data):
        x = data.signals['position']
        band = BAND * position_noise(x)[0]
        terms = contact(x, band, data.sample_period)
        velocities = measured_velocities(data, terms['between'].shape[1])
        peak = peak_speed(velocities)
        return [dataclasses.replace(self, velocity_span=span, velocity=v, direction=terms['direction'],
                                    between_direction=terms['between'][..., 0], band=band).at(data, peak * f)
                for span, v in velocities.items() for f in GRID]

    def reread(self, data):
        terms = contact(data.signals['position'], self.band, data.sample_period)
        pieces = terms['between'].shape[1]
        velocity = measured_velocities(data, pieces, spans=(self.velocity_span,))[self.velocity_span]
        return dataclasses.replace(self, velocity=velocity, direction=terms['direction'],
                                   between_direction=terms['between'][..., 0]).at(data, self.stribeck_speed)

    def at(self, data, value):
        """The variant (of `variants`: its velocity and direction read) at v_s = `value`."""
        fade = np.exp(-(self.velocity[0] / float(value)) ** 2)
        between = self.between_direction * np.exp(-(self.velocity[1] / float(value)) ** 2)
        return dataclasses.replace(self, stribeck_speed=float(value), shape=self.direction * fade,
                                   between=between[..., None])

    def force(self, s):
        return self.shape[s.index][None]

    def force_between(self, data):
        return self.between


@register_effect
@dataclasses.dataclass(frozen=True)
class StribeckFriction(Effect):
    """The excess dF exp(-(v / v_s)^2) sign(v) of a dry friction over its Coulomb level; the part breaks away at
    the Coulomb level + dF. In the plant it raises the sticking level by dF and takes back
    dF (1 - exp(-(v / v_s)^2)) sign(v) while sliding (continuous at v = 0)."""

    name: ClassVar[str] = 'stribeck_friction'
    parameters: ClassVar[tuple] = PARAMETERS
    settings: ClassVar[tuple] = SETTINGS
    candidate: ClassVar[type] = _Candidate
    online_refusal: ClassVar[str] = 'its Stribeck speed is not a linear parameter (searched over whole records)'
    control_refusal: ClassVar[str] = 'the inverse law has one friction level, the Coulomb one'
    stribeck_force: float = 0.5
    stribeck_speed: float = 0.01

    def friction_level(self) -> float:
        return self.stribeck_force

    def extra_force(self, position: float, velocity: float) -> float:
        fade = -math.expm1(-(velocity / self.stribeck_speed) ** 2)
        return -self.stribeck_force * math.copysign(fade, velocity)
