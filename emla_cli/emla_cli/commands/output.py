"""What the commands share for their output: JSON with non-finite numbers as null; outputs checked before any
work (never over an input, over an existing one only with --force, only as regular files or directories);
and files that appear complete under their name or not at all, all of a command's together (each written to
a hidden name beside it, then renamed)."""
import json
import math
import os
import shutil
import stat
import sys
import tempfile
from pathlib import Path

import numpy as np

from emla_core.errors import InputError


def finite(value):
    """JSON-safe at any depth of dicts and lists: non-finite floats become null, numpy scalars Python ones."""
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def json_text(data):
    return json.dumps(finite(data), indent=2) + '\n'


# What a directory output holds once complete: --force replaces an existing directory only if it holds this.
BAG, REPORT = 'metadata.yaml', 'report.md'
RELATIONS = {'same': 'is', 'inside': 'is inside', 'holds': 'contains'}
KINDS = {stat.S_IFREG: 'a regular file', stat.S_IFDIR: 'a directory', stat.S_IFCHR: 'a device',
         stat.S_IFBLK: 'a device', stat.S_IFIFO: 'a FIFO', stat.S_IFSOCK: 'a socket'}


def add_force_argument(parser, text='replace output files that exist already'):
    parser.add_argument('--force', action='store_true', help=text)


def check_outputs(files, inputs=(), force=False, directories=None):
    """Refuse, before a command reads its data, any output that would destroy an input or a file unasked.

    Parameters
    ----------
    files : dict
        Flag (as the user wrote it: '--json') -> path, or None when not given, of each output written as a file.
    inputs : iterable
        Every path the command reads: data file or bag directory, model file, parameter file (None is skipped).
    force : bool
        Whether an existing output may be replaced.
    directories : dict, optional
        Flag -> (path or None, marker) of each output written as a directory (BAG, REPORT): an existing one
        must be empty, or with `force` hold the file `marker` (a previous output of the same kind).

    Raises
    ------
    InputError
        An output that is an input, lies inside an input directory or would contain an input; two outputs on
        one path (or one inside the other); an output file whose directory does not exist; one that exists and is
        not a regular file (a device, FIFO or directory; for a directory output, not a directory); an existing
        output without `force`.
    """
    outputs = [(flag, Path(path), None) for flag, path in files.items() if path is not None]
    outputs += [(flag, Path(path), marker) for flag, (path, marker) in (directories or {}).items()
                if path is not None]
    inputs = [Path(path) for path in inputs if path is not None]
    for k, (flag, path, _marker) in enumerate(outputs):
        for source in inputs:
            if relation := _relation(path, source):
                raise InputError(f'{flag} {path}: {RELATIONS[relation]} the input {source}; an output never '
                                 f'replaces an input, choose another path')
        for other_flag, other, _ in outputs[:k]:
            if relation := _relation(path, other):
                raise InputError(f'{flag} {path}: {RELATIONS[relation]} the output {other_flag} {other}; give each '
                                 f'output a path of its own')
    for flag, path, marker in outputs:
        _check_existing(flag, path, marker, force)


def _relation(path, other):
    """'same', 'inside' or 'holds' (`path` is, lies inside or contains `other`), or None."""
    if os.path.exists(path) and os.path.exists(other) and os.path.samefile(path, other):
        return 'same'
    path, other = path.resolve(), other.resolve()
    if path == other:
        return 'same'
    return 'inside' if other in path.parents else 'holds' if path in other.parents else None


