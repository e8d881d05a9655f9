"""Loading measured data into a Recording, whatever file it comes in."""
from pathlib import Path

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
