"""Uniformly sampled recordings of an actuator run (reading them: emla_core.data)."""
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from emla_core.errors import InputError


@dataclass
class Recording:
    """Signals sampled at `sample_period` (s) from `start_time` (s); `signals` maps name -> 1-D float array
    in SI units (voltage V, current A, position m, velocity m/s, force N; other names as they came).

    source: where it came from (a path); metadata: a bag's custom data (e.g. true_resistance of a simulated
    run); inputs: which column/topic and unit each signal was read from; sampling: how time was read
    (period, jitter), for the commands' JSON; gaps: ((sample, missing), ...), `missing` samples lost before
    sample number `sample` (a logger that dropped them: the record is in segments, which segments() gives;
    emla_core.data.load names what may take them), () for a record without gaps.
    """
    sample_period: float
    signals: dict
    start_time: float = 0.0
    source: str = ''
    metadata: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    sampling: dict = field(default_factory=dict)
    gaps: tuple = ()

    def __post_init__(self):
        lengths = {len(v) for v in self.signals.values()}
        if len(lengths) > 1:
            raise InputError(f'{self.source or "recording"}: signals have different lengths {sorted(lengths)}')

    def __len__(self):
        return len(next(iter(self.signals.values()))) if self.signals else 0

    @property
    def time(self) -> np.ndarray:
        """The time (s) of each sample, the gaps' missing samples skipped."""
        return self.start_time + self.sample_period * self._grid(np.arange(len(self)))

    def _grid(self, samples):
        """The places on the record's steady grid (sample 0 at 0) of the sample numbers `samples` (increasing)."""
        samples = np.asarray(samples, dtype=np.int64)
        places = samples.copy()
        for sample, missing in self.gaps:
            places[samples >= sample] += missing
        return places

    def segments(self) -> list:
        """The contiguous parts of the record between its gaps, in time order: Recordings without gaps whose
        signals are views of this one's."""
        bounds = [0, *(sample for sample, _ in self.gaps), len(self)]
        starts = self.start_time + self.sample_period * self._grid(bounds[:-1])
        return [replace(self, signals={name: values[a:b] for name, values in self.signals.items()},
                        start_time=float(start), gaps=()) for a, b, start in zip(bounds, bounds[1:], starts)]

    def has(self, *names: str) -> bool:
        return all(n in self.signals for n in names)

    def truth(self, names: Iterable[str]) -> dict[str, float]:
        """{name: value} of the true parameters a simulated run carries in its metadata (`true_<name>`), of
        those of `names` it has."""
        out = {}
        for name in names:
            try:
                out[name] = float(self.metadata[f'true_{name}'])
            except (KeyError, TypeError, ValueError):
                pass
        return out

    def require(self, *names: str) -> None:
        missing = [n for n in names if n not in self.signals]
        if missing:
            raise InputError(f'{self.source or "recording"}: missing column(s) {", ".join(missing)} '
                             f'(has {", ".join(self.signals) or "none"})')


def write_csv(recording: Recording, path: Path | str, columns: Iterable[str] | None = None) -> None:
    """Write `columns` (default: all signals) with a leading `t` column."""
    columns = list(columns or recording.signals)
    table = np.column_stack([recording.time] + [recording.signals[c] for c in columns])
    np.savetxt(path, table, delimiter=',', header=','.join(['t'] + columns), comments='', fmt='%.10g')
