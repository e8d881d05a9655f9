"""The measured signals the discrepancy workflow works on, and the signal state its effect terms see.

`Data` is a Recording reduced to what the two equations need (voltage, current, position, or force and
position), with a point velocity estimate and room at the end for re-aligning delayed sensors.
`State` is the set of signals at some samples: the measured ones when regressing, the predicted ones
(current, position, velocity) when simulating; candidate effects are written against it.

Re-aligning (a sensor's delay, whole or fractional, `realigned`) never re-samples the drive signal (current or
force): with its kinks at every sample (dI/dt jumps with the held voltage) interpolation would falsify it. The
other signals are moved to it instead: the held voltage by its interval means, the position (smooth to its
second derivative) by an all-pass fractional delay, which leaves its noise as it is. A first-order low-pass
on the drive signal (`unfiltered`) is matched by passing the voltage and position through the same filter;
one on the position is undone. What that does to each signal's white noise is kept as an FIR filter
(`shaping`), so the noise floor (adequacy.py) sees the noise the equations see.
"""
import math
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np

from emla_core.errors import InputError
from emla_identification.checks import missing_signals
from emla_identification.regressors import HISTORY, LEAD, default_model, regressions_for

THIRAN_ORDER = 5       # of the all-pass that moves a smooth signal by a fraction of a sample (3 was not flat far
                       # enough for a 2 kHz logger's fast motion: docs/physics.md 7)
PARTS = 32              # equal parts of an interval a re-aligned voltage is described on (Data.voltage_parts)
SMOOTH_DERIVATIVE = 7  # samples of the quartic whose slope undoes a position's filter (Data._undone)
MAX_DELAY = 8          # samples a sensor delay may have; the last MAX_DELAY samples are kept for re-alignment
MIN_SAMPLES = 400      # below this neither the statistics nor the k-step predictions mean much


