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
SPANS = (5, 2, 0)   # samples each side of the local cubic v is read from (measured_velocities); the first: a default
PIECES = 8          # parts of each interval the term is given on between the samples


def measured_velocities(data, pieces=PIECES, spans=SPANS):
    """{span: (v at the samples, v at the middle of each of `pieces` equal parts of every interval)} for each span
    of SPANS: the slope of a local cubic through the measured position over +-span samples (Savitzky-Golay), linear
    between the samples; for span 0 the slope of the cubic spline through the samples, at and between them.

    The friction candidates try each (variants; Candidate.reading: the fit that leaves least is kept). A wide cubic
    averages the quantiser's noise, which the five-point difference of data.velocity() carries tenfold (1 um at
    10 kHz: 3 mm/s rms) and which would smear a friction that turns over a few mm/s; but where the logger is slow
    it smears the strokes' jerk: +-5 samples at 2-3 kHz left the force balance of a tanh over 8 mm/s at 25-64 times
    its floor, the spline 1.5-2. At 20 kHz the spline is the one that carries too much noise (3.5 times)."""
    from scipy.interpolate import CubicSpline  # here: the nodes that load the physics need no scipy
    from scipy.signal import savgol_filter
    x, ts = data.signals['position'], data.sample_period
    out = {}
    for span in spans:
        if span == 0:
            spline = CubicSpline(np.arange(len(x)), x)
            middles = np.arange(len(x) - 1)[:, None] + (np.arange(pieces) + 0.5) / pieces
            out[span] = (spline(np.arange(len(x)), 1) / ts, spline(middles, 1) / ts)
        else:
            v = savgol_filter(x, min(2 * span + 1, len(x) // 2 * 2 - 1), 3, deriv=1, delta=ts)
            out[span] = (v, at_pieces(v, pieces))
    return out


def at_pieces(values, pieces):
    """(intervals, pieces): `values` given at the samples, linear over each interval, at the middle of each of its
    `pieces` equal parts."""
    share = (np.arange(pieces) + 0.5) / pieces
    return (1.0 - share) * values[:-1, None] + share * values[1:, None]


def peak_speed(velocities):
    """The record's peak speed the candidates' grids of v_s are relative to (on the widest cubic's velocity: one
    grid for every span, so a refinement's neighbours are its own span's)."""
    return max(float(np.max(np.abs(velocities[SPANS[0]][0]))), np.finfo(float).tiny)


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """Fc tanh(v / v_s) as a force term, v the measured velocity (measured_velocities: each span a variant), in
    simulation too; v_s searched over 1e-4 .. 0.1 times the record's peak speed, then refined. Between the samples
    (force_between) v follows the span's velocity over each interval: a friction steep in v turns within the
    interval where v crosses zero."""

    name: ClassVar[str] = 'smooth_friction'
    parameters, units = of_effect(PARAMETERS)
    acts_on: ClassVar[tuple] = ('mechanical', 'force')
    reads: ClassVar[tuple] = ('position',)
    signs: ClassVar[tuple] = (1,)
    reading: ClassVar[str] = 'velocity_span'
    scale: ClassVar[str] = 'smoothing_speed'
    smoothing_speed: float = 0.0   # m/s
    velocity_span: int = SPANS[0]  # samples (measured_velocities)
    shape: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)
    between: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)
    velocity: tuple | None = dataclasses.field(default=None, repr=False, compare=False)   # (at the samples, between)

    def variants(self, data):
        velocities = measured_velocities(data)
        peak = peak_speed(velocities)
        return [dataclasses.replace(self, velocity_span=span, velocity=v).at(data, peak * f)
                for span, v in velocities.items() for f in GRID]

    def at(self, data, value):
        """The variant (of `variants`: its velocity read) at v_s = `value`."""
        return dataclasses.replace(self, smoothing_speed=float(value), shape=np.tanh(self.velocity[0] / float(value)),
                                   between=np.tanh(self.velocity[1] / float(value))[..., None])

    def reread(self, data):
        velocity = measured_velocities(data, spans=(self.velocity_span,))[self.velocity_span]
        return dataclasses.replace(self, velocity=velocity).at(data, self.smoothing_speed)

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
