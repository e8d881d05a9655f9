"""A solenoid's coil resistance followed online from its voltage balance, its inductance curve known
(docs/physics.md §9.3): what an adaptive valve controller needs while the coil warms.

Over the sample interval [t_k, t_k+1], with the voltage u_k held, the flux linkage psi = L(x) I gains exactly

    psi_k+1 - psi_k = u_k Ts - R * integral of I dt,

so y_k = u_k - (psi_k+1 - psi_k) / Ts = R phi_k with phi_k the interval's mean current, taken by the trapezoid
(I_k + I_k+1) / 2 (its error, Ts^2 I'' / 12, changes sign with the current's curvature and averages out over a
memory: within 0.006 % of R on the independent generator at 5 kHz, docs/physics.md §9.3). psi comes from the
measured current and position
through L(x) = L0 + a / (g0 - x) of an identification (emla_identification.solenoid) or a model. The recursion is
emla_identification.rls with forgetting: R follows a drift with a lag of about the memory time.

Noise: the current's noise enters y through the flux difference (L / Ts times it: about 0.6 V at 5 mA, 10 kHz)
and phi through the mean; their correlation biases R by -L sigma_I^2 / (2 Ts R mean(I^2)), 1e-4 of R for the
valve of issue 24. Over a 30 ms memory the estimate scatters by about 0.5 % of R.
"""
import numpy as np
from numpy.typing import ArrayLike

from emla_core.physics.solenoid import SolenoidParameters

from .rls import RecursiveLeastSquares


class ResistanceEstimate:
    """What a solenoid's identifier node publishes on /emla/effects of an estimator with `resistance` and `std`
    (ohm): ResistanceTracker, solenoid_observer.PositionObserver."""

    @property
    def resistance(self) -> float:
        """The estimate of R (ohm): each subclass's."""
        raise NotImplementedError

    @property
    def std(self) -> float:
        """Its one-sigma (ohm): each subclass's."""
        raise NotImplementedError

    @property
    def effects(self) -> tuple[str, ...]:
        """The names it publishes."""
        return ('resistance',)

    def full_estimate(self) -> tuple[dict, dict, tuple]:
        """({'resistance': R}, {'resistance': one-sigma}, (names, covariance)), as OnlineIdentifier.full_estimate."""
        return ({'resistance': self.resistance}, {'resistance': self.std},
                (('resistance',), np.array([[self.std ** 2]])))

    def problems(self) -> list[str]:
        """What the node's status warns of (nothing: R alone has no fit check)."""
        return []


class ResistanceTracker(ResistanceEstimate):
    """R of a solenoid from frames of its voltage, current and position (SI units).

    Parameters
    ----------
    params : SolenoidParameters
        The inductance curve (leakage_inductance, gap_coefficient, gap) and the initial resistance.
    sample_period : float
        Ts (s).
    memory_time : float
        The forgetting's time constant (s): lambda = 1 - Ts / memory_time.

    Examples
    --------
    >>> from emla_core.physics.solenoid import SolenoidParameters
    >>> tracker = ResistanceTracker(SolenoidParameters(), 1e-4, memory_time=0.03)
    >>> tracker.update(voltage, current, position)     # doctest: +SKIP
    >>> tracker.resistance, tracker.std                 # doctest: +SKIP
    """

    def __init__(self, params: SolenoidParameters, sample_period: float, *, memory_time: float = 0.03) -> None:
        self.params = params
        self.sample_period = float(sample_period)
        self._rls = RecursiveLeastSquares(1, memory_time=memory_time, sample_period=self.sample_period,
                                          initial_covariance=1e6, initial_theta=[params.resistance])
        # (voltage, current, flux linkage) of the previous frame's last sample
        self._last: tuple[float, float, float] | None = None

    @property
    def samples(self) -> int:
        """Rows used so far (one per sample interval)."""
        return self._rls.samples

    @property
    def resistance(self) -> float:
        """The estimate of R (ohm)."""
        return float(self._rls.theta[0])

    @property
    def std(self) -> float:
        """Its one-sigma (ohm; NaN before two rows)."""
        return float(self._rls.parameter_std()[0]) if self._rls.samples > 1 else float('nan')

    def update(self, voltage: ArrayLike, current: ArrayLike, position: ArrayLike) -> float:
        """Take a frame of consecutive samples (the voltage held from each sample to the next); the estimate."""
        u, i, x = (np.asarray(v, dtype=float).reshape(-1) for v in (voltage, current, position))
        psi = self.params.inductance(x) * i
        if self._last is not None:   # the interval from the last frame's last sample to this frame's first
            u, i, psi = (np.concatenate(([last], now)) for last, now in zip(self._last, (u, i, psi)))
        if len(i) > 1:
            mean = 0.5 * (i[:-1] + i[1:])
            self._rls.update_block(mean[:, None], u[:-1] - np.diff(psi) / self.sample_period)
        self._last = (u[-1], i[-1], psi[-1])
        return self.resistance

    def restart(self) -> None:
        """The next frame does not follow on from the last one (samples were lost): no row spans the gap."""
        self._last = None

    gap = restart   # the name the identifier node gives it (OnlineIdentifier.gap)


