"""Logged times onto one uniform grid: the steady rate behind jittered timestamps, missing samples found,
signals of different times or rates aligned.

A data-acquisition clock samples at a steady rate, but the host that logs the samples stamps them late by a
varying delay (+-5 % of the period is common over USB or Ethernet). Such timestamps are taken as the steady
rate they jitter around (up to JITTER_LIMIT). A step of about two or more periods is samples lost (a logger that
drops some): a gap on the grid, never bridged. The record is then in segments (Recording.gaps; the grey-box
identification joins no regression row across a gap). More than MAX_GAPS gaps, or a gap of more samples than
the record holds, is not a record in segments but a broken logger or separate records: check_gaps refuses it.

Grid places are whole sample periods from a record's first sample; a run is (first place, end place) of
samples that follow on from each other, a signal's runs are in time order and do not touch (shared: the places
all of several signals have).
"""
import numpy as np

from emla_core.errors import InputError

JITTER_LIMIT = 0.25  # of the period: steps this close to it are jitter (stamps jittering by +-10 % of the
                     # period make steps up to 20 % off); a step over a gap, this close to whole periods
SAME_RATE = 1e-3    # relative difference of periods below which signals share one rate
MAX_GAPS = 100      # gaps a record in segments may have (a logger that drops samples now and then)


def steady_period(t, source, what='t', row='sample', first=0):
    """(period, start, jitter, gaps) of increasing times `t` (s) of a steadily sampled signal.

    period: the median step; start: the time of sample 0 on the steady grid that fits `t` best (so the
    grid is not shifted by the jitter of the first stamp); jitter: the largest |t - grid| / period; gaps:
    ((sample, missing), ...) as Recording.gaps, for the steps of two periods or more.
    InputError for too few samples, times that do not increase, steps further than JITTER_LIMIT from a whole
    number of periods and gaps beyond check_gaps's bounds; it names the place as `row` number (row_number of
    `first` and the index), e.g. 'data row' 2 for a CSV file's first step.
    """
    t = np.asarray(t, dtype=float)
    if len(t) < 2:
        raise InputError(f'{source}: needs at least two samples of {what}')
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        raise InputError(f'{source}: time is not increasing at {row} {row_number(first, k + 1)} '
                         f'({what} = {t[k + 1]:.9g} s after {t[k]:.9g} s)')
    period = float(np.median(steps))
    spans = np.maximum(np.rint(steps / period), 1.0)   # the whole periods each step spans
    deviation = np.abs(steps - spans * period) / period
    if deviation.max() > JITTER_LIMIT:
        k = int(np.argmax(deviation))
        raise InputError(f'{source}: sampling is not uniform at {row} {row_number(first, k + 1)} (step '
                         f'{steps[k]:.6g} s, steady step {period:.6g} s; steps up to {JITTER_LIMIT:.0%} off are taken '
                         f'as jitter)')
    places = np.concatenate(([0.0], np.cumsum(spans)))
    k = places - places.mean()                        # the steady grid that fits the stamps best
    period = float(k @ (t - t.mean()) / (k @ k))
    start = float(t.mean() - period * places.mean())
    jitter = float(np.max(np.abs(t - start - period * places))) / period
    gaps = tuple((int(k) + 1, int(spans[k]) - 1) for k in np.flatnonzero(spans > 1))
    check_gaps(source, gaps, len(t), start, period)
    return period, start, jitter, gaps


def row_number(first, k):
    """The number that names sample k in messages: `first` + k, or `first`[k] where `first` numbers each sample
    (the rows a window or dropped repeats left)."""
    return int(first[k]) if np.ndim(first) else first + k


def check_gaps(source, gaps, samples, start, period):
    """InputError when the gaps ((sample, missing), ...) of a record of `samples` samples from `start` (s) at
    `period` (s) are too many (MAX_GAPS) or one is longer than the record's samples (separate records)."""
    if not gaps:
        return
    missing = np.array([m for _, m in gaps])
    if len(gaps) > MAX_GAPS:
        raise InputError(f'{source}: {len(gaps)} gaps (missing samples), more than the {MAX_GAPS} a record in '
                         f'segments may have, the first after t = {gap_time(gaps, 0, start, period):.6g} s: check '
                         f'the logger (or the time column)')
    j = int(np.argmax(missing))
    if missing[j] > samples:
        raise InputError(f'{source}: {missing[j]} samples are missing after t = {gap_time(gaps, j, start, period):.6g}'
                         f' s, more than the {samples} the record holds: these are separate records; identify each '
                         f'on its own (take one with --start S --end E)')


