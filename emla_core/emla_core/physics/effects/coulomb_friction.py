"""Coulomb friction: a dry friction force Fc against the motion, sticking below breakaway (docs/physics.md §6.2)."""
import dataclasses
from typing import ClassVar

import numba
import numpy as np

from ..candidate import Candidate, of_effect
from ..effect import Effect, Parameter, register_effect
from ..online import OnlineColumn

PARAMETERS = (Parameter('coulomb_force', 'N', 1.0, lower=0.0, doc='friction level Fc'),
              Parameter('presliding_damping', 'N s/m', 0.0, lower=0.0,
                        doc='sigma1, the damping of the stuck contact within its pre-sliding band (LuGre)'))
SETTINGS = (Parameter('presliding_displacement', 'm', 0.0, lower=0.0,
                      doc='delta, the pre-sliding band of an elastic stuck contact (0: the part sticks rigidly)'),)
SLIDING_SPEED = 0.1  # m/s: online rows slower than this are skipped (see `_online_force`)
PIECES = 8           # parts of each sample interval over which the candidate follows the contact (`contact`)


@dataclasses.dataclass(frozen=True)
class _Candidate(Candidate):
    """Fc d(t) + sigma1 dz/dt: dry friction whose direction d follows the measured motion with a pre-sliding
    band, and the damping of its stuck contact.

    d = z / delta, z = x - y, y the play (backlash) operator of width delta on the measured position: d is
    +-1 while sliding. Where the measured position stays within the band the part sticks, in one of two
    ways searched as variants: rigidly (static friction balances whatever else acts, so the force balance
    says only that it does not accelerate: `held`), or elastically (the friction Fc d pulls it back within
    the band: the elasto-plastic limit of the Dahl model, a pre-sliding stiffness Fc / delta). Within the band
    the contact also damps the motion, sigma1 dz/dt (LuGre's micro-damping; z is still while sliding, so
    this term lives at the reversals and the hunting at rest, where it can far exceed Fc: a contact
    critically damped over 2 um has sigma1 = 2 sqrt(m Fc / delta), 150 N s/m for 0.1 kg and 0.1 N). delta is
    searched on a grid from a few times the position noise; the friction therefore reads the measured
    motion, in simulation too.
    """

    name: ClassVar[str] = 'coulomb_friction'
    parameters, units = of_effect(PARAMETERS)
    acts_on: ClassVar[tuple] = ('mechanical', 'force')
    reads: ClassVar[tuple] = ('position',)
    signs: ClassVar[tuple] = (1, 1)
    scale: ClassVar[str] = 'presliding'
    presliding: float = 0.0   # m
    direction: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)   # at the samples
    rate: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)        # dz/dt at the samples
    between: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)     # (d, dz/dt) per piece
    stuck: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)

    def variants(self, data):
        x = data.signals['position']
        variants = []
        for delta in band_widths(x):   # then refined between the best's neighbours (Candidate.scale)
            terms = contact(x, delta, data.sample_period)
            # stuck parts either held still (rigid sticking) or pulled back elastically within the band
            variants += [dataclasses.replace(self, presliding=float(delta), **terms),
                         dataclasses.replace(self, presliding=float(delta), **dict(terms, stuck=None))]
        return variants

    def at(self, data, value):
        terms = contact(data.signals['position'], float(value), data.sample_period)
        if self.stuck is None:
            terms['stuck'] = None
        return dataclasses.replace(self, presliding=float(value), **terms)

    def reread(self, data):
        return self.at(data, self.presliding)

    def force(self, s):
        return np.stack((self.direction[s.index], self.rate[s.index]))

    def force_between(self, data):
        return self.between

    def held(self, data):
        return self.stuck

    def settings(self):
        return {'presliding_displacement': self.presliding, 'rigid_sticking': self.stuck is not None}


def band_widths(x, most=12):
    """The pre-sliding bands delta tried on the measured positions x: 3 sigma times 1, 2, 4, ... up to 8 times
    3 sigma' (position_noise), at most `most` of them."""
    noise, upper = position_noise(x)
    count = min(most, int(np.floor(np.log2(8.0 * upper / noise) + 1e-9)) + 1)
    return 3.0 * noise * 2.0 ** np.arange(count)


