"""Loading measured data into a Recording, whatever file it comes in."""
from pathlib import Path

import numpy as np

from emla_core.errors import InputError
from emla_core.recording import read_csv


def load(path):
    """A Recording from a CSV file, a rosbag2 directory or a bare .mcap file.

    Parameters
    ----------
    path : str or Path
        A CSV file with a header row and a `t` column in seconds (uniform sampling), or a bag.

    Returns
    -------
    Recording

    Raises
    ------
    InputError
        The file is missing, unreadable, or its data are unusable (the message names the file and problem).
    """
    path = Path(path)
    if path.is_dir() or path.suffix == '.mcap':
        from emla_core.bag import read_bag
        return read_bag(path).recording
    if not path.exists():
        raise InputError(f'{path}: no such file or directory')
    return read_csv(path)


SIGNAL_NAMES = ('voltage', 'current', 'position', 'velocity', 'force')


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
    from emla_core.recording import Recording

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
        raise InputError(f'sample_period must be a positive number of seconds with signal arrays, got {sample_period!r}')
    arrays = {name: np.asarray(values, dtype=float).reshape(-1) for name, values in given.items()}
    return Recording(sample_period=float(sample_period), signals=arrays, start_time=float(start_time),
                     source='arrays')
