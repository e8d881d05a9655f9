"""The recordings of a fleet: finding them (files, directories, globs), the time each is placed at in the trend
(recording_time: its first sample's, its file's modification time, a column or a date in its name) and
identifying one, as `emla identify` does, in a function a Dask worker runs: a path and plain options in, plain
data out (it pickles to any worker).
"""
import glob
import math
import os
import re
from collections.abc import Iterable, Mapping
from datetime import datetime, timezone
from pathlib import Path

from emla_core.errors import InputError
from emla_core.recording import Recording

RECORDING_SUFFIXES = ('.csv', '.mat', '.mcap')  # files taken from a directory; a bag directory is one recording
BAG_MARKER = 'metadata.yaml'
DATA_FLAGS = ('columns', 'units', 'topics', 'sample_period', 'delimiter', 'decimal')
GREYBOX_MODELS = ('full', 'electrical', 'mechanical')
GLOB_CHARACTERS = '*?['
TIMED_SUFFIXES = ('.mcap', '.db3')   # bag files: their samples' times are stamps, whatever the layout
TIME_FROM = 'start, mtime, column:NAME or pattern:FORMAT'   # the forms of recording_time's `how`, for messages
# The digits each %X of a --time-from pattern takes (the group X of the regular expression it becomes).
PATTERN_FIELDS = {'Y': r'\d{4}', 'm': r'\d{2}', 'd': r'\d{2}', 'H': r'\d{2}', 'M': r'\d{2}', 'S': r'\d{2}',
                  'f': r'\d{1,9}', 's': r'\d+(?:\.\d+)?'}


def find_recordings(paths: Iterable[str | Path]) -> list[str]:
    """The recordings that `paths` name, each once, in the order given (a directory's sorted).

    Parameters
    ----------
    paths : iterable of str or Path
        Recordings (CSV, MAT or .mcap files, bag directories), directories holding them (searched at any depth;
        a bag directory is one recording) or glob patterns of either ('runs/*.csv', 'fleet/**/run_*').

    Returns
    -------
    list of str
        The recordings' paths as found (relative where the argument was).

    Raises
    ------
    InputError
        A path that does not exist and matches nothing, or no recording found at all.
    """
    found, seen = [], set()
    for given, matches in expand_paths(paths):
        for match in matches:
            for path in _recordings_in(Path(match), explicit=match == given):
                key = os.path.realpath(path)
                if key not in seen:
                    seen.add(key)
                    found.append(str(path))
    if not found:
        raise InputError(f'no recordings (CSV, MAT or .mcap files, bag directories) in {", ".join(map(str, paths))}')
    return found


def expand_paths(paths: Iterable[str | Path]) -> list[tuple[str, list[str]]]:
    """(given, matches) of each of `paths`: itself when it exists, else the files and directories its glob pattern
    matches (sorted); what find_recordings searches. InputError for a path that is neither."""
    expanded = []
    for given in paths:
        given = str(given)
        if os.path.exists(given):
            matches = [given]
        elif any(c in given for c in GLOB_CHARACTERS):
            matches = sorted(glob.glob(given, recursive=True))
            if not matches:
                raise InputError(f'{given}: no file or directory matches this pattern')
        else:
            raise InputError(f'{given}: no such file or directory')
        expanded.append((given, matches))
    return expanded


def _recordings_in(path, explicit):
    """The recordings at `path`: itself (a file given by name, a bag), or those in a directory."""
    if path.is_dir():
        if (path / BAG_MARKER).is_file():
            return [path]
        inside = []
        for root, directories, files in os.walk(path):
            directories.sort()
            if BAG_MARKER in files:   # a bag: one recording, not its files
                inside.append(Path(root))
                directories.clear()
                continue
            inside += [Path(root) / name for name in sorted(files)
                       if name.lower().endswith(RECORDING_SUFFIXES) and not name.startswith('.')]
        return inside
    if explicit or path.name.lower().endswith(RECORDING_SUFFIXES):
        return [path]
    return []


