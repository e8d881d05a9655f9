"""The grey-box statistics of a record in consecutive parts (Recordings), which may lie in segments: the core of
streaming.identify_chunks (a record too long for memory) and of greybox.identify of a record with gaps
(identify_segments).

Per regression it keeps an offline.WeightedAccumulator and the moments.RowMoments of its rows, and their plain Gram
matrix for the excitation check: memory of one part and a few small matrices. A part that does not follow on from
the one before (it starts after that one's end: samples were lost, Recording.gaps, a bag's missing frames) begins
a new segment, and the rows restart there (RowStream.restart), so that none spans a gap; every segment's rows
feed the one estimate, and a segment shorter than a row gives none (the result's notes say so). A return spring
is tried as greybox.identify tries it: the rows with its column are accumulated beside the nominal ones in the same
pass (online_effects.EffectColumns, restarted with the rows), and greybox.chosen_result makes the GreyBoxResult of
the one it chooses; it is passed in (greybox.identify comes here with a record with gaps).
"""
import itertools
from collections.abc import Callable, Iterator
from dataclasses import replace

import numpy as np

from emla_core.recording import Recording

from . import checks, offline
from .moments import RowMoments
from .online_effects import EffectColumns, spring_options, with_columns
from .regressors import COLUMNS, HISTORY, INSTRUMENTED, RowStream

CHUNK_SAMPLES = 1 << 14  # samples whose rows are formed at a time: they stay in cache


