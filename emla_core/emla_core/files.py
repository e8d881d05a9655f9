"""What every reader of a user's file checks before it opens it: that it is a regular file of a size the suite
can read (a device such as /dev/zero reads forever, a FIFO without a writer blocks for ever, both through a
symlink as well).
"""
import errno
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
        raise InputError(f'{path}: cannot read: {os_reason(path, exc)}') from None
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


def path_kind(path):
    """'dir', 'file' (anything else that exists: a file, device, FIFO...) or None where `path` does not exist
    (symlinks followed), as Path.is_dir and Path.exists tell it, but a path that cannot be looked up at all (a
    name longer than the file system takes, a loop of symlinks, a folder that may not be searched) is an
    InputError in one line rather than an OSError."""
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:
        raise InputError(f'{path}: cannot look it up: {os_reason(path, exc)}') from None
    except ValueError:   # a NUL byte in it
        raise InputError(f'{str(path)!r}: not a path (it holds a NUL character)') from None
    return 'dir' if stat.S_ISDIR(mode) else 'file'


def os_reason(path, exc):
    """The reason of an OSError about `path` in words: for a name too long, which part and the limit."""
    if exc.errno == errno.ENAMETOOLONG:
        longest = max(Path(path).parts, key=len, default='')
        limit = _name_max(path)
        if len(longest) > limit:
            return (f'a name in it has {len(longest)} characters, more than the {limit} a file name may have '
                    f'({longest[:24]}...)')
        return f'the path has {len(str(path))} characters, more than the file system takes'
    return exc.strerror or str(exc)


def _name_max(path):
    """The longest file name (bytes) the file system of `path`'s nearest existing folder takes; 255 if unknown."""
    folder = Path(os.path.abspath(path))
    for parent in folder.parents:
        try:
            return os.pathconf(parent, 'PC_NAME_MAX')
        except (OSError, ValueError):
            continue
    return 255
