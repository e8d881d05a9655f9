"""What every reader of a user's file checks before it opens it: that it is a regular file of a size the suite
can read (a device such as /dev/zero reads forever, a FIFO without a writer blocks for ever, both through a
symlink as well).
"""
import os
import stat
from pathlib import Path

from emla_core.errors import InputError

# Larger inputs are refused in one line rather than read until memory runs out. 8 GiB holds a CSV of some
# 100 million samples; a bag's MCAP files are read in chunks and are not held whole, so they have no limit.
MAX_INPUT_BYTES = 8 << 30


def regular_file(path, what='file', limit=MAX_INPUT_BYTES):
    """`path` as a Path once it is known to be a regular file (symlinks followed) of at most `limit` bytes.

    Parameters
    ----------
    path : str or Path
        The file to read.
    what : str, optional
        What the file is, for the message ('CSV file', 'model file', ...).
    limit : int or None, optional
        Largest size in bytes; None for no limit.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        The path is missing, not a regular file (a directory, device, FIFO or socket), or too large.
    """
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise InputError(f'{path}: no such file') from None
    except OSError as exc:
        raise InputError(f'{path}: cannot read: {exc.strerror or exc}') from None
    if not stat.S_ISREG(mode):
        kind = ('a directory' if stat.S_ISDIR(mode) else 'a FIFO' if stat.S_ISFIFO(mode)
                else 'a device' if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else 'a socket' if stat.S_ISSOCK(mode)
                else 'not a regular file')
        raise InputError(f'{path}: is {kind}; the suite reads a {what} only from a regular file')
    size = path.stat().st_size
    if limit is not None and size > limit:
        unit, scale = ('GiB', 2**30) if limit >= 2**30 else ('MiB', 2**20)
        raise InputError(f'{path}: {size / scale:.1f} {unit} is more than the {limit / scale:.0f} {unit} a {what} '
                         f'may have')
    return path
