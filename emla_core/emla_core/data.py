"""Loading measured data into a Recording, whatever file it comes in and whatever the user called things.

Files: CSV (a header row), MATLAB .mat (v5 or v7.3; variables as vectors), rosbag2 directories (MCAP or
sqlite3) and bare .mcap files. Columns (or variables) are matched to the suite's signals (t, voltage,
current, position, velocity, force) by `columns` ('NAME=SOURCE,...'), else by their names (also the usual
short ones: time, u, i, x, v, f); units come from `units` ('NAME=UNIT,...'), else from the header
('x_mm', 'x [mm]', 'x (mm)'), else SI. What was understood is kept in `recording.inputs` and how time was
read in `recording.sampling`, for the commands' JSON. Values beyond MAX_MAGNITUDE in SI are refused.

A window `start`/`end` (s, on the record's own time axis) keeps the samples from `start` on, before `end`: of a
CSV or MAT file the rows whose time is in it, as if the file had been cut there, before anything else is read
from them. A row that repeats the one before exactly (time and values: a logger that wrote it twice) is dropped
with a warning (in `recording.sampling['warnings']`); a time repeated with other values is refused. Samples
missing (emla_core.sampling) leave the record in segments (Recording.gaps), which `load` returns only when
asked to (`gaps=True`, for what identifies across them); else it refuses the record, naming the part to take.
"""
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from emla_core.errors import InputError
from emla_core.files import path_kind
from emla_core.recording import Recording
from emla_core.sampling import gap_time, row_number, steady_period
from emla_core.units import SIGNAL_NAMES, SIGNAL_UNITS, parse_assignments, parse_unit, split_header

# Column names (without their unit) taken for a signal when no --columns says otherwise; case is ignored.
ALIASES = {'t': ('t', 'time'), 'voltage': ('voltage', 'u'), 'current': ('current', 'i'),
           'position': ('position', 'x'), 'velocity': ('velocity', 'v'), 'force': ('force', 'f')}
# Scalar MATLAB variables taken as the sample period (s) or rate (Hz) of a file without a time vector.
PERIOD_NAMES = {'period': ('ts', 'dt'), 'rate': ('fs',)}
PERIOD_AGREEMENT = 1e-6   # relative difference of a given --sample-period from the file's own, refused beyond
BAG_SUFFIXES = ('.mcap', '.db3')
# Largest magnitude of a value in SI: no actuator signal comes near it, and squares and products of the
# identification's regressors stay far from float overflow.
MAX_MAGNITUDE = 1e100


def load(path: Path | str, *, columns: str | None = None, units: str | None = None, topics: str | None = None,
         sample_period: float | None = None, delimiter: str | None = None, decimal: str | None = None,
         start: float | None = None, end: float | None = None, gaps: bool = False) -> Recording:
    """A Recording of the data in a CSV file, MATLAB file, rosbag2 directory or .mcap file.

    Parameters
    ----------
    path : str or Path
        The file or bag directory.
    columns : str, optional
        'NAME=SOURCE[,NAME=SOURCE...]': which CSV column or MAT variable holds each signal NAME (t, voltage,
        current, position, velocity, force). Unnamed signals are found by their column names.
    units : str, optional
        'NAME=UNIT[,...]': each signal's unit (s, ms, us, m, mm, um, A, mA, V, mV, N, rad, deg, ... or a factor
        to SI); a leading minus flips the sign (current=-A). Wins over a unit in the column header.
    topics : str, optional
        'NAME=TOPIC[:FIELD[INDEX]][,...]' of a bag whose topics are not the suite's (see emla_core.bag.foreign).
    sample_period : float, optional
        Sample period in s for data without a time column.
    delimiter, decimal : str, optional
        Delimiter (',', ';', '|', 'tab') and decimal mark ('.', ',') of a CSV file, where the guess from its
        header and first rows is not enough.
    start, end : float, optional
        The window of the record to read (s, on its own time axis): the samples from `start` on, before `end`.
    gaps : bool, optional
        Whether a record with missing samples is returned in segments (Recording.gaps), for a caller that takes
        them (greybox.identify); by default it is refused.

    Returns
    -------
    Recording
        With `inputs` (signal -> source, unit, scale) and `sampling` (period, jitter) saying what was read.

    Raises
    ------
    InputError
        The file is missing or unreadable, its data unusable, or the window holds none of them (the message
        names the file and problem).
    """
    path = Path(path)
    _check_window(start, end)
    recording = _read(path, columns, units, topics, sample_period, delimiter, decimal, start, end)
    if recording.gaps and not gaps:
        raise _gapped(recording)
    return recording