def _check_existing(flag, path, marker, force):
    """InputError unless `path` is new (a file: in an existing directory) or may be replaced (see check_outputs)."""
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        if marker is None and not path.resolve().parent.is_dir():   # a directory is made with its parents
            raise InputError(f'{flag} {path}: its directory does not exist') from None
        return
    if not (stat.S_ISREG if marker is None else stat.S_ISDIR)(mode):
        raise InputError(f'{flag} {path}: is {_kind(mode)}; this output is written to a new or '
                         f'{"regular file" if marker is None else "empty directory"} only')
    if marker is not None and not any(path.iterdir()):
        return
    if not force:
        raise InputError(f'{flag} {path}: exists; choose another path, or --force to replace it')
    if marker is not None and not (path / marker).is_file():
        raise InputError(f'{flag} {path}: --force replaces only a previous output, and this directory holds no '
                         f'{marker}')


def stage(path, write):
    """write(temporary) to a hidden name beside `path` (a file, or a directory the writer makes); the temporary
    path, or the exception and nothing left (an OSError as InputError)."""
    path = Path(path)
    temporary = path.with_name(f'.{path.name}.{os.getpid()}{path.suffix}')   # same suffix: formats follow it
    try:
        write(temporary)
    except BaseException as exc:
        _remove(temporary)
        if isinstance(exc, OSError):
            raise InputError(f'{path}: cannot write: {exc.strerror or exc}') from None
        raise
    return temporary


def publish(staged):
    """Rename each staged (temporary, path) into place, once every target is known to take it (a file only
    over a regular file, a directory over a directory); whatever is not renamed is removed."""
    try:
        for temporary, path in staged:
            _check_target(temporary, path)
        for temporary, path in staged:
            try:
                _replace(temporary, Path(path))
            except OSError as exc:
                raise InputError(f'{path}: cannot write: {exc.strerror or exc}') from None
    finally:
        discard(staged)


def discard(staged):
    """Remove the temporaries of staged (temporary, path) pairs that are still there."""
    for temporary, _ in staged:
        _remove(temporary)


def _kind(mode):
    return KINDS.get(stat.S_IFMT(mode), 'not a regular file')


def _check_target(temporary, path):
    """InputError if `path` has become what a rename of `temporary` must not land on (since check_outputs)."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return
    if not (stat.S_ISDIR if os.path.isdir(temporary) else stat.S_ISREG)(mode):
        raise InputError(f'{path}: is now {_kind(mode)}; nothing was written')


def _replace(temporary, path):
    """os.replace, also of a directory over one that is not empty (a previous output: moved aside, then removed)."""
    if not (os.path.isdir(temporary) and path.is_dir() and any(path.iterdir())):
        os.replace(temporary, path)
        return
    aside = tempfile.mkdtemp(prefix=f'.{path.name}.old.', dir=path.parent)
    os.replace(path, aside)
    try:
        os.replace(temporary, path)
    except OSError:
        os.replace(aside, path)
        raise
    _remove(aside)


def _remove(path):
    """Remove the file or directory tree at `path`, if there is one (a symlink itself, not what it points to)."""
    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path)
    elif os.path.lexists(path):
        os.remove(path)


def emit_json(data, path=None, files=()):
    """`data` as JSON to `path` (to stdout when None), with each (path, write) of `files` (None: not asked for)
    written by write(temporary): the files appear together and complete, or none does."""
    text = json_text(data)
    staged = []
    try:
        for target, write in (*files, (path, lambda temporary: Path(temporary).write_text(text))):
            if target is not None:
                staged.append((stage(target, write), target))
    except BaseException:
        discard(staged)
        raise
    publish(staged)
    if path is None:
        write_stdout(text)


def write_stdout(text):
    """`text` on stdout, flushed; InputError if stdout cannot take it (a full disk, a closed pipe), and stdout then
    sent to /dev/null, so that the interpreter's last flush of what is left cannot fail again."""
    try:
        sys.stdout.write(text)
        sys.stdout.flush()
    except OSError as exc:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
        raise InputError(f'cannot write to stdout: {exc.strerror or exc}') from None


def replace_bag(path, force):
    """With `force`, remove the previous bag at `path` (check_outputs found it to be one), for a new one."""
    path = Path(path)
    if force and path.is_dir() and any(path.iterdir()):
        _remove(path)
