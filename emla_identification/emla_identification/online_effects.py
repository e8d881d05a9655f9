"""Effects the online identifier estimates along with the nominal parameters: those of the physics layer with an
online column (emla_core.physics, `Effect.online`), as extra columns of every regression of regressors.py;
each column's form, and the reason an effect cannot run online, are in the effect's own file.

A column is -f, f the effect's force per unit parameter about sample k (opposing +x); it enters each regression
as a load force does, with coefficient -(the regression's gain of a unit load force) p (physical.py; p / m in
the force regression). A stiffness (the spring) enters the regressions' transition instead, exactly
(emla_core.physics.online.StiffnessColumn). An effect followed by the forgetting instead
(`online_by_forgetting`: the resistance drift) needs a forgetting factor below 1. Columns need the position:
a velocity recording runs without them. The same columns serve the offline identification (regression_rows).

Uncertainties: the sensor-noise model (noise.py) carries noise into a column through its stencils; the
friction's direction is taken as exact (its skipped rows keep noise from flipping it). The spring's column is
instrumented by x_k-2 (StiffnessColumn.instrument says why).
"""
import numpy as np

from emla_core.errors import InputError
from emla_core.physics import EFFECTS

from .regressors import HISTORY, LEAD, instruments, rows


def online_effects():
    """Names of the effects that run online (a column, or followed by the forgetting)."""
    return [name for name, e in EFFECTS.items() if e.online is not None or e.online_by_forgetting]


def spring_options(kinds, spring):
    """The extra columns greybox.identify tries, as its `spring` asks: none, the return spring's, or both (the
    nominal first). The spring's exact rows are those from position: with the coil's equation only."""
    sprung = (EFFECTS['return_spring'].online,)
    if spring is False or 'electrical' not in kinds:
        return [()]
    return [sprung] if spring else [(), sprung]


def columns_for(effects, forgetting):
    """The extra OnlineColumns of `effects` (names and/or ModelEffects of a model file), in the given order. An
    InputError names any effect that cannot run online, and why; one followed by the forgetting needs
    `forgetting` < 1."""
    out, refused = {}, []
    for effect in effects:
        name = getattr(effect, 'candidate', effect)
        spec = EFFECTS.get(name)
        if spec is None:
            refused.append(f'{name} (unknown; online: {", ".join(online_effects())})')
        elif spec.online is not None:
            out[name] = spec.online
        elif spec.online_by_forgetting:
            if forgetting == 1.0:
                raise InputError(f'{name} is followed online by forgetting: give a memory time or a forgetting '
                                 f'factor below 1')
        else:
            refused.append(f'{name} ({spec.online_refusal})')
    if refused:
        raise InputError(f'cannot estimate online: {"; ".join(refused)}')
    return tuple(out.values())


class EffectColumns:
    """The extra columns of the regressions frame by frame, aligned with regressors.RowStream's rows
    (each frame with the last HISTORY samples of the previous one in front)."""

    def __init__(self, columns, sample_period):
        self.columns = tuple(columns)
        self.sample_period = float(sample_period)
        self.restart()

    def restart(self):
        """As RowStream.restart: the next frame does not follow on from the last one."""
        self._tail = np.empty(0)

    def rows(self, position, kinds):
        """({kind: (columns, their instruments)}, rows to skip or None) of the rows the new frame's positions
        complete."""
        x = np.concatenate((self._tail, np.asarray(position, dtype=float).reshape(-1)))
        self._tail = x[-HISTORY:]
        n = max(len(x) - HISTORY, 0)   # the rows the frame completes (none in a segment shorter than a row)
        lagged = [x[j:j + n] for j in range(LEAD - 2, LEAD + 3)]   # positions k-2 .. k+2
        out, skipped = {}, None
        for kind in kinds:
            columns, instruments = (np.empty((len(lagged[0]), len(self.columns))) for _ in range(2))
            for j, column in enumerate(self.columns):
                force, skip = column.column(lagged, self.sample_period, kind)
                columns[:, j] = -force
                instruments[:, j] = -column.instrument(lagged, self.sample_period, kind)
                if skip is not None:
                    skipped = skip if skipped is None else skipped | skip
            out[kind] = columns, instruments
        return out, skipped


def regression_rows(signals, kinds, sample_period, columns=()):
    """{kind: (Phi, Y, instruments or None)} of a whole record's rows (regressors.rows), with the effects'
    `columns` (OnlineColumns) beside each regression's own; rows an effect skips are zero (they contribute
    nothing)."""
    made = {kind: (*rows(kind, signals, sample_period), instruments(kind, signals, sample_period)) for kind in kinds}
    if not columns:
        return made
    return with_columns(made, *EffectColumns(columns, sample_period).rows(signals['position'], kinds))


def with_columns(made, extra, skipped):
    """{kind: (Phi, Y, instruments or None)} of rows `made` with the effects' columns and their instruments
    `extra` beside each regression's own, and the rows `skipped` (or None) zero (they contribute nothing):
    EffectColumns.rows gives (extra, skipped) for the same rows."""
    out = {}
    for kind, (phi, y, zeta) in made.items():
        phi = np.hstack((phi, extra[kind][0]))
        zeta = None if zeta is None else np.hstack((zeta, extra[kind][1]))
        if skipped is not None:
            phi[skipped], y = 0.0, np.where(skipped, 0.0, y)
            if zeta is not None:
                zeta[skipped] = 0.0
        out[kind] = phi, y, zeta
    return out
