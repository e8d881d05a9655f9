"""Coulomb friction: a dry friction force Fc against the motion, sticking below breakaway (docs/physics.md §6.2)."""
import dataclasses
from typing import ClassVar

import numpy as np

from ..candidate import Candidate, of_effect
from ..effect import Effect, Parameter, register_effect
from ..online import OnlineColumn

PARAMETERS = (Parameter('coulomb_force', 'N', 1.0, lower=0.0, doc='friction level Fc'),
              Parameter('presliding_damping', 'N s/m', 0.0, lower=0.0,
                        doc='sigma1, the damping of the stuck contact within its pre-sliding band (LuGre)'))
SLIDING_SPEED = 0.1  # m/s: online rows slower than this are skipped (see `_online_force`)


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
    signs: ClassVar[tuple] = (1, 1)
    presliding: float = 0.0   # m
    direction: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)
    rate: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)   # dz/dt
    stuck: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)

    def variants(self, data):
        x = data.signals['position']
        # white position noise has third differences of variance 20 sigma^2 (MAD for robustness)
        noise = max(1.4826 * np.median(np.abs(np.diff(x, 3))) / np.sqrt(20.0), 1e-6 * np.ptp(x))
        variants = []
        for delta in 3.0 * noise * np.array([1.0, 2.0, 4.0, 8.0]):
            play = _play(x, delta)
            play['rate'] = np.gradient(play['direction'] * delta, data.sample_period)
            # stuck parts either held still (rigid sticking) or pulled back elastically within the band
            variants += [dataclasses.replace(self, presliding=float(delta), **play),
                         dataclasses.replace(self, presliding=float(delta), direction=play['direction'],
                                             rate=play['rate'])]
        return variants

    def force(self, s):
        return np.stack((self.direction[s.index], self.rate[s.index]))

    def held(self, data):
        return self.stuck

    def settings(self):
        return {'presliding_displacement': self.presliding, 'rigid_sticking': self.stuck is not None}


def _play(x, width):
    """{'direction': (x - y) / width, 'stuck': y did not move into sample k} with y the play operator:
    y_k = clip(y_k-1, x_k - width, x_k + width). While the measured position stays within the band, the
    part is taken to stick."""
    y = np.empty_like(x)
    last = float(x[0])
    for k, xk in enumerate(x.tolist()):
        last = min(max(last, xk - width), xk + width)
        y[k] = last
    return {'direction': (x - y) / width, 'stuck': np.concatenate(([False], np.diff(y) == 0.0))}


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
    candidate: ClassVar[type] = _Candidate
    online: ClassVar[object] = OnlineColumn('coulomb_force', _online_force)
    coulomb_force: float = 1.0
    presliding_damping: float = 0.0   # the plant sticks rigidly: no pre-sliding motion for it to damp

    def friction_level(self) -> float:
        return self.coulomb_force

    def kernel_values(self) -> dict[str, float] | None:
        return {'coulomb_force': self.coulomb_force}

    def compensation(self) -> dict[str, float]:
        return {'coulomb_force': self.coulomb_force}
