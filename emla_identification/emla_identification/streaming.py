"""Identification of records too long to hold in memory, part by part (identify_chunks).

identify_chunks takes a record as consecutive parts (Recordings: emla_core.bag.iter_chunks from a bag, split()
of one in memory) and accumulates their rows' statistics (segments.py): memory of one part and a few small
matrices, whatever the record's length. The result is greybox.identify's on the whole record to rounding (the
same least-squares states and moments, summed in other groupings); the convergence trajectory is sampled at
part ends. A record in segments (samples lost) goes the same way: no row spans a gap.
"""
import itertools
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from emla_core.data import window_parts
from emla_core.recording import Recording

from . import checks, greybox
from .greybox import GreyBoxResult
from .segments import identified, skipped, split

LONG_SAMPLES = 1 << 20   # from here on a record is identified part by part (bounded memory)


def read_record(path: Path | str, load: Callable[[Path], Recording], *, plain: bool = True,
                long_samples: int | None = None, start: float | None = None,
                end: float | None = None) -> tuple[Recording, Iterator[Recording] | None]:
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
    start, end : float, optional
        The window (s, emla_core.data.load's) a bag read in parts is cut to; `load` cuts the others itself.

    Returns
    -------
    tuple
        (the Recording, None) when it is shorter than `long_samples`, else (it or its first part, an iterator
        over its consecutive parts). Either may be in segments: the Recording's gaps, parts that do not follow on.
    """
    from emla_core.bag import iter_chunks
    from emla_core.bag.foreign import suite_layout
    path = Path(path)
    long_samples = LONG_SAMPLES if long_samples is None else long_samples
    if not plain or not suite_layout(path):
        recording = load(path)
        return recording, None if len(recording) < long_samples else split(recording)
    parts = window_parts(iter_chunks(path), start, end)
    head, samples = [], 0
    for part in parts:
        head.append(part)
        samples += len(part)
        if samples >= long_samples:
            return head[0], itertools.chain(_handed_over(head), parts)
    return join(head), None   # iter_chunks yields at least one part


def join(parts: list[Recording]) -> Recording:
    """One Recording of consecutive parts (each without gaps, in time order, as iter_chunks yields them): their
    samples, with a gap (Recording.gaps) where a part does not follow on from the one before."""
    first, gaps, samples, end = parts[0], [], 0, None
    for part in parts:
        missing = 0 if end is None else skipped(end, part)
        if missing:
            gaps.append((samples, missing))
        samples += len(part)
        end = part.start_time + len(part) * part.sample_period
    whole = {name: np.concatenate([part.signals[name] for part in parts]) for name in first.signals}
    return Recording(first.sample_period, whole, first.start_time, first.source, first.metadata, gaps=tuple(gaps))


def _handed_over(parts):
    """The parts of a list, each removed from it as it is yielded (so the list does not keep them alive)."""
    while parts:
        yield parts.pop(0)


def identify_chunks(chunks: Iterable[Recording], model: str | None = None, forgetting: float = 1.0, *,
                    initial_covariance: float = 1e6, points: int = 200,
                    progress: Callable[[int], object] | None = None, spans: list | None = None,
                    spring: bool | None = None) -> GreyBoxResult:
    """greybox.identify of the record that `chunks` yields as consecutive Recordings, one held at a time.

    A part that starts after the previous one's end begins a new segment of the record (samples were lost
    between them): no row spans the gap. The trajectory holds the estimates after at most `points` evenly spaced
    parts (the last: the final estimate); progress: None or a function called with the samples done after each
    part; spans: None or a list that gets [start time s, samples] of each segment as it is read (for
    emla_core.sampling.listing); spring: as greybox.identify's (the rows with the spring's column accumulated
    beside the nominal ones in the same pass).
    """
    chunks = iter(chunks)
    first = next(chunks, None)
    if first is None:
        raise ValueError('identify_chunks needs at least one part of the record')
    model, kinds, lam = checks.setup(first, model, forgetting)
    checks.check_magnitudes(first)
    with checks.numerical_failures(first.source, f'the {model} model cannot be identified'):
        return identified(first, chunks, model, kinds, lam, initial_covariance, points, progress,
                          [] if spans is None else spans, greybox.chosen_result, spring=spring)
