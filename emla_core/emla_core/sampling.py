"""Logged times onto one uniform grid: the steady rate behind jittered timestamps, gaps named, signals of
different times or rates aligned.

A data-acquisition clock samples at a steady rate, but the host that logs the samples stamps them late by a
varying delay (+-5 % of the period is common over USB or Ethernet). Such timestamps are taken as the steady
rate they jitter around (up to JITTER_LIMIT); a missing sample shows as a step of about two periods and is a
gap, which is named and never bridged.
"""
import numpy as np

from emla_core.errors import InputError

JITTER_LIMIT = 0.25  # of the period: steps this close to it are jitter (stamps jittering by +-10 % of the
                     # period make steps up to 20 % off)
GAP_FACTOR = 1.5    # steps beyond this many periods are missing samples
SAME_RATE = 1e-3    # relative difference of periods below which signals share one rate


def steady_period(t, source, what='t', row='sample', first=0):
    """(period, start, jitter) of increasing times `t` (s) of a steadily sampled signal.

    period: the median step; start: the time of sample 0 on the steady grid that fits `t` best (so the
    grid is not shifted by the jitter of the first stamp); jitter: the largest |step - period| / period.
    InputError for too few samples, times that do not increase, gaps and jitter beyond JITTER_LIMIT; it
    names the place as `row` number (index + `first`), e.g. 'data row' 2 for a CSV file's first step.
    """
    t = np.asarray(t, dtype=float)
    if len(t) < 2:
        raise InputError(f'{source}: needs at least two samples of {what}')
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        raise InputError(f'{source}: time is not increasing at {row} {first + k + 1} '
                         f'({what} = {t[k + 1]:.9g} s after {t[k]:.9g} s)')
    period = float(np.median(steps))
    gaps = np.flatnonzero(steps > GAP_FACTOR * period)
    if len(gaps):
        k = gaps[0]
        missing = round(steps[k] / period) - 1
        raise InputError(f'{source}: {len(gaps)} gap(s) in {what}, the first after t = {t[k]:.6g} s '
                         f'(about {missing} sample(s) missing); a record is not bridged across missing samples: '
                         f'identify the parts before and after it separately')
    deviation = np.abs(steps - period) / period
    if deviation.max() > JITTER_LIMIT:
        k = int(np.argmax(deviation))
        raise InputError(f'{source}: sampling is not uniform at {row} {first + k + 1} (step {steps[k]:.6g} s, '
                         f'steady step {period:.6g} s; steps up to {JITTER_LIMIT:.0%} off are taken as jitter)')
    k = np.arange(len(t)) - (len(t) - 1) / 2          # the steady grid that fits the stamps best
    period = float(k @ (t - t.mean()) / (k @ k))
    start = float(t.mean() - period * (len(t) - 1) / 2)
    jitter = float(np.max(np.abs(t - start - period * np.arange(len(t))))) / period
    return period, start, jitter


def align(series, source):
    """One uniform grid for signals logged at their own times: {name: (t, values)} ->
    (period, start, {name: values on the grid}, sampling) where sampling says how (for the JSON).

    Signals at one rate are aligned sample by sample (their steady grids shifted by whole samples onto the
    latest start, cut to the span all of them cover): no value is interpolated. Signals at different rates
    are brought onto the fastest one's grid by linear interpolation.
    """
    grids = {name: steady_period(t, source, name) for name, (t, _) in series.items()}
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
