"""The measured signals the discrepancy workflow works on, and the signal state its effect terms see.

`Data` is a Recording reduced to what the two equations need (voltage, current, position, or force and
position), with a point velocity estimate and room at the end for re-aligning delayed sensors.
`State` is the set of signals at some samples: the measured ones when regressing, the predicted ones
(current, position, velocity) when simulating; candidate effects are written against it.
"""
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from emla_core.errors import InputError
from emla_identification.checks import missing_signals
from emla_identification.regressors import default_model, regressions_for

from .first_order import HISTORY

MAX_DELAY = 8          # samples a sensor delay may have; the last MAX_DELAY samples are kept for re-alignment
MIN_SAMPLES = 400      # below this neither the statistics nor the k-step predictions mean much


@dataclass(frozen=True)
class Data:
    """Equally long arrays of the window analysed; `spare` holds the MAX_DELAY samples after it."""

    sample_period: float
    start_time: float
    signals: dict          # name -> array over the window: voltage, current, position | force, position
    spare: dict            # name -> the MAX_DELAY samples that follow the window
    kinds: tuple           # regressions of first_order.py: ('electrical', 'mechanical') or ('force',)
    source: str = ''
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
        """Data with each sensed signal moved `delays[name]` samples earlier (undoing a sensor delay)."""
        signals = dict(self.signals)
        for name, d in delays.items():
            full = np.concatenate((self.signals[name], self.spare[name]))
            signals[name] = full[d:d + len(self)]
        return replace(self, signals=signals)

    def velocity(self):
        """Point velocity at every sample: five-point central difference (exact for cubic motion).

        A wider smoothing fit would be biased by the jerk of the fast strokes (~1e6 m/s^3 at Table 1)."""
        x = self.signals['position']
        v = np.gradient(x, self.sample_period)
        v[2:-2] = (x[:-4] - 8.0 * x[1:-3] + 8.0 * x[3:-1] - x[4:]) / (12.0 * self.sample_period)
        return v

    def state(self):
        """The measured State at every sample."""
        return State(self, np.arange(len(self)), velocity=self.velocity(), **self.signals)


@dataclass
class State:
    """Signals at samples `index` of `data`; None for those the data do not have."""

    data: Data
    index: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    current: np.ndarray = None
    voltage: np.ndarray = None
    force: np.ndarray = None

    @property
    def time(self):
        return self.data.start_time + self.data.sample_period * self.index


def regression_rows(data):
    """Sample index of each regression row of first_order.rows (rows need samples k-2 .. k+2)."""
    return np.arange(HISTORY // 2, len(data) - HISTORY // 2)
