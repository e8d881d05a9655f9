"""The recordings of a fleet: finding them (files, directories, globs) and identifying one, as `emla identify`
does, in a function a Dask worker runs: a path and plain options in, plain data out (it pickles to any worker).
"""
import glob
import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path

from emla_core.errors import InputError

RECORDING_SUFFIXES = ('.csv', '.mat', '.mcap')  # files taken from a directory; a bag directory is one recording
BAG_MARKER = 'metadata.yaml'
DATA_FLAGS = ('columns', 'units', 'topics', 'sample_period', 'delimiter', 'decimal')
GREYBOX_MODELS = ('full', 'electrical', 'mechanical')
GLOB_CHARACTERS = '*?['


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
        messages), 'source' (the path to report, default `path`) and the data flags of emla_core.load
        (columns, units, topics, sample_period, delimiter, decimal).

    Returns
    -------
    dict
        {'path', 'start' (s: the first sample's time, from the bag's stamps or the file's time column; None when
        the data have no time), 'duration' (s), 'parameters', 'std' ({name: SI value}; a model file's effects'
        parameters beside the nominal ones), 'fit' (per equation, as `emla identify`), 'warnings' (lines),
        'truth' ({name: value} a simulated recording carries, else {})}; or {'path', 'error': one line} when the
        recording cannot be identified. Never raises for a bad recording.
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
    structure = options.get('structure')

    def loaded(where):
        return load(where, **flags)

    with read_warnings() as lost:
        if options.get('actuator') == 'solenoid':
            from ..solenoid import identify_solenoid
            recording = loaded(path)
            result = identify_solenoid(recording)
            parameters, std = dict(result.parameters), dict(result.std)
            fit, samples = {name: f.to_dict() for name, f in result.fit.items()}, result.samples
            warnings = list(lost) + result.warnings() + _unknown(parameters, std)
            return _record(path, recording, samples, parameters, std, fit, warnings)
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
            recording, parts = read_record(path, loaded, plain=plain)
            model = options.get('model')
            result = (identify(recording, model, points=1) if parts is None
                      else identify_chunks(parts, model, points=1))
            parameters, std = dict(result.parameters), dict(result.std)
            fit = {name: f.to_dict() for name, f in result.fit.items()}
            found, samples = result.warnings(), result.samples
        found = plausibility_warnings(parameters, std, recording) + found + _unknown(parameters, std)
        warnings = list(lost) + found
    return _record(path, recording, samples, parameters, std, fit, warnings)


def _record(path, recording, samples, parameters, std, fit, warnings):
    """identify_recording's result but its path."""
    timed = 't' in (recording.inputs or {}) or Path(path).is_dir() or Path(path).suffix in ('.mcap', '.db3')
    return {'start': float(recording.start_time) if timed else None,
            'duration': samples * recording.sample_period, 'parameters': parameters, 'std': std, 'fit': fit,
            'warnings': warnings, 'truth': recording.truth(parameters)}


def _unknown(parameters, std):
    """A warning for each figure that is not a finite number (null in the JSON), as `emla identify` gives."""
    return [f'{kind}.{name} cannot be computed from these data (null in the JSON)'
            for kind, values in (('parameters', parameters), ('std', std)) for name, value in values.items()
            if not (isinstance(value, (int, float)) and math.isfinite(value))]