class WindowedSolenoid:
    """The whole solenoid model online (docs/physics.md §9.1): the offline identification (identify_solenoid) of
    the latest `window` s of samples, refitted each time `refit_period` s of new samples have come (a moving
    horizon; R, L0, a, g0, m, B, k, F0 with their one-sigmas and the fit check of each equation).

    A fit that fails (a window in which the armature does not move between its stops, say) keeps the previous
    estimate; `failure` says why. A gap in the samples (`gap`) empties the window: the identification needs
    consecutive samples.

    Parameters
    ----------
    sample_period : float
        Ts (s).
    window : float
        The samples each fit takes, the latest ones (s).
    refit_period : float
        New samples between fits (s).

    Examples
    --------
    >>> model = WindowedSolenoid(2e-4, window=2.0, refit_period=0.5)
    >>> model.update(voltage, current, position)      # doctest: +SKIP
    >>> model.result.parameters['gap'], model.result.warnings()   # doctest: +SKIP
    """

    def __init__(self, sample_period: float, *, window: float = 2.0, refit_period: float = 0.5) -> None:
        if not (sample_period > 0 and window > 0 and refit_period > 0):
            raise ValueError('sample_period, window and refit_period must be positive')
        self.sample_period = float(sample_period)
        self._size = max(1, round(window / sample_period))
        self._every = max(1, round(refit_period / sample_period))
        self._frames: list[np.ndarray] = []   # (3, n) arrays of the samples since the window's start, kept until a fit
        self._new = 0               # samples since the last fit
        self.result = None          # the latest SolenoidResult
        self.failure = None         # why the latest fit failed (None: it did not)

    @property
    def effects(self) -> tuple[str, ...]:
        """The names it publishes (SOLENOID_PARAMETER_NAMES)."""
        from emla_core.physics.solenoid import SOLENOID_PARAMETER_NAMES
        return SOLENOID_PARAMETER_NAMES

    @property
    def samples(self) -> int:
        """The samples of the latest fit (0 before the first)."""
        return self.result.samples if self.result is not None else 0

    def update(self, voltage: ArrayLike, current: ArrayLike, position: ArrayLike) -> None:
        """Take a frame of consecutive samples (the voltage held from each sample to the next); refit when due."""
        frame = np.vstack([np.asarray(v, dtype=float).reshape(-1) for v in (voltage, current, position)])
        self._frames.append(frame)
        self._new += frame.shape[1]
        if self._new >= self._every:
            self._new = 0
            self._refit()

    def _refit(self):
        from emla_core.errors import InputError

        from .solenoid import identify_solenoid
        window = np.hstack(self._frames)[:, -self._size:]   # joined only here: frames may be single samples
        self._frames = [window]
        u, i, x = window
        try:
            self.result = identify_solenoid(sample_period=self.sample_period, voltage=u, current=i, position=x)
            self.failure = None
        except InputError as exc:
            self.failure = str(exc)

    def gap(self) -> None:
        """The next frame does not follow on from the last one: the window starts again."""
        self._frames, self._new = [], 0

    def full_estimate(self) -> tuple[dict, dict, tuple]:
        """(values, one-sigmas, (names, covariance)) of the latest fit, as OnlineIdentifier.full_estimate; NaN
        before the first."""
        names = self.effects
        if self.result is None:
            nan = dict.fromkeys(names, float('nan'))
            return nan, dict(nan), (names, np.full((len(names),) * 2, np.nan))
        return dict(self.result.parameters), dict(self.result.std), (names, self.result.covariance)

    def problems(self) -> list[str]:
        """What the node's status warns of: a failed latest fit, the latest result's warnings (fit check)."""
        return ([f'the latest fit failed: {self.failure}'] if self.failure else []) + \
            (self.result.warnings() if self.result is not None else [])
