"""An effect's column in the online identifier's mechanical regression (emla_identification.online_effects).

That regression's output is the triangle-weighted mean acceleration over [t_k-1, t_k+1], so a force p f(t)
opposing +x enters as the column -(f_k-1 + 4 f_k + f_k+1) / 6 with coefficient p / m (docs/physics.md §6).
"""
import dataclasses

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

    def stencil(self, signal: str) -> np.ndarray:
        """How white noise on `signal` at samples k-2 .. k+2 enters the column."""
        return np.asarray(self.stencils.get(signal, np.zeros(5)), dtype=float)