def _read(path, columns, units, topics, sample_period, delimiter, decimal, start, end):
    """load's Recording, gaps and all."""
    kind = path_kind(path)
    if kind is None:
        raise InputError(f'{path}: no such file or directory')
    bag = kind == 'dir' or path.suffix in BAG_SUFFIXES
    mat = not bag and path.suffix.lower() == '.mat'
    tables, csv = 'CSV and MAT files; map bag topics with --topics', 'CSV files'
    for flag, value, applies, scope in (
            ('--columns', columns, not bag, tables), ('--sample-period', sample_period, not bag, tables),
            ('--topics', topics, bag, 'bags; map columns with --columns'),
            ('--delimiter', delimiter, not (bag or mat), csv), ('--decimal', decimal, not (bag or mat), csv)):
        if value is not None and not applies:
            raise InputError(f'{path}: {flag} applies to {scope}')
    if bag:
        from emla_core.bag.foreign import load_bag
        recording = load_bag(path, topics, units)
        for name, values in recording.signals.items():
            _in_range(values, 1.0, str(path), f'signal {name}', 'sample', 0)
        return window(recording, start, end)
    if mat:
        from emla_core.tables import mat_vectors, read_mat_columns
        vectors = mat_vectors(path)
        columns, units, period, given = _mat_period(path, vectors, columns, units, sample_period)
        chosen = _choose(vectors, columns, period, str(path))
        recording = from_columns(read_mat_columns(path, chosen.values()), str(path), columns=columns, units=units,
                                 sample_period=period, row='element', first=1, start=start, end=end)
        if given is not None:
            recording.inputs['t'] = given['input']
            recording.sampling['how'] = given['how']
        return recording
    return read_csv(path, columns=columns, units=units, sample_period=sample_period, delimiter=delimiter,
                    decimal=decimal, start=start, end=end, gaps=True)


def read_csv(path: Path | str, *, columns: str | None = None, units: str | None = None,
             sample_period: float | None = None, delimiter: str | None = None, decimal: str | None = None,
             start: float | None = None, end: float | None = None, gaps: bool = False) -> Recording:
    """A Recording from a CSV file with a header row (see `load` for the mapping, units, CSV dialect, window and
    gaps)."""
    from emla_core.tables import read_csv_columns
    recording = from_columns(read_csv_columns(path, delimiter, decimal), str(path), columns=columns, units=units,
                             sample_period=sample_period, row='data row', first=1, start=start, end=end)
    if recording.gaps and not gaps:
        raise _gapped(recording)
    return recording


