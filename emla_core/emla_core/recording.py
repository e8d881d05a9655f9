"""Uniformly sampled recordings of an actuator run (reading them: emla_core.data)."""
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from emla_core.errors import InputError


@dataclass
class Recording:
    """Signals sampled at `sample_period` (s) from `start_time` (s); `signals` maps name -> 1-D float array
    in SI units (voltage V, current A, position m, velocity m/s, force N; other names as they came).

    source: where it came from (a path); metadata: a bag's custom data (e.g. true_resistance of a simulated
    run); inputs: which column/topic and unit each signal was read from; sampling: how time was read
    (period, jitter), for the commands' JSON.
    """
    sample_period: float
    signals: dict
    start_time: float = 0.0
    source: str = ''
    metadata: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    sampling: dict = field(default_factory=dict)

    def __post_init__(self):
        lengths = {len(v) for v in self.signals.values()}
        if len(lengths) > 1:
            raise InputError(f'{self.source or "recording"}: signals have different lengths {sorted(lengths)}')

    def __len__(self):
        return len(next(iter(self.signals.values()))) if self.signals else 0

    @property
    def time(self) -> np.ndarray:
        return self.start_time + self.sample_period * np.arange(len(self))

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