def recording_time(path: str | Path, how: str = 'start', recording: Recording | None = None) -> float | None:
    """The time (s) a recording is placed at in a trend: what orders the recordings and is their plot's abscissa.

    Parameters
    ----------
    path : str or Path
        The recording (file or bag directory).
    how : str, optional
        Where the time comes from (`emla trend --time-from`):

        - 'start' (default): its first sample's time, from a bag's stamps (the wall clock) or a CSV or MAT
          file's time column (which often begins at 0 in every file: the same time for all); None for data
          without a time (a --sample-period).
        - 'mtime': the path's modification time (os.stat; a bag directory's own), s since 1970.
        - 'column:NAME': the first value of the CSV column NAME (one not read as a signal: the header's name as
          written), an absolute time in s.
        - 'pattern:FORMAT': a date and time in the file's name (a bag directory's), for files that all begin at
          0: FORMAT is a regular expression searched in the name, in which %Y (4 digits), %m %d %H %M %S (2
          each), %f (the digits of a fraction of a second) and %s (s since 1970, the others then unused) stand
          for the digits they take, %% for a %; the date is read as UTC. 'run_%Y%m%dT%H%M%S' gives
          run_20240131T120000.csv 2024-01-31 12:00:00; groups of the regular expression named Y, m, d, H, M,
          S, f or s do as the letters do ('(?P<Y>[0-9]{4})').
    recording : Recording, optional
        The record as read (the data flags and window applied), for 'start' and 'column': the window's first
        sample and row. Default: read with emla_core.load's defaults.

    Returns
    -------
    float or None
        The time in s (since 1970, or on the record's own axis for 'start' with a time column); None only for
        'start' and data without a time.

    Raises
    ------
    InputError
        `how` of another form, a pattern with no date in it or a name it does not match (or that names no
        date), a column the file does not have.
    """
    kind, argument = _time_source(how)
    if kind == 'mtime':
        return os.stat(path).st_mtime
    if kind == 'pattern':
        return _named_time(Path(path).name, _pattern(argument, how), how)
    if recording is None:
        from emla_core.data import load
        recording = load(path, gaps=True)
    if kind == 'column':
        return _column_time(recording, argument, how)
    timed = 't' in (recording.inputs or {}) or Path(path).is_dir() or Path(path).suffix in TIMED_SUFFIXES
    return float(recording.start_time) if timed else None


def check_time_from(how: str, paths: Iterable[str | Path]) -> None:
    """InputError in one line, before any recording is read, when `how` is not a form of recording_time's or is
    a pattern that one of `paths`' names does not match (the first such named, and how many)."""
    kind, argument = _time_source(how)
    if kind != 'pattern':
        return
    pattern = _pattern(argument, how)
    missed = [str(path) for path in paths if not pattern.search(Path(path).name)]
    if missed:
        raise InputError(f'--time-from {how}: {len(missed)} recording name(s) do not match it, the first '
                         f'{Path(missed[0]).name} ({missed[0]})')


def _time_source(how):
    """(kind, argument) of a `how` of recording_time: ('start', ''), ('column', NAME) ...; InputError otherwise."""
    kind, colon, argument = str(how).partition(':')
    if (kind in ('start', 'mtime') and not colon) or (kind in ('column', 'pattern') and argument):
        return kind, argument
    raise InputError(f'--time-from {how}: give {TIME_FROM}')


def _pattern(text, how):
    """The compiled regular expression of a pattern's FORMAT: each %X of PATTERN_FIELDS a group named X of its
    digits, %% a %; InputError for another %X, a FORMAT that is no regular expression or gives no date."""
    def field(match):
        letter = match[1]
        if letter == '%':
            return '%'
        if letter not in PATTERN_FIELDS:
            raise InputError(f'--time-from {how}: %{letter} is none of %{" %".join(PATTERN_FIELDS)} (%% for a %)')
        return f'(?P<{letter}>{PATTERN_FIELDS[letter]})'

    try:
        regex = re.compile(re.sub('%(.?)', field, text))
    except re.error as exc:
        raise InputError(f'--time-from {how}: not a regular expression ({exc})') from None
    if not {'Y', 's'} & set(regex.groupindex):
        raise InputError(f'--time-from {how}: no date in it: put %Y (with %m %d %H %M %S) or %s in it')
    return regex


def _named_time(name, pattern, how):
    """The time (s since 1970) a pattern finds in a name: its %s, else the UTC date of its other fields."""
    match = pattern.search(name)
    if match is None:
        raise InputError(f'{name}: the name does not match --time-from {how}')
    fields = {key: value for key, value in match.groupdict().items() if key in PATTERN_FIELDS and value}
    if 's' in fields:
        return float(fields['s'])
    try:
        stamp = datetime(int(fields['Y']), int(fields.get('m', 1)), int(fields.get('d', 1)), int(fields.get('H', 0)),
                         int(fields.get('M', 0)), int(fields.get('S', 0)), tzinfo=timezone.utc)
    except (KeyError, ValueError) as exc:   # an optional group that took nothing, a 13th month
        raise InputError(f'{name}: no date by --time-from {how} ({exc})') from None
    return stamp.timestamp() + float('0.' + fields.get('f', '0'))


def _column_time(recording, name, how):
    """The first value of the column `name` of a record as read (its window's first row): one of the columns
    emla_core.load keeps beside the signals; InputError listing those when it has none of that name."""
    others = [column for column in recording.signals if column not in recording.inputs]
    if name not in others:
        raise InputError(f'{recording.source}: --time-from {how}: no such column beside the signals (has '
                         f'{", ".join(others) or "none"})')
    return float(recording.signals[name][0])