def position_noise(x):
    """(sigma, sigma'): the measured position's noise, and an upper bound of it (m).

    sigma' is the MAD of the third differences (white noise: variance 20 sigma^2), which is the noise at fast
    sampling but the motion's own third difference when the logger is slow (a loop hunting at 2 kHz: 60 um for
    a 1 um quantiser); sigma is a quantiser's step / sqrt(12) where the positions lie on a grid, else sigma'."""
    steps = np.diff(np.unique(x))
    step = steps.min() if steps.size else 0.0
    on_grid = step > 1e-9 * np.ptp(x) and np.all(np.abs(steps / step - np.round(steps / step)) < 1e-3)
    quantiser = step / np.sqrt(12.0) if on_grid else 0.0
    # (a part held still most of the time leaves third differences of 0: the quantiser's noise is the floor)
    upper = max(1.4826 * np.median(np.abs(np.diff(x, 3))) / np.sqrt(20.0), 1e-6 * np.ptp(x), quantiser)
    return (quantiser if on_grid else upper), upper


def contact(x, width, sample_period, pieces=PIECES):
    """{'direction', 'rate', 'between', 'stuck'} of the dry contact on the measured positions x: z = x - y, y the
    play operator of `width`, d = z / width, followed along the cubic spline through the samples at `pieces`
    points per interval. direction, rate: d and dz/dt at the samples; between: (intervals, pieces, 2), the means of
    d and dz/dt over each piece (Candidate.force_between: a reversal within an interval, every few samples in a
    loop hunting at a 2 kHz logger, enters the rows at its time); stuck: y did not move over the interval before
    the sample (the band held the part)."""
    from scipy.interpolate import CubicSpline  # here: the nodes that load the physics need no scipy
    n = len(x)
    fine = CubicSpline(np.arange(n), x)(np.arange((n - 1) * pieces + 1) / pieces)
    y = _play(fine, float(width))
    z = fine - y
    parts = (n - 1, pieces)
    direction = 0.5 * (z[:-1] + z[1:]).reshape(parts) / width   # the trapezoid over each piece
    rate = np.diff(z).reshape(parts) * (pieces / sample_period)
    moved = np.concatenate(([True], np.any(np.diff(y).reshape(parts) != 0.0, axis=1)))
    return {'direction': z[::pieces] / width, 'rate': np.gradient(z[::pieces], sample_period),
            'between': np.stack((direction, rate), axis=-1), 'stuck': ~moved}


@numba.njit(cache=True)
def _play(x, width):
    """y, the play operator on x: y_k = clip(y_k-1, x_k - width, x_k + width) (y_0 = x_0)."""
    y = np.empty_like(x)
    last = x[0]
    for k in range(x.size):
        last = min(max(last, x[k] - width), x[k] + width)
        y[k] = last
    return y


def _online_force(x, sample_period):
    """sign(v) with v the motion over [t_k-2, t_k+2] (samples outside the second difference: their noise does not
    enter the column); rows slower than SLIDING_SPEED are skipped: there the part sticks, reverses or creeps,
    and the friction is whatever balances the other forces, not Fc sign(v)."""
    motion = x[4] - x[0]
    return np.sign(motion), np.abs(motion) < SLIDING_SPEED * 4.0 * sample_period


@register_effect
@dataclasses.dataclass(frozen=True)
class CoulombFriction(Effect):
    """Dry friction Fc sign(v), sticking below breakaway (equations.friction_force); 1 N is ~1.5 % of the
    Table 1 actuator's peak force."""

    name: ClassVar[str] = 'coulomb_friction'
    parameters: ClassVar[tuple] = PARAMETERS
    settings: ClassVar[tuple] = SETTINGS
    candidate: ClassVar[type] = _Candidate
    online: ClassVar[object] = OnlineColumn('coulomb_force', _online_force)
    coulomb_force: float = 1.0
    presliding_damping: float = 0.0        # damps the elastic contact's pre-sliding motion
    presliding_displacement: float = 0.0   # 0: the part sticks rigidly (equations.friction_force)

    @classmethod
    def from_model(cls, values, settings):
        """The friction of a model file's entry: its contact elastic within the pre-sliding band where the entry
        says it does not stick rigidly (`rigid_sticking: false`); rigid otherwise (a file without the key too)."""
        if settings.get('rigid_sticking', True):
            settings = {k: v for k, v in settings.items() if k != 'presliding_displacement'}
        return super().from_model(values, settings)

    def friction_level(self) -> float:
        return self.coulomb_force

    def kernel_values(self) -> dict[str, float] | None:
        return {'coulomb_force': self.coulomb_force}

    def compensation(self) -> dict[str, float]:
        return {'coulomb_force': self.coulomb_force}