def identify_segments(recording: Recording, model: str, kinds: tuple, forgetting: float, initial_covariance: float,
                      points: int, progress: Callable[[float], object], spring: bool | None, finish: Callable):
    """greybox.identify of a checked Recording with gaps (greybox's settings `model`, `kinds`, `forgetting`,
    `spring`; progress(fraction done); finish: greybox.chosen_result): its segments' rows, none across a gap, in
    one estimate, the trajectory after parts of about len / `points` samples. The fit is checked on the longest
    segment (the estimate describes them all) or, with forgetting, on the last (the one it remembers)."""
    segments = recording.segments()
    parts = split(recording, max(len(recording) // max(points, 1), 1))
    checked_on = max(segments, key=len) if forgetting == 1.0 else segments[-1]
    return identified(next(parts), parts, model, kinds, forgetting, initial_covariance, points,
                      lambda samples: progress(samples / len(recording)), [], finish, checked_on, spring)


def identified(first, chunks, model, kinds, lam, initial_covariance, points, progress, spans, finish,
               checked_on=None, spring=None):
    """The GreyBoxResult (made by `finish`: greybox.chosen_result, of the nominal rows and, as `spring` asks,
    those with the spring: online_effects.spring_options) of checked settings from consecutive parts: the first part,
    then the others from the iterator `chunks`. Each part that does not follow on from the one before (skipped)
    begins a segment, whose [start time s, samples] `spans` gets; the trajectory is sampled every stride-th part
    (the stride doubling to keep fewer than `points`); progress(samples done) after each part; the fit is checked
    on `checked_on` (default: the first part)."""
    ts = first.sample_period
    stream = RowStream(kinds, ts)
    options = [(EffectColumns(columns, ts) if columns else None,
                {kind: _Regression(kind, lam, initial_covariance, columns) for kind in kinds})
               for columns in spring_options(kinds, spring)]
    snapshots, ends, times, stride, parts, rows, end = [[] for _ in options], [], [], 1, 0, 0, None
    for part in itertools.chain([first], chunks):
        if part.sample_period != ts:
            raise ValueError(f'parts with different sample periods ({ts}, {part.sample_period})')
        if end is None or skipped(end, part):   # a new segment: its rows start afresh
            stream.restart()
            for columns, _ in options:
                if columns is not None:
                    columns.restart()
            spans.append([part.start_time, 0])
        spans[-1][1] += len(part)
        end = part.start_time + len(part) * ts
        checks.check_finite(part, kinds, first=stream.samples)
        for start in range(0, len(part), CHUNK_SAMPLES):  # whatever the parts' size, rows in cache-sized slices
            piece = {name: part.signals[name][start:start + CHUNK_SAMPLES] for name in stream.signals}
            made = stream.rows(piece)
            for columns, regressions in options:
                extended = made if columns is None else with_columns(made, *columns.rows(piece['position'], kinds))
                for kind, (phi, y, zeta) in extended.items():
                    regressions[kind].add(phi, y, zeta)
            rows += len(made[kinds[0]][1])   # (every regression has a row at each sample)
        if rows:
            parts += 1
            if parts % stride == 0 and points > 1:  # every stride-th part, stride doubling to keep < points
                for kept, (_, regressions) in zip(snapshots, options):
                    kept.append({kind: r.statistics() for kind, r in regressions.items()})
                ends.append(rows)
                times.append(end - ts)
                if len(ends) >= points:
                    snapshots = [kept[1::2] for kept in snapshots]
                    ends, times, stride = ends[1::2], times[1::2], 2 * stride
        if progress:
            progress(stream.samples)
    checks.check_length(min(stream.samples, rows + HISTORY), model, first.source)
    for kind, regression in options[0][1].items():
        checks.check_excitation(regression.gram(), kind, first.source or 'recording')
    if ends and ends[-1] == rows:
        snapshots = [kept[:-1] for kept in snapshots]
        ends, times = ends[:-1], times[:-1]
    for kept, (_, regressions) in zip(snapshots, options):
        kept.append({kind: r.statistics() for kind, r in regressions.items()})
    ends.append(rows)
    times.append(end - ts)
    out = finish(model, snapshots, ends, checked_on or first, stream.samples, lam, spring)
    out.trajectory = replace(out.trajectory, time=np.array(times))
    short = [(start, samples) for start, samples in spans if samples <= HISTORY]
    if short:
        shown = ', '.join(f't = {start:.6g} s ({samples} samples)' for start, samples in short[:5])
        out.notes.append(f'{len(short)} segment(s) shorter than a regression row ({HISTORY + 1} samples) are not '
                         f'used: {shown}{", ..." if len(short) > 5 else ""}')
    return out


class _Regression:
    """What identified keeps of one regression's rows."""

    def __init__(self, kind, forgetting, initial_covariance, columns=()):
        n, self.nominal = len(COLUMNS[kind]) + len(columns), len(COLUMNS[kind])
        self.least_squares = offline.WeightedAccumulator(n, instrumented=kind in INSTRUMENTED,
                                                         forgetting=forgetting, initial_covariance=initial_covariance)
        self.moments = RowMoments(n, forgetting, kind in INSTRUMENTED, tuple(columns))
        self._gram = None if forgetting == 1.0 else np.zeros((n, n))  # else the lag-0 moment is that sum

    def add(self, phi, y, zeta):
        z = np.column_stack((phi, y) if zeta is None else (phi, y, zeta))
        self.least_squares.add_stacked(z)
        self.moments.update(z[:, :phi.shape[1] + 1], zeta)
        if self._gram is not None:
            self._gram += phi.T @ phi

    def gram(self):
        """sum of phi phi' over the rows, unweighted, of the nominal columns (for the excitation check)."""
        gram = self.moments.rows.moments[0, :-1, :-1] if self._gram is None else self._gram
        return gram[:self.nominal, :self.nominal]

    def statistics(self):
        estimate = self.least_squares.estimate()
        return self.moments.statistics(estimate.theta, estimate.covariance)


def skipped(end: float, part: Recording) -> int:
    """The samples missing before `part` after a part that ended at `end` (s: the time after its last sample);
    a ValueError where it begins before."""
    missing = round((part.start_time - end) / part.sample_period)
    if missing < 0:
        raise ValueError(f'a part at t = {part.start_time:.9g} s begins before the one before it ends ({end:.9g} s)')
    return missing


def split(recording: Recording, chunk_samples: int = CHUNK_SAMPLES) -> Iterator[Recording]:
    """Consecutive parts of an in-memory Recording, `chunk_samples` samples each (views): of each of its segments
    in turn (the last part of each shorter)."""
    for segment in recording.segments():
        for start in range(0, max(len(segment), 1), chunk_samples):
            yield replace(segment, signals={name: values[start:start + chunk_samples]
                                            for name, values in segment.signals.items()},
                          start_time=segment.start_time + start * segment.sample_period)