def from_columns(table, source, *, columns=None, units=None, sample_period=None, row='sample', first=0, start=None,
                 end=None):
    """A Recording of named columns {name: array} (see `load`: its window `start`/`end` cuts the rows, and rows
    that repeat the one before are dropped); `row`/`first` name places in messages (`first`: the number of the
    first row). It has gaps (Recording.gaps) where the time skips samples."""
    chosen = _choose(table, columns, sample_period, source)
    given_units = parse_assignments('--units', units, ('t', *SIGNAL_NAMES), 'UNIT')
    unmapped = sorted(set(given_units) - set(chosen))
    if unmapped:
        raise InputError(f'{source}: --units names {", ".join(unmapped)}, which no column holds')
    inputs, scales = {}, {}
    for signal, column in chosen.items():
        header_unit = split_header(column)[1]
        if signal in given_units:
            scale, unit = parse_unit(signal, given_units[signal])
            origin = '--units'
        elif header_unit is not None:
            try:
                scale, unit = parse_unit(signal, header_unit)
            except InputError as exc:
                raise InputError(f'{source}: column {column!r}: {exc}; give the unit with --units') from None
            origin = 'header'
        else:
            scale, unit, origin = 1.0, SIGNAL_UNITS[signal], 'SI (assumed)'
        inputs[signal] = {'source': column, 'unit': unit, 'scale': scale, 'unit_from': origin}
        scales[signal] = scale
    numbers, sampling = first, {}   # the number of the first row, or of each row once rows were dropped
    if 't' in chosen:
        t = _in_range(table[chosen['t']], scales['t'], source, f'column {chosen["t"]}', row, first)
        rows = _window_rows(t, start, end, source)
        table, t, numbers = {name: v[rows] for name, v in table.items()}, t[rows], first + (rows.start or 0)
        table, kept, dropped = _without_repeats(table, chosen['t'], t, source, row, numbers)
        if dropped:
            t, numbers = t[kept], numbers + np.flatnonzero(kept)
            shown = ', '.join(map(str, dropped[:5])) + (', ...' if len(dropped) > 5 else '')
            sampling['warnings'] = [f'{source}: {len(dropped)} repeated row(s) dropped ({row} {shown}: the same time '
                                    f'and values as the row before)']
    values = {signal: _in_range(table[column], scales[signal], source, f'column {column}', row, numbers)
              for signal, column in chosen.items() if signal != 't'}
    signals = {**{name: v for name, v in table.items() if name not in chosen.values()}, **values}
    if 't' in chosen:
        period, start_time, jitter, gaps = steady_period(t, source, inputs['t']['source'], row, numbers)
    else:
        if not 0.0 < float(sample_period) < float('inf'):
            raise InputError(f'{source}: --sample-period must be a positive number of seconds, got {sample_period}')
        period, start_time, jitter, gaps = float(sample_period), 0.0, 0.0, ()
    recording = Recording(sample_period=period, signals=signals, start_time=start_time, source=source, inputs=inputs,
                          sampling={'period': period, 'jitter': jitter, **sampling}, gaps=gaps)
    return recording if 't' in chosen else window(recording, start, end)


def window(recording, start=None, end=None):
    """The samples of `recording` from `start` (s) on, before `end` (s) (None: from its first, to after its last);
    an InputError, naming the record's span, when there are none."""
    if start is None and end is None:
        return recording
    time = recording.time
    inside = np.flatnonzero(_within(time, start, end))
    if not len(inside):
        raise _outside(recording.source, start, end, *(time[[0, -1]] if len(time) else (math.nan, math.nan)))
    a, b = inside[0], inside[-1] + 1
    gaps = tuple((sample - a, missing) for sample, missing in recording.gaps if a < sample < b)
    return replace(recording, signals={name: v[a:b] for name, v in recording.signals.items()},
                   start_time=float(time[a]), gaps=gaps)


def window_parts(parts, start=None, end=None):
    """Consecutive parts of a record (Recordings without gaps, in time order: emla_core.bag.iter_chunks') cut to
    the window as `window` cuts a whole record; the parts after it are not read. An InputError, naming the
    record's span, when none of their samples is in it."""
    _check_window(start, end)
    if start is None and end is None:
        yield from parts
        return
    found, first, last, source = False, math.nan, math.nan, ''
    for part in parts:
        time, source = part.time, part.source
        if len(time):
            first, last = time[0] if math.isnan(first) else first, time[-1]
        if _within(time, start, end).any():
            found = True
            yield window(part, start, end)
        elif found:
            return
    if not found:
        raise _outside(source, start, end, first, last)


def _check_window(start, end):
    """An InputError unless the window's `start` is before its `end` (where both are given)."""
    if start is not None and end is not None and not start < end:
        raise InputError(f'--start {start:g} s must be before --end {end:g} s')


def _within(time, start, end):
    """Whether each time is from `start` on and before `end` (either None: unbounded)."""
    return (time >= (-np.inf if start is None else start)) & (time < (np.inf if end is None else end))


def _window_rows(t, start, end, source):
    """The slice of the rows from the first whose time `t` (s) is in the window to the last (all rows without one)."""
    if start is None and end is None:
        return slice(None)
    inside = np.flatnonzero(_within(t, start, end))
    if not len(inside):
        raise _outside(source, start, end, *(t[[0, -1]] if len(t) else (math.nan, math.nan)))
    return slice(inside[0], inside[-1] + 1)


