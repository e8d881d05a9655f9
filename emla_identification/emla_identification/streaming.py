"""Identification of records too long to hold in memory, part by part (identify_chunks).

identify_chunks takes a record as consecutive parts (Recordings: emla_core.bag.iter_chunks from a bag, split()
of one in memory) and keeps per regression an offline.WeightedAccumulator and the moments.RowMoments of its rows,
and their plain Gram matrix for the excitation check: memory of one part and a few small matrices, whatever the
record's length. The result is greybox.identify's on the whole record to rounding (the same least-squares
states and moments, summed in other groupings); the convergence trajectory is sampled at part ends.
"""
import itertools
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from emla_core.recording import Recording

from . import checks, greybox, offline
from .greybox import GreyBoxResult
from .moments import RowMoments
from .regressors import COLUMNS, HISTORY, INSTRUMENTED, RowStream

CHUNK_SAMPLES = 1 << 14  # samples whose rows are formed at a time: they stay in cache
LONG_SAMPLES = 1 << 20   # from here on a record is identified part by part (bounded memory)


def read_record(path: Path | str, load: Callable[[Path], Recording], *, plain: bool = True,
                long_samples: int | None = None) -> tuple[Recording, Iterator[Recording] | None]:
    """A record as identify_chunks or greybox.identify takes it, read in bounded memory when it is long.

    Parameters
    ----------
    path : str or Path
        The data: a file or bag directory.
    load : callable
        load(path) -> Recording, the whole record (with the caller's mapping of columns and units).
    plain : bool, optional
        The data need no mapping (no columns, units or topics given): a bag of the suite's own layout is then
        read in parts as it goes, never held whole.
    long_samples : int, optional
        Records of this many samples or more are identified part by part (default LONG_SAMPLES).

    Returns
    -------
    tuple
        (the Recording, None) when it is shorter than `long_samples`, else (it or its first part, an iterator
        over its consecutive parts).
    """
    from emla_core.bag import iter_chunks
    from emla_core.bag.foreign import suite_layout
    path = Path(path)
    long_samples = LONG_SAMPLES if long_samples is None else long_samples
    if not plain or not suite_layout(path):
        recording = load(path)
        return recording, None if len(recording) < long_samples else split(recording)
    parts = iter_chunks(path)
    head, samples = [], 0
    for part in parts:
        head.append(part)
        samples += len(part)
        if samples >= long_samples:
            return head[0], itertools.chain(_handed_over(head), parts)
    first = head[0]  # iter_chunks yields at least one part
    whole = {name: np.concatenate([part.signals[name] for part in head]) for name in first.signals}
    return Recording(first.sample_period, whole, first.start_time, first.source, first.metadata), None


def _handed_over(parts):
    """The parts of a list, each removed from it as it is yielded (so the list does not keep them alive)."""
    while parts:
        yield parts.pop(0)


class _Regression:
    """What identify_chunks keeps of one regression's rows."""

    def __init__(self, kind, forgetting, initial_covariance):
        n = len(COLUMNS[kind])
        self.least_squares = offline.WeightedAccumulator(n, instrumented=kind in INSTRUMENTED,
                                                         forgetting=forgetting, initial_covariance=initial_covariance)
        self.moments = RowMoments(n, forgetting, kind in INSTRUMENTED)
        self._gram = None if forgetting == 1.0 else np.zeros((n, n))  # else the lag-0 moment is that sum

    def add(self, phi, y, zeta):
        z = np.column_stack((phi, y) if zeta is None else (phi, y, zeta))
        self.least_squares.add_stacked(z)
        self.moments.update(z[:, :phi.shape[1] + 1], zeta)
        if self._gram is not None:
            self._gram += phi.T @ phi

    def gram(self):
        """sum of phi phi' over the rows, unweighted (for the excitation check)."""
        return self.moments.rows.moments[0, :-1, :-1] if self._gram is None else self._gram

    def statistics(self):
        estimate = self.least_squares.estimate()
        return self.moments.statistics(estimate.theta, estimate.covariance)


def identify_chunks(chunks: Iterable[Recording], model: str | None = None, forgetting: float = 1.0, *,
                    initial_covariance: float = 1e6, points: int = 200,
                    progress: Callable[[int], object] | None = None) -> GreyBoxResult:
    """greybox.identify of the record that `chunks` yields as consecutive Recordings, one held at a time.

    The trajectory holds the estimates after at most `points` evenly spaced parts (the last: the final
    estimate); progress: None or a function called with the samples done after each part.
    """
    chunks = iter(chunks)
    first = next(chunks, None)
    if first is None:
        raise ValueError('identify_chunks needs at least one part of the record')
    model, kinds, lam = checks.setup(first, model, forgetting)
    checks.check_magnitudes(first)
    with checks.numerical_failures(first.source, f'the {model} model cannot be identified'):
        return _identified(first, chunks, model, kinds, lam, initial_covariance, points, progress)


def _identified(first, chunks, model, kinds, lam, initial_covariance, points, progress):
    """identify_chunks on checked settings: the first part, then the others from the iterator `chunks`."""
    stream = RowStream(kinds, first.sample_period)
    regressions = {kind: _Regression(kind, lam, initial_covariance) for kind in kinds}
    snapshots, ends, stride, parts = [], [], 1, 0
    for part in itertools.chain([first], chunks):
        if part.sample_period != first.sample_period:
            raise ValueError(f'parts with different sample periods ({first.sample_period}, {part.sample_period})')
        checks.check_finite(part, kinds, first=stream.samples)
        for start in range(0, len(part), CHUNK_SAMPLES):  # whatever the parts' size, rows in cache-sized slices
            piece = {name: part.signals[name][start:start + CHUNK_SAMPLES] for name in stream.signals}
            for kind, (phi, y, zeta) in stream.rows(piece).items():
                regressions[kind].add(phi, y, zeta)
        if stream.samples > HISTORY:
            parts += 1
            if parts % stride == 0 and points > 1:  # every stride-th part, stride doubling to keep < points
                snapshots.append({kind: r.statistics() for kind, r in regressions.items()})
                ends.append(stream.samples - HISTORY)
                if len(snapshots) >= points:
                    snapshots, ends, stride = snapshots[1::2], ends[1::2], 2 * stride
        if progress:
            progress(stream.samples)
    checks.check_length(stream.samples, model, first.source)
    for kind, regression in regressions.items():
        checks.check_excitation(regression.gram(), kind, first.source or 'recording')
    if ends and ends[-1] == stream.samples - HISTORY:
        snapshots, ends = snapshots[:-1], ends[:-1]
    snapshots.append({kind: r.statistics() for kind, r in regressions.items()})
    ends.append(stream.samples - HISTORY)
    return greybox.result(model, snapshots, ends, first, stream.samples, lam)


def split(recording: Recording, chunk_samples: int = CHUNK_SAMPLES) -> Iterator[Recording]:
    """Consecutive parts of an in-memory Recording, `chunk_samples` samples each (the last shorter; views)."""
    ts = recording.sample_period
    for start in range(0, max(len(recording), 1), chunk_samples):
        yield Recording(ts, {name: values[start:start + chunk_samples] for name, values in recording.signals.items()},
                        start_time=recording.start_time + start * ts, source=recording.source,
                        metadata=recording.metadata)
