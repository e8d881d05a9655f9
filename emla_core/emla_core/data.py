"""Loading measured data into a Recording, whatever file it comes in and whatever the user called things.

Files: CSV (a header row), MATLAB .mat (v5 or v7.3; variables as vectors), rosbag2 directories (MCAP or
sqlite3) and bare .mcap files. Columns (or variables) are matched to the suite's signals (t, voltage,
current, position, velocity, force) by `columns` ('NAME=SOURCE,...'), else by their names (also the usual
short ones: time, u, i, x, v, f); units come from `units` ('NAME=UNIT,...'), else from the header
('x_mm', 'x [mm]', 'x (mm)'), else SI. What was understood is kept in `recording.inputs` and how time was
read in `recording.sampling`, for the commands' JSON. Values beyond MAX_MAGNITUDE in SI are refused.
"""
from pathlib import Path

import numpy as np

from emla_core.errors import InputError
from emla_core.files import path_kind
from emla_core.recording import Recording
from emla_core.sampling import steady_period
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
         sample_period: float | None = None, delimiter: str | None = None, decimal: str | None = None) -> Recording:
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

    Returns
    -------
    Recording
        With `inputs` (signal -> source, unit, scale) and `sampling` (period, jitter) saying what was read.

    Raises
    ------
    InputError
        The file is missing or unreadable, or its data unusable (the message names the file and problem).
    """
    path = Path(path)
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
        return recording
    if mat:
        from emla_core.tables import mat_vectors, read_mat_columns
        vectors = mat_vectors(path)
        columns, units, period, given = _mat_period(path, vectors, columns, units, sample_period)
        chosen = _choose(vectors, columns, period, str(path))
        recording = from_columns(read_mat_columns(path, chosen.values()), str(path), columns=columns, units=units,
                                 sample_period=period, row='element', first=1)
        if given is not None:
            recording.inputs['t'] = given['input']
            recording.sampling['how'] = given['how']
        return recording
    return read_csv(path, columns=columns, units=units, sample_period=sample_period, delimiter=delimiter,
                    decimal=decimal)


def read_csv(path: Path | str, *, columns: str | None = None, units: str | None = None,
             sample_period: float | None = None, delimiter: str | None = None, decimal: str | None = None) -> Recording:
    """A Recording from a CSV file with a header row (see `load` for the mapping, units and CSV dialect)."""
    from emla_core.tables import read_csv_columns
    return from_columns(read_csv_columns(path, delimiter, decimal), str(path), columns=columns, units=units,
                        sample_period=sample_period, row='data row', first=1)


def from_columns(table, source, *, columns=None, units=None, sample_period=None, row='sample', first=0):
    """A Recording of named columns {name: array} (see `load`); `row`/`first` name places in messages."""
    chosen = _choose(table, columns, sample_period, source)
    given_units = parse_assignments('--units', units, ('t', *SIGNAL_NAMES), 'UNIT')
    unmapped = sorted(set(given_units) - set(chosen))
    if unmapped:
        raise InputError(f'{source}: --units names {", ".join(unmapped)}, which no column holds')
    inputs, values = {}, {}
    for signal, column in chosen.items():
        header_unit = split_header(column)[1]
        if signal in given_units:
            scale, unit, origin = *parse_unit(signal, given_units[signal]), '--units'
        elif header_unit is not None:
            try:
                scale, unit = parse_unit(signal, header_unit)
            except InputError as exc:
                raise InputError(f'{source}: column {column!r}: {exc}; give the unit with --units') from None
            origin = 'header'
        else:
            scale, unit, origin = 1.0, SIGNAL_UNITS[signal], 'SI (assumed)'
        inputs[signal] = {'source': column, 'unit': unit, 'scale': scale, 'unit_from': origin}
        values[signal] = _in_range(table[column], scale, source, f'column {column}', row, first)
    signals = {**{name: v for name, v in table.items() if name not in chosen.values()},
               **{name: v for name, v in values.items() if name != 't'}}
    if 't' in values:
        period, start, jitter = steady_period(values['t'], source, inputs['t']['source'], row, first)
    else:
        if not 0.0 < float(sample_period) < float('inf'):
            raise InputError(f'{source}: --sample-period must be a positive number of seconds, got {sample_period}')
        period, start, jitter = float(sample_period), 0.0, 0.0
    return Recording(sample_period=period, signals=signals, start_time=start, source=source, inputs=inputs,
                     sampling={'period': period, 'jitter': jitter})


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
    `first` name the place of one that is."""
    with np.errstate(over='ignore'):   # an overflow to inf is refused below
        values = raw * scale if scale != 1.0 else raw
    beyond = (values > MAX_MAGNITUDE) | (values < -MAX_MAGNITUDE)   # no temporary array of floats
    if beyond.any():
        k = int(np.argmax(beyond))
        given = f' ({raw[k]:.6g} times the unit factor {scale:g})' if scale != 1.0 else ''
        raise InputError(f'{source}: {what} at {row} {k + first} is {values[k]:.6g} in SI{given}, beyond the '
                         f'{MAX_MAGNITUDE:g} the suite computes with; check the data and its unit (--units)')
    return values


def _match(table, explicit, source, skip=()):
    """{signal: column}: the explicit ones, then columns whose name (unit aside) is the signal's or an alias
    (not for the signals in `skip`)."""
    for signal, column in explicit.items():
        if column not in table:
            raise InputError(f'{source}: --columns {signal}={column}: no such column (has {", ".join(table)})')
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


def as_recording(data=None, *, sample_period=None, start_time=0.0, **signals):
    """The Recording that `data` or the arrays `signals` describe: what the suite's functions accept as data.

    Parameters
    ----------
    data : Recording, str, Path or None
        A Recording (returned as it is), a file or bag to `load`, or None to build one from `signals`.
    sample_period : float, optional
        Sample period in s of the arrays; required with `signals`.
    start_time : float, optional
        Time of the first sample, s.
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
        if given:
            raise InputError(f'give either data or signal arrays, not both (got data and {", ".join(given)})')
        return data if isinstance(data, Recording) else load(data)
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