def _outside(source, start, end, first, last):
    """The InputError of a window that holds no sample of a record whose samples run from `first` to `last` (s)."""
    span = f'the record runs from t = {first:.9g} to {last:.9g} s'
    if start is not None and start > last:
        return InputError(f'{source}: --start {start:g} s is after the end of the record ({span})')
    if end is not None and end <= first:
        return InputError(f'{source}: --end {end:g} s is not after the start of the record ({span})')
    low, high = -math.inf if start is None else start, math.inf if end is None else end
    return InputError(f'{source}: no samples from t = {low:g} to {high:g} s: they fall in a gap of the record ({span})')


def _without_repeats(table, time, t, source, row, first):
    """(table, kept, dropped) of a table without the rows that repeat the row before exactly: the table, which
    rows are kept (a mask), the numbers of those dropped (the first row's: `first`); an InputError where the time
    `t` (of column `time`) repeats with other values."""
    same = np.flatnonzero(t[1:] == t[:-1]) + 1
    if not len(same):
        return table, None, []
    equal = np.ones(len(same), dtype=bool)
    for values in table.values():
        now, before = values[same], values[same - 1]
        equal &= (now == before) | (np.isnan(now) & np.isnan(before))
    if not equal.all():
        k = same[np.argmax(~equal)]
        raise InputError(f'{source}: time is not increasing at {row} {first + k} ({time} = {t[k]:.9g} s again, '
                         f'with other values than the row before)')
    kept = np.ones(len(t), dtype=bool)
    kept[same] = False
    return {name: values[kept] for name, values in table.items()}, kept, (first + same).tolist()


def _gapped(recording):
    """The InputError of a record with gaps for a caller that takes none: where, and the longest part to take."""
    ts, gaps = recording.sample_period, recording.gaps
    longest = max(recording.segments(), key=len)
    return InputError(f'{recording.source}: {len(gaps)} gap(s) (missing samples), the first after t = '
                      f'{gap_time(gaps, 0, recording.start_time, ts):.6g} s ({gaps[0][1]} sample(s) missing); only '
                      f'the grey-box identification (emla identify) takes a record in segments: take a part '
                      f'without gaps with --start S --end E (the longest: --start '
                      f'{longest.start_time - ts / 2:.9g} --end {longest.start_time + (len(longest) - 0.5) * ts:.9g})')


def _mat_period(path, vectors, columns, units, sample_period):
    """(columns, units, sample period, how) of a MATLAB file without a time vector: the period of a scalar
    variable, the one `columns` maps to t (t=Ts) or else one named as in PERIOD_NAMES (Ts, dt: s; fs: Hz),
    in place of `sample_period` (which must agree with it within PERIOD_AGREEMENT). `columns` and `units`
    come back without their t (which the vectors do not hold); `how` is None where no scalar is used, else
    {'input', 'how'} for the recording's inputs['t'] and sampling."""
    from emla_core.tables import mat_scalars
    mapped = parse_assignments('--columns', columns, ('t', *SIGNAL_NAMES), 'SOURCE')
    given_units = parse_assignments('--units', units, ('t', *SIGNAL_NAMES), 'UNIT')
    if 't' in mapped and mapped['t'] in vectors:
        return columns, units, sample_period, None
    if 't' not in mapped:
        timed = 't' in _match(vectors, mapped, str(path), skip=() if sample_period is None else ('t',))
        found = {} if timed else mat_scalars(path, lambda name: _period_name(name) is not None)
        if not found:
            return columns, units, sample_period, None
    else:
        found = mat_scalars(path, lambda name: name == mapped['t'])
        if not found:
            return columns, units, sample_period, None      # _match names the missing column
    periods = {}
    for name, value in found.items():
        kind = _period_name(name) or 'period'
        unit = given_units.get('t', split_header(name)[1] if kind == 'period' else None)
        if kind == 'rate' and unit is not None:
            raise InputError(f'{path}: variable {name} is a sample rate in Hz; --units t does not apply to it')
        scale = parse_unit('t', unit)[0] if unit is not None else 1.0
        seconds = scale * value if kind == 'period' else 1.0 / value if value else float('inf')
        if not 0.0 < seconds < float('inf'):
            raise InputError(f'{path}: variable {name} = {value:g} is no sample {kind}: map a time vector with '
                             f'--columns t=NAME or give --sample-period S')
        periods[name] = (seconds, kind, unit, scale)
    first, (seconds, kind, unit, scale) = next(iter(periods.items()))
    for name, (other, *_) in periods.items():
        if abs(other - seconds) > PERIOD_AGREEMENT * seconds:
            raise InputError(f'{path}: variables {first} and {name} give different sample periods ({seconds:.9g} s, '
                             f'{other:.9g} s); choose one with --columns t=NAME')
    if sample_period is not None and abs(float(sample_period) - seconds) > PERIOD_AGREEMENT * seconds:
        hertz = ' Hz' if kind == 'rate' else ''
        raise InputError(f'{path}: --sample-period {float(sample_period):.9g} s disagrees with the file\'s '
                         f'{first} = {found[first]:.9g}{hertz} (a period of {seconds:.9g} s); '
                         f'leave --sample-period out to use {first}, or correct it')
    names = ', '.join(periods)
    if sample_period is not None:
        period, how = float(sample_period), f'--sample-period (agrees with MAT variable {names})'
        source = {'source': '--sample-period', 'unit': 's', 'scale': 1.0, 'unit_from': 'SI (assumed)'}
    else:
        period, how = seconds, f'sample period from MAT variable {names}'
        origin = '--units' if 't' in given_units else 'header' if unit is not None else 'SI (assumed)'
        source = {'source': first, 'unit': 'Hz' if kind == 'rate' else unit or 's', 'scale': scale,
                  'unit_from': origin}
    columns = ','.join(f'{k}={v}' for k, v in mapped.items() if k != 't') or None
    units = ','.join(f'{k}={v}' for k, v in given_units.items() if k != 't') or None
    return columns, units, period, {'input': source, 'how': how}