def identify_recording(path: str, options: Mapping | None = None) -> dict:
    """One recording identified as `emla identify` identifies it (the grey-box model, or a model file's
    structure), for a trend: the function each Dask worker runs.

    Parameters
    ----------
    path : str
        The recording (file or bag directory), as the worker can open it.
    options : dict, optional
        'actuator' (moving_coil, the default, or solenoid: emla_identification.solenoid's R, L0, a, g0, m, B, k,
        F0), 'model' (full, electrical or mechanical; default: from the signals), 'structure' (an
        emla_core.model_file.Model whose effects are identified too, or None), 'model_file' (its name, for
        messages), 'source' (the path to report, default `path`), 'time_from' (recording_time's `how`, default
        'start'), 'start' and 'end' (the window, s on the record's own time axis, as `emla identify --start
        --end`) and the data flags of emla_core.load (columns, units, topics, sample_period, delimiter, decimal).
        A record with missing samples is identified in segments by the grey-box models, as `emla identify`
        does (none of its rows spans a gap); a solenoid's or a model file's structure refuses it, as there.

    Returns
    -------
    dict
        {'path', 'start' (s: the recording's time, recording_time's: by default the first sample's, from the
        bag's stamps or the file's time column; None when the data have no time), 'duration' (s), 'parameters',
        'std' ({name: SI value}; a model file's effects' parameters beside the nominal ones), 'fit' (per
        equation, as `emla identify`), 'warnings' (lines), 'truth' ({name: value} a simulated recording carries,
        else {})}; or {'path', 'error': one line} when the recording cannot be identified. Never raises for a
        bad recording.
    """
    options = dict(options or {})
    source = options.get('source') or path
    try:
        record = _identified(path, options)
    except InputError as exc:
        return {'path': source, 'error': _one_line(str(exc))}
    except Exception as exc:  # noqa: BLE001 - any failure is this recording's, and the others go on
        return {'path': source, 'error': _one_line(f'{type(exc).__name__}: {exc}')}
    return {'path': source, **record}


def _one_line(text):
    lines = [line.strip() for line in str(text).splitlines() if line.strip()]
    return ' '.join(lines) if lines else 'failed without a message'


def _identified(path, options):
    """The identification of `path` (see identify_recording), raising on a bad recording."""
    from emla_core.bag.report import read_warnings
    from emla_core.data import load

    from ..greybox import identify
    from ..plausibility import plausibility_warnings
    from ..streaming import identify_chunks, read_record

    flags = {name: options.get(name) for name in DATA_FLAGS}
    window = {'start': options.get('start'), 'end': options.get('end')}
    structure = options.get('structure')
    how = options.get('time_from') or 'start'

    def loaded(where, gaps=False):
        return load(where, **flags, **window, gaps=gaps)

    with read_warnings() as lost:
        if options.get('actuator') == 'solenoid':
            from ..solenoid import identify_solenoid
            recording = loaded(path)
            result = identify_solenoid(recording)
            parameters, std = dict(result.parameters), dict(result.std)
            fit, samples = {name: f.to_dict() for name, f in result.fit.items()}, result.samples
            warnings = list(lost) + result.warnings() + _unknown(parameters, std)
            return _record(path, how, recording, samples, parameters, std, fit, warnings)
        if structure is not None and structure.effects:
            from ..model import identified_structure
            recording = loaded(path)
            result, _ = identified_structure(structure, recording, path, 'emla trend',
                                             options.get('model_file') or 'model file')
            parameters, std = dict(result['parameters']), dict(result['std'])
            for effect in result['effects']:
                for name, value in effect['parameters'].items():
                    key = name if name not in parameters else f'{effect["effect"]}.{name}'
                    parameters[key], std[key] = value, effect['std'][name]
            fit, found, samples = {}, [], len(recording)
        else:
            plain = all(value is None for value in flags.values())
            recording, parts = read_record(path, lambda where: loaded(where, gaps=True), plain=plain, **window)
            model = options.get('model')
            result = (identify(recording, model, points=1) if parts is None
                      else identify_chunks(parts, model, points=1))
            parameters, std = dict(result.parameters), dict(result.std)
            fit = {name: f.to_dict() for name, f in result.fit.items()}
            found, samples = result.warnings(), result.samples
        found = plausibility_warnings(parameters, std, recording) + found + _unknown(parameters, std)
        warnings = list(lost) + found
    return _record(path, how, recording, samples, parameters, std, fit, warnings)


def _record(path, how, recording, samples, parameters, std, fit, warnings):
    """identify_recording's result but its path; its 'start' the recording's time as `how` says (recording_time)."""
    return {'start': recording_time(path, how, recording),
            'duration': samples * recording.sample_period, 'parameters': parameters, 'std': std, 'fit': fit,
            'warnings': warnings, 'truth': recording.truth(parameters)}


def _unknown(parameters, std):
    """A warning for each figure that is not a finite number (null in the JSON), as `emla identify` gives."""
    return [f'{kind}.{name} cannot be computed from these data (null in the JSON)'
            for kind, values in (('parameters', parameters), ('std', std)) for name, value in values.items()
            if not (isinstance(value, (int, float)) and math.isfinite(value))]