@dataclass(frozen=True)
class Data:
    """Equally long arrays of the window analysed; `spare` holds the MAX_DELAY samples after it."""

    sample_period: float
    start_time: float
    signals: dict          # name -> array over the window: voltage, current, position | force, position
    spare: dict            # name -> the MAX_DELAY samples that follow the window
    kinds: tuple           # regressions of regressors.py: ('electrical', 'mechanical') or ('force',)
    source: str = ''
    shaping: dict = field(default_factory=dict)   # name -> FIR taps a re-alignment applied to its noise
    # the voltage's mean over each of PARTS parts of every interval (window and spare: samples x PARTS) where a
    # re-alignment left it not held over the interval (the exact rows take it so, rows.py); None: held
    voltage_parts: np.ndarray | None = None
    # re-align with finer interpolators (an all-pass two orders higher; a position's slope unsmoothed): what the
    # estimates do then bounds what the interpolation leaves in them (profile.finer)
    finer: bool = False
    max_delay: ClassVar[int] = MAX_DELAY

    @classmethod
    def from_recording(cls, recording):
        source = recording.source or 'recording'
        model = default_model(recording.signals)
        if model is None:
            raise missing_signals(recording)
        kinds = regressions_for(model, recording.signals)
        if 'position' not in recording.signals:
            raise InputError(f'{source}: the discrepancy analysis needs the position (this record has the velocity '
                             f'only; `emla identify` takes it)')
        names = ('force', 'position') if kinds == ('force',) else ('voltage', 'current', 'position')
        n = len(recording) - MAX_DELAY
        if n < MIN_SAMPLES:
            raise InputError(f'{source}: {len(recording)} samples are too few for the discrepancy analysis '
                             f'(needs at least {MIN_SAMPLES + MAX_DELAY})')
        arrays = {}
        for name in names:
            values = np.asarray(recording.signals[name], dtype=float)
            bad = ~np.isfinite(values)
            if bad.any():
                raise InputError(f'{source}: non-finite {name} at sample {int(np.argmax(bad))}')
            arrays[name] = values
        if np.ptp(arrays['position']) == 0.0:
            raise InputError(f'{source}: the position never changes; nothing to compare a model with')
        return cls(recording.sample_period, recording.start_time, {k: v[:n] for k, v in arrays.items()},
                   {k: v[n:] for k, v in arrays.items()}, kinds, source)

    def __len__(self):
        return len(self.signals['position'])

    @property
    def electrical(self):
        return 'electrical' in self.kinds

    @property
    def mechanical(self):
        """The mechanical regression's kind: 'mechanical' (coil current) or 'force' (measured force)."""
        return self.kinds[-1]

    @property
    def drive(self):
        """The mechanical input: 'current' (force Km I) or 'force' (measured)."""
        return 'force' if 'force' in self.signals else 'current'

    @property
    def sensed(self):
        """Signals a sensor measures (and may deliver late), as opposed to the applied voltage."""
        return tuple(n for n in self.signals if n != 'voltage')

    @property
    def time(self):
        return self.start_time + self.sample_period * np.arange(len(self))

    def realigned(self, delays):
        """Data with each sensed signal moved `delays[name]` samples earlier (undoing a sensor delay; a delay may
        be fractional, 0 <= delay <= MAX_DELAY).

        The drive signal (current or force) moves by whole samples only, floor(its delay); the fraction c left
        over is applied to the others in the other direction: the held voltage becomes its mean over the
        interval c later, c u_k-1 + (1 - c) u_k, and every other sensed signal moves delay - c samples
        earlier, by a Thiran all-pass (`_advanced`) where that is fractional. The record's time moves by c
        samples, which nothing reads."""
        delays = {name: float(d) for name, d in delays.items() if d}
        for name, d in delays.items():
            if name not in self.sensed or not 0.0 <= d <= MAX_DELAY:
                raise ValueError(f'cannot undo a delay of {d:g} samples on {name!r}')
        c = delays.get(self.drive, 0.0) % 1.0
        signals, spare, shaping = dict(self.signals), dict(self.spare), dict(self.shaping)
        parts = self.voltage_parts
        n = len(self)
        for name in self.signals:
            full = np.concatenate((self.signals[name], self.spare[name]))
            if name == 'voltage':
                if c:   # the voltage over [t_k - c Ts, t_k+1 - c Ts], by parts
                    parts = _parts_later(self._parts(), c)
                    full = parts.mean(axis=1)
            else:
                shift = delays.get(name, 0.0) - c
                if shift == round(shift):
                    full = np.concatenate((full[int(shift):], np.repeat(full[-1:], int(shift))))
                else:
                    full = _advanced(full, shift, THIRAN_ORDER + 2 * self.finer)
            signals[name], spare[name] = full[:n], full[n:]
        return replace(self, signals=signals, spare=spare, shaping=shaping, voltage_parts=parts)

    def _parts(self):
        """The voltage's mean over each of PARTS parts of every interval (samples x PARTS, window and spare)."""
        if self.voltage_parts is not None:
            return self.voltage_parts
        return np.repeat(np.concatenate((self.signals['voltage'], self.spare['voltage']))[:, None], PARTS, axis=1)

    def unfiltered(self, names, time_constant):
        """Data in which `names` (a sensed signal, or several) are taken to have passed a first-order low-pass,
        tau dy/dt = w - y, before they were sampled.

        For the drive signal (current or force) the voltage and the position pass the same filter instead, so
        that every equation holds between filtered signals (exactly for the linear model, which commutes with
        the filter), and the drive's own noise, which dominates the electrical equation's error, is left as
        it is: undoing the filter would amplify it, and a current's kinks at every sample with it; filtering it
        would smooth its noise away, which the held-out errors would reward whatever the filter. The filter is
        applied exactly to the held voltage (each interval's mean of the filtered staircase) and to a position
        cubic through x_k-1 .. x_k+2; it starts settled at the first samples. Every sensed signal behind the same
        filter (one anti-alias filter per channel): the voltage alone passes it.

        For the position alone (smooth), the filter is undone (_undone).

        What this does to a signal's noise is kept in `shaping`."""
        names = (names,) if isinstance(names, str) else tuple(names)
        if not names or any(name not in self.sensed for name in names):
            raise ValueError(f'{names!r} are not sensed signals of these data')
        tau = float(time_constant)
        if not tau > 0.0:
            return self
        if set(names) == set(self.sensed):
            passing = [k for k in self.signals if k == 'voltage']
        elif names == (self.drive,):
            passing = [k for k in self.signals if k != self.drive]
        elif len(names) == 1:
            return self._undone(names[0], tau)
        else:
            raise ValueError(f'a filter on {names!r} alone is not modelled')
        from scipy.signal import lfilter
        a = math.exp(-self.sample_period / tau)
        ratio = tau / self.sample_period
        signals, spare, shaping = dict(self.signals), dict(self.spare), dict(self.shaping)
        parts = self.voltage_parts
        n = len(self)
        full = {k: np.concatenate((self.signals[k], self.spare[k])) for k in self.signals}
        for other in passing:
            w = full[other]
            if other == 'voltage':   # each part held: y_end = b y_start + (1 - b) u,
                # its mean u + (y_start - u) T (1 - b), T = PARTS tau / Ts (tau in parts)
                b, fine = a ** (1.0 / PARTS), self._parts().ravel()
                y = lfilter([1.0 - b], [1.0, -b], fine, zi=[b * fine[0]])[0]
                start = np.concatenate((fine[:1], y[:-1]))
                parts = (fine + (start - fine) * ratio * PARTS * (1.0 - b)).reshape(-1, PARTS)
                full[other] = parts.mean(axis=1)
            else:
                weights = _filter_weights(a, ratio)
                padded = np.concatenate((w[:1], w, np.repeat(w[-1:], 2)))
                drive = sum(weights[j] * padded[j:j + len(w)] for j in range(4))
                full[other] = np.concatenate((w[:1], lfilter([1.0], [1.0, -a], drive[:-1], zi=[a * w[0]])[0]))
                impulse = lfilter([1.0], [1.0, -a], np.eye(1, _taps(a))[0])
                shaping[other] = np.convolve(shaping.get(other, [1.0]), np.convolve(weights, impulse))
        for k in self.signals:
            signals[k], spare[k] = full[k][:n], full[k][n:]
        return replace(self, signals=signals, spare=spare, shaping=shaping, voltage_parts=parts)

    def _undone(self, name, tau):
        """Data with the filter of `tau` undone on sensed signal `name`: w = y + tau dy/dt, dy/dt the Savitzky-Golay
        derivative (a quartic through SMOOTH_DERIVATIVE samples, least squares; where `finer`, the polynomial through
        them, unsmoothed). The three-point difference errs by tau Ts^2 y'''/6 (R 0.03 %, 7 sigma, off on a 5 kHz
        record behind a 12.7 kHz position filter); the five-point one is exact to the same order as this but
        amplifies the noise by 0.90 tau^2/Ts^2 (this: 0.26), which the held-out search of tau penalises: it left tau
        7 % short behind a 2 kHz filter at 10 kHz."""
        from scipy.signal import savgol_coeffs, savgol_filter
        ratio = tau / self.sample_period
        w = np.concatenate((self.signals[name], self.spare[name]))
        degree = SMOOTH_DERIVATIVE - 1 if self.finer else 4
        out = w + ratio * savgol_filter(w, SMOOTH_DERIVATIVE, degree, deriv=1)
        taps = ratio * savgol_coeffs(SMOOTH_DERIVATIVE, degree, deriv=1, use='dot')   # in sample order
        taps[SMOOTH_DERIVATIVE // 2] += 1.0
        n = len(self)
        return replace(self, signals=dict(self.signals, **{name: out[:n]}), spare=dict(self.spare, **{name: out[n:]}),
                       shaping=dict(self.shaping, **{name: np.convolve(self.shaping.get(name, [1.0]), taps)}))

    def velocity(self):
        """Point velocity at every sample: five-point central difference (exact for cubic motion; kept: every
        candidate column's current path starts from it, Rows._path). Read only.

        A wider smoothing fit would be biased by the jerk of the fast strokes (~1e6 m/s^3 at Table 1)."""
        if '_velocity' not in self.__dict__:
            x = self.signals['position']
            v = np.gradient(x, self.sample_period)
            v[2:-2] = (x[:-4] - 8.0 * x[1:-3] + 8.0 * x[3:-1] - x[4:]) / (12.0 * self.sample_period)
            v.flags.writeable = False
            self.__dict__['_velocity'] = v
        return self.__dict__['_velocity']

    def state(self):
        """The measured State at every sample."""
        return State(self, np.arange(len(self)), velocity=self.velocity(), **self.signals)

    def voltage_deviation(self):
        """The voltage's mean over each of PARTS parts of every interval of the window less the interval's mean
        (samples x PARTS; kept: every Rows of a re-aligned record asks), or None where the voltage is held."""
        if self.voltage_parts is None:
            return None
        if '_voltage_deviation' not in self.__dict__:
            parts = self.voltage_parts[:len(self)]
            self.__dict__['_voltage_deviation'] = parts - parts.mean(axis=1, keepdims=True)
        return self.__dict__['_voltage_deviation']

    def between(self, pieces):
        """{'position', 'velocity'}: (intervals, pieces) at the middle of each of `pieces` equal parts of every
        interval, along the cubic spline through the measured positions (kept: a diagnosis asks often)."""
        key = f'_between_{pieces}'
        if key not in self.__dict__:
            from scipy.interpolate import CubicSpline
            n = len(self)
            spline = CubicSpline(np.arange(n), self.signals['position'])
            middles = np.arange(n - 1)[:, None] + (np.arange(pieces) + 0.5) / pieces
            self.__dict__[key] = {'position': spline(middles), 'velocity': spline(middles, 1) / self.sample_period}
        return self.__dict__[key]


@dataclass
class State:
    """Signals at samples `index` of `data`; None for those the data do not have."""

    data: Data
    index: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    current: np.ndarray | None = None
    voltage: np.ndarray | None = None
    force: np.ndarray | None = None

    @property
    def time(self):
        return self.data.start_time + self.data.sample_period * self.index


def _advanced(values, shift, order=THIRAN_ORDER):
    """values at index k + shift for every k (a fractional shift > -order - 1/2), by a Thiran all-pass fractional
    delay of `order`: its group delay is maximally flat at low frequencies, where a smooth signal (the position)
    lives, and its gain is 1 at every frequency, so white noise stays white at its level. (An interpolating FIR
    would smooth the noise away, and a held-out error would reward the fraction that smooths most.) The filter
    delays the sequence (its end held) by D = round(shift) + order - shift in [order - 1/2, order + 1/2], where it
    is stable and its phase closest to a delay's, and its output is read round(shift) + order samples on. It
    starts settled at the first sample, as if the signal had rested there: started at a later sample instead
    (the record cut before filtering), a record that begins in motion put a transient in the first rows that
    differed between the two ranges of D and made the held-out error jump where round(shift) steps (a position
    0.64 samples late at 10 kHz was set at 0.5)."""
    from scipy.signal import lfilter, lfilter_zi
    whole = round(shift) + order
    delay = whole - shift
    k = np.arange(order + 1)
    a = np.array([(-1.0) ** j * math.comb(order, j) *
                  np.prod([(delay - order + m) / (delay - order + j + m) for m in range(order + 1)]) for j in k])
    padded = np.concatenate((values, np.repeat(values[-1:], whole)))
    return lfilter(a[::-1], a, padded, zi=lfilter_zi(a[::-1], a) * values[0])[0][whole:]


def _parts_later(parts, c):
    """Parts (samples x PARTS means of a voltage over each interval's parts) of the same voltage taken `c` (0..1)
    samples later, exact for a voltage held over each part: c PARTS = w + f parts, so each new part overlaps the
    old part w + 1 back by f and the one w back by 1 - f. Before the record, the first value held."""
    fine = parts.ravel()
    whole, f = divmod(c * PARTS, 1.0)
    padded = np.concatenate((np.repeat(fine[:1], int(whole) + 1), fine))
    n = len(fine)
    return ((1.0 - f) * padded[1:n + 1] + f * padded[:n]).reshape(parts.shape)


def _filter_weights(a, tau):
    """w_j (j = -1 .. 2) with y_k+1 = a y_k + sum_j w_j x_k+j the first-order filter (time constant `tau`
    samples, a = exp(-1/tau)) over [t_k, t_k+1] of the cubic through x_k-1 .. x_k+2 (Gauss-Legendre, exact to
    rounding for these smooth integrands)."""
    nodes, weights = np.polynomial.legendre.leggauss(12)
    s = 0.5 * (nodes + 1.0)                       # in [0, 1] of the interval
    kernel = 0.5 * weights * np.exp(-(1.0 - s) / tau) / tau
    basis = [(-1.0, [0.0, 1.0, 2.0]), (0.0, [-1.0, 1.0, 2.0]), (1.0, [-1.0, 0.0, 2.0]), (2.0, [-1.0, 0.0, 1.0])]
    return np.array([kernel @ np.prod([(s - o) / (node - o) for o in others], axis=0) for node, others in basis])


def _taps(a, floor=1e-9):
    """Length of an impulse response decaying as a^k until below `floor`."""
    return int(min(512, max(1, math.ceil(math.log(floor) / math.log(a)) if a > 0 else 1)))


def regression_rows(data):
    """Sample index k of each regression row of regressors.rows (rows use samples k-3 .. k+2)."""
    return np.arange(LEAD, LEAD + max(len(data) - HISTORY, 0))
