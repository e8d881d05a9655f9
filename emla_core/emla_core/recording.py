"""Uniformly sampled recordings of an actuator run, and reading them from CSV with clear errors."""
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from emla_core.errors import InputError

# Relative spread of time steps accepted as uniform sampling (CSV time columns carry rounding).
UNIFORM_TOLERANCE = 1e-3


@dataclass
class Recording:
    """Signals sampled at `sample_period` from `start_time`; `signals` maps name -> 1-D float array."""
    sample_period: float
    signals: dict
    start_time: float = 0.0
    source: str = ''
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        lengths = {len(v) for v in self.signals.values()}
        if len(lengths) > 1:
            raise InputError(f'{self.source or "recording"}: signals have different lengths {sorted(lengths)}')

    def __len__(self):
        return len(next(iter(self.signals.values()))) if self.signals else 0

    @property
    def time(self):
        return self.start_time + self.sample_period * np.arange(len(self))

    def has(self, *names):
        return all(n in self.signals for n in names)

    def require(self, *names):
        missing = [n for n in names if n not in self.signals]
        if missing:
            raise InputError(f'{self.source or "recording"}: missing column(s) {", ".join(missing)} '
                             f'(has {", ".join(self.signals) or "none"})')


def read_csv(path):
    """A Recording from a CSV file with a header row and a `t` column in seconds (uniform sampling)."""
    path = Path(path)
    try:
        with path.open() as f, warnings.catch_warnings():
            warnings.simplefilter('ignore')      # loadtxt warns on no rows; that case is reported below
            header = f.readline()
            data = np.loadtxt(f, delimiter=',', ndmin=2, dtype=float)
    except FileNotFoundError:
        raise InputError(f'{path}: no such file') from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f'{path}: cannot read: {exc}') from None
    except ValueError as exc:
        raise InputError(f'{path}: not numeric CSV: {exc}') from None
    names = [n.strip() for n in header.strip().split(',')]
    if not header.strip():
        raise InputError(f'{path}: empty file')
    if 't' not in names:
        raise InputError(f'{path}: missing column t (time in s); header is {header.strip()!r}')
    if len(set(names)) != len(names):
        raise InputError(f'{path}: repeated column names in header {header.strip()!r}')
    if data.size == 0:
        raise InputError(f'{path}: no data rows')
    if data.shape[1] != len(names):
        raise InputError(f'{path}: {data.shape[1]} values per row but {len(names)} columns in the header')
    if data.shape[0] < 2:
        raise InputError(f'{path}: needs at least two samples')
    bad = ~np.isfinite(data)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise InputError(f'{path}: non-finite value {data[row, col]} in column {names[col]} at data row {row + 1}')
    t = data[:, names.index('t')]
    return Recording(sample_period=_uniform_period(t, path), start_time=float(t[0]), source=str(path),
                     signals={n: data[:, i].copy() for i, n in enumerate(names) if n != 't'})


def _uniform_period(t, path):
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0))
        raise InputError(f'{path}: time is not increasing at data row {k + 2} (t = {t[k + 1]:.9g} s after {t[k]:.9g} s)')
    period = (t[-1] - t[0]) / (len(t) - 1)
    if np.max(np.abs(dt - period)) > UNIFORM_TOLERANCE * period:
        k = int(np.argmax(np.abs(dt - period)))
        raise InputError(f'{path}: sampling is not uniform at data row {k + 2} '
                         f'(step {dt[k]:.6g} s, mean step {period:.6g} s)')
    return float(period)


def write_csv(recording, path, columns=None):
    """Write `columns` (default: all signals) with a leading `t` column."""
    columns = list(columns or recording.signals)
    table = np.column_stack([recording.time] + [recording.signals[c] for c in columns])
    np.savetxt(path, table, delimiter=',', header=','.join(['t'] + columns), comments='', fmt='%.10g')