def gap_time(gaps, j, start, period):
    """The time (s) of the last sample before gap j of `gaps` ((sample, missing), ...) of a record from `start`."""
    return start + period * (gaps[j][0] - 1 + sum(m for _, m in gaps[:j]))


def listing(spans, period):
    """{'segments': [{start, end, samples}], 'gaps': [{start, end, missing}]} of a record's contiguous segments
    [(start time s, samples)], for the commands' JSON: times in s, each end the time after its last sample (a
    gap's span is its missing samples')."""
    segments = [{'start': float(t), 'end': float(t + n * period), 'samples': int(n)} for t, n in spans]
    gaps = [{'start': a['end'], 'end': b['start'], 'missing': int(round((b['start'] - a['end']) / period))}
            for a, b in zip(segments, segments[1:])]
    return {'segments': segments, 'gaps': gaps}


def shared(runs):
    """The runs that all of {name: runs} cover (the places every signal has a sample at)."""
    common = None
    for mine in runs.values():
        if common is None:
            common = [(a, b) for a, b in mine if a < b]
            continue
        both, j = [], 0
        for a, b in common:
            while j < len(mine) and mine[j][1] <= a:
                j += 1
            k = j
            while k < len(mine) and mine[k][0] < b:
                low, high = max(a, mine[k][0]), min(b, mine[k][1])
                if low < high:
                    both.append((low, high))
                k += 1
        common = both
    return common or []


def align(series, source):
    """One uniform grid for signals logged at their own times: {name: (t, values)} ->
    (period, start, {name: values on the grid}, sampling) where sampling says how (for the JSON).

    Signals at one rate are aligned sample by sample (their steady grids shifted by whole samples onto the
    latest start, cut to the span all of them cover): no value is interpolated. Signals at different rates
    are brought onto the fastest one's grid by linear interpolation. Signals that miss samples are refused:
    neither way keeps the record in segments.
    """
    grids = {name: steady_period(t, source, name) for name, (t, _) in series.items()}
    gapped = next((name for name, g in grids.items() if g[3]), None)
    if gapped is not None:
        period, start, _, gaps = grids[gapped]
        raise InputError(f'{source}: {gapped} misses samples ({len(gaps)} gap(s), the first after t = '
                         f'{gap_time(gaps, 0, start, period):.6g} s, {gaps[0][1]} sample(s) missing): signals '
                         f'mapped from their own topics are aligned only without gaps')
    fastest = min(grids, key=lambda name: grids[name][0])
    period = grids[fastest][0]
    jitter = max(g[2] for g in grids.values())
    if all(abs(g[0] - period) <= SAME_RATE * period for g in grids.values()):
        start = max(g[1] for g in grids.values())
        offsets = {name: round((start - g[1]) / period) for name, g in grids.items()}
        n = min(len(series[name][1]) - offsets[name] for name in series)
        if n < 2:
            raise InputError(f'{source}: the signals share no time span ({", ".join(series)})')
        values = {name: np.asarray(v, dtype=float)[offsets[name]:offsets[name] + n]
                  for name, (_, v) in series.items()}
        start = grids[fastest][1] + offsets[fastest] * period
        how = 'one rate: samples aligned by their times, none interpolated'
    else:
        # the fastest signal's own samples from the latest start on: only the slower ones are interpolated
        latest = max(g[1] for g in grids.values())
        start = grids[fastest][1] + np.ceil((latest - grids[fastest][1]) / period - 1e-9) * period
        end = min(g[1] + (len(series[name][1]) - 1) * g[0] for name, g in grids.items())
        n = int(np.floor((end - start) / period + 1e-9)) + 1
        if n < 2:
            raise InputError(f'{source}: the signals share no time span ({", ".join(series)})')
        grid = start + period * np.arange(n)
        values = {name: np.interp(grid, g[1] + g[0] * np.arange(len(series[name][1])),
                                  np.asarray(series[name][1], dtype=float)) for name, g in grids.items()}
        slower = sorted(name for name, g in grids.items() if g[0] > (1 + SAME_RATE) * period)
        how = f'{", ".join(slower)} interpolated linearly onto the {1 / period:.6g} Hz grid of {fastest}'
    sampling = {'period': period, 'jitter': jitter, 'how': how,
                'rates': {name: 1.0 / g[0] for name, g in grids.items()}}
    return period, start, values, sampling
