"""Online grey-box identification from frames of consecutive samples (the identifier node, the closed loop).

The rows are those of regressors.py, computed per frame with the last HISTORY samples of the previous frame
in front (regressors.RowStream), so the stream yields exactly the rows of the whole record; each regression runs
its own RecursiveLeastSquares over them (with its instruments, if it has any). The physical parameters are
formed from the recursions' states by physical.physical, as greybox.identify forms them from the batch solution:
with forgetting 1 the final estimate equals greybox.identify on the same samples (to rounding). After lost
samples, gap() restarts the rows on the next frame, so that none spans the gap.

Effects (a list of names and/or a model file's Model): those linear in their parameters are estimated along
with the nominal ones, as extra columns of every regression (online_effects.py, which says which can and which
cannot); their parameters follow the nominal ones in estimate() and values().

An estimate that cannot be computed (an overflow of the squared sums, a non-finite or singular information
matrix: a frame of 1e50 among samples of order 1) raises an UnestimableError, from estimate(), full_estimate()
and values() alike (_fit, the way they all go); the frames since the last checkpoint() poisoned the statistics,
and restore() goes back to it (the identifier node does so at each estimate it publishes). An estimate of NaN
from statistics that are sound is no such failure: the data do not (or no longer) identify the model.
"""
from __future__ import annotations

import copy
import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from emla_core.errors import InputError

from .moments import RowMoments, UnestimableError
from .online_effects import EffectColumns, columns_for
from .physical import fit, reported
from .regressors import COLUMNS, INSTRUMENTED, SIGNALS, RowStream, regressions_for
from .rls import RecursiveLeastSquares, forgetting_factor

if TYPE_CHECKING:
    from emla_core.model_file import Model, ModelEffect


