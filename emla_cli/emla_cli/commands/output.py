"""What the commands share for their output: JSON with non-finite numbers as null; outputs checked and
reserved before any work (never over an input, over an existing one only with --force, only as regular files
or directories, a directory only where emla wrote it); and outputs that appear complete under their name or
not at all, all of a command's together (each built in a staging directory beside it, then moved into place:
emla_cli.commands.staging)."""
import json
import math
import os
import stat
import sys
from pathlib import Path

import numpy as np

from emla_core.errors import InputError

from . import staging


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


# The kinds of directory output (staging.OUTPUT_KINDS): --force replaces a directory only if emla wrote it as this kind.
BAG, REPORT, FLEET = 'bag', 'report', 'fleet'
RELATIONS = {'same': 'is', 'inside': 'is inside', 'holds': 'contains'}
KINDS = {stat.S_IFREG: 'a regular file', stat.S_IFDIR: 'a directory', stat.S_IFCHR: 'a device',
         stat.S_IFBLK: 'a device', stat.S_IFIFO: 'a FIFO', stat.S_IFSOCK: 'a socket'}


def add_force_argument(parser, text='replace output files that exist already'):
    parser.add_argument('--force', action='store_true', help=text)


def check_outputs(files, inputs=(), force=False, directories=None):
    """Refuse, before a command reads its data, any output that would destroy an input or a file unasked, and
    reserve each output for this process (emla_cli.commands.staging: one writer at a time).

    Parameters
    ----------
    files : dict
        Flag (as the user wrote it: '--json') -> path, or None when not given, of each output written as a file.
    inputs : iterable
        Every path the command reads: data file or bag directory, model file, parameter file (None is skipped).
    force : bool
        Whether an existing output may be replaced.
    directories : dict, optional
        Flag -> (path or None, kind) of each output written as a directory (BAG, REPORT, FLEET): an existing one
        must be empty, or with `force` be a previous output of that kind that holds only what emla wrote.

    Raises
    ------
    InputError
        An output that is an input, lies inside an input directory or would contain an input; two outputs on
        one path (or one inside the other); an output that is or holds the working directory; an output file
        whose directory does not exist; one that exists and is not a regular file (a device, FIFO or
        directory; for a directory output, not a directory); an existing output without `force`, or one
        `force` may not replace; an output another emla command is writing.
    """
    outputs = [(flag, Path(path), None) for flag, path in files.items() if path is not None]
    outputs += [(flag, Path(path), kind) for flag, (path, kind) in (directories or {}).items()
                if path is not None]
    inputs = [Path(path) for path in inputs if path is not None]
    for k, (flag, path, _kind) in enumerate(outputs):
        for source in inputs:
            if relation := _relation(flag, path, source):
                raise InputError(f'{flag} {path}: {RELATIONS[relation]} the input {source}; an output never '
                                 f'replaces an input, choose another path')
        for other_flag, other, _ in outputs[:k]:
            if relation := _relation(flag, path, other):
                raise InputError(f'{flag} {path}: {RELATIONS[relation]} the output {other_flag} {other}; give each '
                                 f'output a path of its own')
        if _relation(flag, path, _working_directory()) in ('same', 'holds'):
            raise InputError(f'{flag} {path}: is or holds the working directory; run the command from outside it')
    for flag, path, kind in outputs:
        _check_existing(flag, path, kind, force)
        if kind is not None:
            try:
                path.parent.mkdir(parents=True, exist_ok=True)   # a directory output is made with its parents
            except OSError as exc:
                raise staging.cannot_write(f'{flag} {path}', exc) from None
        staging.reserve(path)


def _relation(flag, path, other):
    """'same', 'inside' or 'holds' (`path` is, lies inside or contains `other`), or None."""
    try:
        if os.path.exists(path) and os.path.exists(other) and os.path.samefile(path, other):
            return 'same'
        path, other = path.resolve(), other.resolve()
    except RuntimeError:   # Python 3.11's Path.resolve on a symbolic link loop
        raise InputError(f'{flag} {path}: cannot be resolved: a symbolic link loop') from None
    except OSError as exc:
        raise InputError(f'{flag} {path}: cannot be resolved: {exc.strerror or exc}') from None
    if path == other:
        return 'same'
    return 'inside' if other in path.parents else 'holds' if path in other.parents else None


def _working_directory():
    try:
        return Path(os.getcwd())
    except FileNotFoundError:
        raise InputError('the working directory no longer exists; cd to one that does') from None


def _check_existing(flag, path, kind, force):
    """InputError unless `path` is new (a file: in an existing directory) or may be replaced (see check_outputs)."""
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        if kind is None and not path.resolve().parent.is_dir():   # a directory is made with its parents
            raise InputError(f'{flag} {path}: its directory does not exist') from None
        return
    except OSError as exc:
        raise InputError(f'{flag} {path}: {exc.strerror or exc}') from None
    if not (stat.S_ISREG if kind is None else stat.S_ISDIR)(mode):
        raise InputError(f'{flag} {path}: is {_kind(mode)}; this output is written to a new or '
                         f'{"regular file" if kind is None else "empty directory"} only')
    if kind is not None and not any(path.iterdir()):
        return
    if not force:
        raise InputError(f'{flag} {path}: exists; choose another path, or --force to replace it')
    if kind is not None:
        staging.replaceable(flag, path, kind)


def stage(path, write, kind=None):
    """write(temporary): the output `path` built in its staging directory (a file, or with `kind` a directory the
    writer makes, then marked as emla's); its Reservation, or the exception with nothing left (an OSError as one
    line)."""
    reservation = staging.reserve(path)
    temporary = reservation.output
    try:
        reservation.clear()
        write(temporary)
        if kind is not None:
            staging.mark(temporary, kind)
    except BaseException as exc:
        reservation.clear()
        if isinstance(exc, OSError):
            raise staging.cannot_write(path, exc) from None
        raise
    return reservation


def publish(staged):
    """Move each staged output (Reservations of `stage`) into place, once every target is known to take it (a
    file only over a regular file, a directory over a directory); whatever is not moved is removed."""
    try:
        for reservation in staged:
            _check_target(reservation.output, reservation.target)
        for reservation in staged:
            try:
                staging.put_in_place(reservation)
            except OSError as exc:
                raise staging.cannot_write(reservation.target, exc) from None
    finally:
        discard(staged)


def write_output(path, write, kind=None):
    """stage and publish one output (see stage)."""
    publish([stage(path, write, kind)])


def discard(staged):
    """Remove what the staged outputs (Reservations) left in their staging directories."""
    for reservation in staged:
        reservation.clear()


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


def emit_json(data, path=None, files=()):
    """`data` as JSON to `path` (to stdout when None), with each (path, write) of `files` (None: not asked for)
    written by write(temporary), or (path, write, kind) for a directory (see stage): the outputs appear together
    and complete, or none does."""
    text = json_text(data)
    staged = []
    try:
        for target, write, *kind in (*files, (path, lambda temporary: Path(temporary).write_text(text))):
            if target is not None:
                staged.append(stage(target, write, *kind))
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