def _period_name(name):
    """'period' or 'rate' for a MATLAB variable named as a sample period or rate (PERIOD_NAMES), else None."""
    base = split_header(name)[0].lower()
    return next((kind for kind, names in PERIOD_NAMES.items() if base in names), None)


def _choose(names, columns, sample_period, source):
    """{signal: column} of the column `names` for the --columns mapping `columns` (see `_match`), with a time
    column unless there is a `sample_period`."""
    chosen = _match(names, parse_assignments('--columns', columns, ('t', *SIGNAL_NAMES), 'SOURCE'), source,
                    skip=('t',) if sample_period is not None else ())
    if 't' in chosen and sample_period is not None:
        raise InputError(f'{source}: give either a time column or --sample-period, not both')
    timed = [c for c in names if c not in chosen.values() and split_header(c)[0].lower() in ALIASES['t']]
    if timed and sample_period is not None and columns is None:   # unmapped, the period would overrule it unsaid
        raise InputError(f'{source}: column {timed[0]!r} holds the time; --sample-period is for data without one '
                         f'(or map the signals with --columns to leave it out)')
    if 't' not in chosen and sample_period is None:
        raise InputError(f'{source}: missing column t (time): map one with --columns t=NAME, or give '
                         f'--sample-period S (columns: {", ".join(names)})')
    return chosen


def _in_range(raw, scale, source, what, row, first):
    """`raw` * `scale` (the values in SI), once none is beyond MAX_MAGNITUDE in magnitude; `what`, `row` and
    `first` (the number of the first value, or the numbers of all) name the place of one that is."""
    with np.errstate(over='ignore'):   # an overflow to inf is refused below
        values = raw * scale if scale != 1.0 else raw
    beyond = (values > MAX_MAGNITUDE) | (values < -MAX_MAGNITUDE)   # no temporary array of floats
    if beyond.any():
        k = int(np.argmax(beyond))
        given = f' ({raw[k]:.6g} times the unit factor {scale:g})' if scale != 1.0 else ''
        raise InputError(f'{source}: {what} at {row} {row_number(first, k)} is {values[k]:.6g} in SI{given}, beyond '
                         f'the {MAX_MAGNITUDE:g} the suite computes with; check the data and its unit (--units)')
    return values