class OnlineIdentifier:
    """Grey-box RLS identification of `model` ('electrical', 'mechanical' or 'full') at `sample_period`.

    signals: the signals the frames carry, by default the coil signals (voltage, current, position); give
    ('force', 'position') for mechanical-only data. Memory: a forgetting factor or a memory time constant
    (s); neither means no forgetting. update() costs about 1.5 us per sample (full model, frames of 100);
    estimate() about 1-3 ms, so call it at the rate the uncertainties are used; values() gives the parameters
    alone, without the noise model (physical.fit with noise=False, started from the last parameters).
    effects: effect names and/or a Model (its effects), estimated online (online_effects.py); an InputError
    names those that cannot be.
    """

    def __init__(self, sample_period: float, model: str = 'full', *, forgetting: float | None = None,
                 memory_time: float | None = None, initial_covariance: float = 1e6,
                 signals: Iterable[str] = SIGNALS['electrical'],
                 effects: str | Iterable[str | ModelEffect] | Model = ()) -> None:
        if not 0.0 < sample_period < math.inf:
            raise ValueError(f'sample period must be positive and finite, got {sample_period!r}')
        self.sample_period = float(sample_period)
        self.model = model
        self.kinds = regressions_for(model, signals)
        self._stream = RowStream(self.kinds, self.sample_period)
        forgetting = 1.0 if forgetting is None else forgetting
        effect_entries = getattr(effects, 'effects', effects)   # a Model: its effects
        if isinstance(effect_entries, str):
            effect_entries = (effect_entries,)
        columns = columns_for(effect_entries, forgetting_factor(forgetting, memory_time, self.sample_period))
        self._effects = EffectColumns(columns, self.sample_period) if columns else None
        if columns and 'velocity' in SIGNALS[self.kinds[0]]:
            raise InputError('effects are estimated online from the position; this identifier has the velocity')
        self._rls = {kind: RecursiveLeastSquares(len(COLUMNS[kind]) + len(columns),
                                                 forgetting=forgetting, memory_time=memory_time,
                                                 sample_period=self.sample_period,
                                                 initial_covariance=initial_covariance)
                     for kind in self.kinds}
        self.reset()

    @property
    def effects(self) -> tuple[str, ...]:
        """The parameters of the effects estimated online (e.g. ('coulomb_force', 'spring_stiffness'))."""
        return () if self._effects is None else tuple(c.parameter for c in self._effects.columns)

    def reset(self) -> None:
        """Forget everything: back to the prior, no samples."""
        for rls in self._rls.values():
            rls.reset()
        self._moments = {kind: RowMoments(rls.n, rls.forgetting, kind in INSTRUMENTED,
                                          self._effects.columns if self._effects else ())
                         for kind, rls in self._rls.items()}
        self._last = None   # the last parameters formed: where the next fit starts
        self._stream.reset()
        if self._effects:
            self._effects.restart()
        self._residual_rms = math.nan
        self._checkpoint = None

    def checkpoint(self) -> None:
        """Keep the present state for restore() (about 0.1 ms: once per estimate, not per frame)."""
        self._checkpoint = copy.deepcopy(self._state())

    def restore(self) -> int:
        """Go back to the last checkpoint(), or without one reset(): the frames since are forgotten (the next one
        follows on from none of them: gap()). The checkpoint is used up (a second restore() without a new one
        resets). Returns the number of samples forgotten."""
        samples = self.samples
        if self._checkpoint is None:
            self.reset()
        else:
            (self._rls, self._moments, self._stream, self._effects, self._last,
             self._residual_rms) = self._checkpoint
            self._checkpoint = None
            self.gap()
        return samples - self.samples

    def _state(self):
        return self._rls, self._moments, self._stream, self._effects, self._last, self._residual_rms

    def gap(self) -> None:
        """Samples were lost: the next frame does not follow on from the last one, and no row will span the
        gap. The estimates and their statistics are kept (the noise model's lagged moments pair the few rows
        either side as neighbours: negligible among thousands)."""
        self._stream.restart()
        if self._effects:
            self._effects.restart()

    def update(self, voltage: ArrayLike | None = None, current: ArrayLike | None = None,
               position: ArrayLike | None = None, *, force: ArrayLike | None = None,
               velocity: ArrayLike | None = None) -> None:
        """Feed one frame (1-D arrays of equal length of the identifier's signals); see gap() when it does not
        follow on from the last one."""
        given = {'voltage': voltage, 'current': current, 'position': position, 'force': force, 'velocity': velocity}
        if any(given[name] is None for name in self._stream.signals):
            raise ValueError(f'the {self.model} identifier needs {", ".join(self._stream.signals)} in each frame')
        with np.errstate(over='ignore', invalid='ignore'):  # an overflow: found by the estimate (_fit)
            self._update(given)

    def _update(self, given):
        effects, stuck = self._effects.rows(given['position'], self.kinds) if self._effects else (None, None)
        for kind, (phi, y, zeta) in self._stream.rows(given).items():
            if effects is not None:
                columns, instruments = effects[kind]
                phi, y = np.hstack((phi, columns)), y if stuck is None else np.where(stuck, np.nan, y)
                zeta = None if zeta is None else np.hstack((zeta, instruments))
            rls = self._rls[kind]
            errors = rls.update_block(phi, y, zeta)
            z = np.column_stack((phi, y))
            skipped = ~np.isfinite(errors)  # by the recursion: no contribution, lags kept aligned
            z[skipped] = 0.0
            self._moments[kind].update(z, None if zeta is None else np.where(skipped[:, None], 0.0, zeta))
            errors = errors[np.isfinite(errors)]  # the recursion skips non-finite samples
            if kind.startswith('electrical') and len(errors):
                # a-priori current error over the voltage's coefficient (beta) = voltage-equation error (V)
                with np.errstate(all='ignore'):  # NaN before beta is identified
                    self._residual_rms = float(np.sqrt(errors @ errors / len(errors))
                                               / rls.theta[COLUMNS[kind].index('voltage')])

    @property
    def samples(self) -> int:
        """Samples fed since the last reset."""
        return self._stream.samples

    @property
    def residual_rms(self) -> float:
        """RMS a-priori error of the voltage equation over the last frame (V); NaN without coil signals."""
        return self._residual_rms

    def estimate(self) -> tuple[dict[str, float], dict[str, float]]:
        """({name: value}, {name: one-sigma}) of the model's parameters; NaN before enough excitation."""
        values, std, _ = self.full_estimate()
        return values, std

    def full_estimate(self) -> tuple[dict[str, float], dict[str, float], tuple[Sequence[str], np.ndarray]]:
        """estimate() and (names, covariance matrix) of the parameters, from one evaluation of the noise model."""
        names, values, covariance = reported(self.model, *self._fit(noise=True))
        return (dict(zip(names, values.tolist())), dict(zip(names, np.sqrt(np.diag(covariance)).tolist())),
                (names, covariance))

    def values(self) -> dict[str, float]:
        """{name: value} as estimate() gives them, without the uncertainties' noise model (for per-frame use)."""
        names, values, _ = reported(self.model, *self._fit(noise=False))
        return dict(zip(names, values.tolist()))

    def _fit(self, noise):
        """(statistics, q, covariance of q), the fit started from the last finite q; an UnestimableError where the
        statistics cannot give one (moments.Statistics.check, .information; any other numerical failure of the
        fit: an overflow, a singular matrix)."""
        statistics = self._statistics()
        try:
            for stats in statistics.values():
                stats.check()
            q, covariance = fit(statistics, self.sample_period, noise, self._last)
        except UnestimableError:
            raise
        except (ValueError, ArithmeticError) as error:  # LinAlgError is a ValueError
            raise UnestimableError(f'the fit failed: {error or type(error).__name__}') from None
        if np.all(np.isfinite(q)):
            self._last = q
        return statistics, q, covariance

    def _statistics(self):
        return {kind: self._moments[kind].statistics(rls.theta, rls.covariance) for kind, rls in self._rls.items()}
