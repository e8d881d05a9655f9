"""Effects the online identifier estimates along with the nominal parameters: those linear in their
parameters, as extra columns of the mechanical (or force) regression of regressors.py.

That regression's output is the triangle-weighted mean acceleration over [t_k-1, t_k+1], so a force p f(t)
opposing +x enters as the column -(f_k-1 + 4 f_k + f_k+1) / 6 with coefficient p / m, as the discrepancy
workflow's force terms do (discrepancy/fit.py); p is formed from it as the load force is (physical.py).
The effects are the discrepancy candidates of the same names (discrepancy/candidates.py, the model file's):

  coulomb_friction  Fc sign(v), v the motion over [t_k-2, t_k+2] (x_k+2 - x_k-2, samples outside the second
                    difference: its noise does not enter the column). The discrepancy candidate's play-operator
                    direction reads x_k-1 .. x_k+1, whose quantisation the output holds too: online that left Fc
                    8 % low. Rows slower than SLIDING_SPEED are skipped: there the part sticks, reverses or
                    creeps, and the friction is whatever balances the other forces, not Fc sign(v) (under a
                    dithered PID loop that hunts at rest, a threshold of 0.05 m/s left Fc twice too large).
  return_spring     k x: the spring's centre xc adds the constant -k xc, which merges with the load force,
                    so load_force is reported as Fl - k xc (the total at x = 0) and the spring's centre as 0.
  resistance_drift  no column: R(t) is followed by the forgetting (memory_time or forgetting < 1), which
                    therefore is required.

Uncertainties: the sensor-noise model (noise.py) carries position noise into the spring column exactly;
the friction's direction is taken as exact (the skipped rows keep noise from flipping it). The triangle
weights leave the spring column's noise correlated with the second difference's, a bias of
sigma_x^2 / (Ts^2 var x) in k / m: 1e-4 relative for 1 um quantisation on a 4 mm stroke.

The other candidates cannot run online (REFUSED): their nonlinear settings (a delay, a time constant, a
saturation current) are searched over whole records, or their terms enter the electrical regression, whose
exact-discretisation form has no place for them.
"""
import dataclasses

import numpy as np

from emla_core.errors import InputError

from .regressors import HISTORY

SLIDING_SPEED = 0.1  # m/s: slower rows are skipped (see the module doc)

REFUSED = {
    'inductance_saturation': 'its saturation current is not a linear parameter, and an inductance term has no '
                             'place in the electrical regression\'s exact discretisation',
    'sensor_delay': 'a delay re-aligns the signals; it is not a linear parameter',
    'force_constant_variation': 'it multiplies the coil current in both equations; the electrical regression\'s '
                                'exact discretisation has no place for it',
    'drive_voltage_error': 'its current scale is not a linear parameter (searched over whole records)',
}


@dataclasses.dataclass(frozen=True)
class Column:
    """An effect's column: `force(x, ts)` gives per row (x: positions k-2 .. k+2 as five arrays) the force term
    f (opposing +x, the column is -f) and the rows to skip (or None); `stencil(signal)` how white noise on
    that signal at samples k-2 .. k+2 enters the column."""
    effect: str
    parameter: str

    def stencil(self, signal):
        if self.effect == 'return_spring' and signal == 'position':
            return -np.array([0.0, 1.0, 4.0, 1.0, 0.0]) / 6.0
        return np.zeros(HISTORY + 1)  # the friction's direction: taken as exact

    def force(self, x, sample_period):
        xm2, xm1, x0, xp1, xp2 = x
        if self.effect == 'return_spring':
            return (xm1 + 4.0 * x0 + xp1) / 6.0, None
        motion = xp2 - xm2
        return np.sign(motion), np.abs(motion) < SLIDING_SPEED * 4.0 * sample_period


COLUMNS = {'coulomb_friction': Column('coulomb_friction', 'coulomb_force'),
           'return_spring': Column('return_spring', 'spring_stiffness')}


def columns_for(effects, forgetting):
    """The extra Columns of `effects` (names and/or ModelEffects of a model file), in the given order. An
    InputError names any effect that cannot run online, and why; resistance_drift needs `forgetting` < 1."""
    out, refused = {}, []
    for effect in effects:
        name = getattr(effect, 'candidate', effect)
        if name in COLUMNS:
            out[name] = COLUMNS[name]
        elif name == 'resistance_drift':
            if forgetting == 1.0:
                raise InputError('resistance_drift is followed online by forgetting: give a memory time or a '
                                 'forgetting factor below 1')
        elif name in REFUSED:
            refused.append(f'{name} ({REFUSED[name]})')
        else:
            refused.append(f'{name} (unknown; online: coulomb_friction, return_spring, resistance_drift)')
    if refused:
        raise InputError(f'cannot estimate online: {"; ".join(refused)}')
    return tuple(out.values())


class EffectColumns:
    """The extra columns of the mechanical regression frame by frame, aligned with regressors.RowStream's rows
    (each frame with the last HISTORY samples of the previous one in front)."""

    def __init__(self, columns, sample_period):
        self.columns = tuple(columns)
        self.sample_period = float(sample_period)
        self.restart()

    def restart(self):
        """As RowStream.restart: the next frame does not follow on from the last one."""
        self._tail = np.empty(0)

    def rows(self, position):
        """(columns, rows to skip or None) of the rows the new frame's positions complete."""
        x = np.concatenate((self._tail, np.asarray(position, dtype=float).reshape(-1)))
        self._tail = x[-HISTORY:]
        lagged = [x[j:len(x) - HISTORY + j] for j in range(HISTORY + 1)]
        columns, skipped = np.empty((len(lagged[0]), len(self.columns))), None
        for j, column in enumerate(self.columns):
            force, skip = column.force(lagged, self.sample_period)
            columns[:, j] = -force
            if skip is not None:
                skipped = skip if skipped is None else skipped | skip
        return columns, skipped
