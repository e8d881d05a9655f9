"""An effect's column in the grey-box regressions (emla_identification.online_effects).

The mechanical regression's output is the triangle-weighted mean acceleration over [t_k-1, t_k+1], so a force
p f(t) opposing +x enters as the column -(f_k-1 + 4 f_k + f_k+1) / 6 with coefficient p / m (docs/physics.md §6).

A stiffness (a spring's k x) is no held force: it is part of the motion's linear dynamics, and the regressions
are exact for it only with k in their transition matrix (docs/physics.md §3.8). Its column is then the position
itself, -x_k-1 in the electrical row and -x_k in the mechanical one, with the coefficient the exact relation
gives (emla_identification.physical); the force regression, on a measured force, keeps the triangle.
"""
import dataclasses
from typing import ClassVar

import numpy as np

TRIANGLE = np.array([0.0, 1.0, 4.0, 1.0, 0.0]) / 6.0   # weights of positions k-2 .. k+2 in the column


@dataclasses.dataclass(frozen=True)
class OnlineColumn:
    """The column of one effect parameter.

    `force(x, ts)` gives per row, from the positions x = (x_k-2, x_k-1, x_k, x_k+1, x_k+2) (five arrays), the
    force term f (opposing +x; the column is -f) and the rows to skip (or None); `stencils[signal]` is how
    white noise on that signal at samples k-2 .. k+2 enters the column (none: taken as exact)."""
    parameter: str
    force: object
    stencils: dict = dataclasses.field(default_factory=dict)

    stiffness: ClassVar[bool] = False

    def column(self, x, sample_period, kind):
        """(f, rows to skip or None) of regression `kind`."""
        return self.force(x, sample_period)

    def instrument(self, x, sample_period, kind):
        """f's instrument in an instrumented regression: f itself (its noise is taken as exact or enters
        outside the row's error)."""
        return self.column(x, sample_period, kind)[0]

    def stencil(self, signal: str, kind: str) -> np.ndarray:
        """How white noise on `signal` at samples k-2 .. k+2 enters the column of regression `kind`."""
        return np.asarray(self.stencils.get(signal, np.zeros(5)), dtype=float)


POSITION_SAMPLE = {'electrical': 1, 'mechanical': 2}   # the sample of x_k-2 .. x_k+2 a stiffness column holds


@dataclasses.dataclass(frozen=True)
class StiffnessColumn(OnlineColumn):
    """The column of a stiffness k: f = x_k-1 (electrical), x_k (mechanical), the triangle-weighted position
    (force); k enters the regressions' transition matrix (module doc)."""

    force: object = None
    stiffness: ClassVar[bool] = True

    def column(self, x, sample_period, kind):
        if kind in POSITION_SAMPLE:
            return x[POSITION_SAMPLE[kind]], None
        return TRIANGLE[1] * x[1] + TRIANGLE[2] * x[2] + TRIANGLE[3] * x[3], None

    def instrument(self, x, sample_period, kind):
        """x_k-2: the position's noise at k-1 .. k+1 is in the rows' errors (the displacement's, with a weight
        Km / L far above the column's coefficient; the second difference's, 2 / Ts^2 beside k / m times var x:
        as its own instrument x_k would bias k by 2 sigma_x^2 m / (Ts^2 k var x), 16 % for 1 um at 10 kHz on a
        50 um stroke), and in closed loop every later sample carries that noise fed back."""
        return x[0]

    def stencil(self, signal, kind):
        if signal != 'position':
            return np.zeros(5)
        return -np.eye(5)[POSITION_SAMPLE[kind]] if kind in POSITION_SAMPLE else -TRIANGLE