def _match(table, explicit, source, skip=()):
    """{signal: column}: the explicit ones, then columns whose name (unit aside) is the signal's or an alias
    (not for the signals in `skip`)."""
    explicit = {signal: _column_named(table, column, signal, source) for signal, column in explicit.items()}
    chosen = dict(explicit)
    for column in table:
        if column in explicit.values():
            continue
        name = split_header(column)[0].lower()
        for signal, aliases in ALIASES.items():
            if name in aliases and signal not in explicit and signal not in skip:
                if signal in chosen:
                    raise InputError(f'{source}: columns {chosen[signal]!r} and {column!r} both look like '
                                     f'{signal}; choose one with --columns {signal}=NAME')
                chosen[signal] = column
    return chosen


def _column_named(table, column, signal, source):
    """The column of `table` called `column`, or whose header is `column` with its unit (U_coil for
    'U_coil [V]'); InputError listing the columns when none or more than one is."""
    if column in table:
        return column
    matches = [name for name in table if split_header(name)[0] == column]
    if len(matches) == 1:
        return matches[0]
    raise InputError(f'{source}: --columns {signal}={column}: '
                     + (f'{" and ".join(matches)} both match' if matches else 'no such column')
                     + f' (has {", ".join(table)})')


def as_recording(data=None, *, sample_period=None, start_time=0.0, gaps=False, time=None, **signals):
    """The Recording that `data` or the arrays `signals` describe: what the suite's functions accept as data.

    Parameters
    ----------
    data : Recording, str, Path, pandas.DataFrame or None
        A Recording (returned as it is), a file or bag to `load`, a table of columns as a CSV file holds them
        (a DataFrame or {name: array}: headers with or without their unit, a time column `t` or `time` in s or
        `sample_period`), or None to build one from `signals`.
    sample_period : float, optional
        Sample period in s of the arrays; required with `signals` unless `time` is given.
    time : array_like, optional
        The samples' times in s (a steady rate; jitter, gaps and repeated rows as in a CSV file's time column).
    start_time : float, optional
        Time of the first sample, s.
    gaps : bool, optional
        Whether a file with missing samples is read in segments (`load`'s gaps), for a caller that takes them.
    **signals : array_like
        1-D arrays of equal length, named voltage (V), current (A), position (m), velocity (m/s) or force (N).

    Returns
    -------
    Recording

    Raises
    ------
    InputError
        Unknown signal names, arrays of different lengths, no data, or an unusable file.
    """
    given = {name: values for name, values in signals.items() if values is not None}
    if data is not None:
        if given or time is not None:
            raise InputError(f'give either data or signal arrays, not both (got data and '
                             f'{", ".join(given) or "time"})')
        if isinstance(data, Recording):
            return data
        if hasattr(data, 'columns') or isinstance(data, dict):   # a DataFrame, or {column: array}
            return _from_table(data, sample_period, gaps)
        return load(data, gaps=gaps)
    if time is not None:
        return _from_table(dict(given, t=time), sample_period, gaps)
    unknown = sorted(set(given) - set(SIGNAL_NAMES))
    if unknown:
        raise InputError(f'unknown signal(s) {", ".join(unknown)}; known: {", ".join(SIGNAL_NAMES)}')
    if not given:
        raise InputError(f'no data: give a Recording, a file, or arrays named {", ".join(SIGNAL_NAMES)}')
    if sample_period is None or not 0.0 < float(sample_period) < float('inf'):
        raise InputError(f'sample_period must be a positive number of seconds with signal arrays, '
                         f'got {sample_period!r}')
    arrays = {name: np.asarray(values, dtype=float).reshape(-1) for name, values in given.items()}
    return Recording(sample_period=float(sample_period), signals=arrays, start_time=float(start_time),
                     source='arrays')


def _from_table(table, sample_period, gaps):
    """as_recording of a table {column: array} or a DataFrame, read as a CSV file's columns (from_columns)."""
    names = [str(name) for name in table.keys()]
    if 'time' in names and 't' not in names:
        table = {('t' if str(k) == 'time' else str(k)): v for k, v in table.items()}
    columns = {str(name): np.asarray(table[name], dtype=float).reshape(-1) for name in table.keys()}
    recording = from_columns(columns, 'table', sample_period=sample_period)
    if recording.gaps and not gaps:
        raise InputError(f'table: samples are missing at {len(recording.gaps)} place(s); this command does not '
                         f'take a record in segments')
    return recording
