"""Outputs that appear complete under their name or not at all, one writer at a time, and replaced only where
emla wrote them.

Every output of a command (a file, or a directory: a bag, a report, a fleet) is built in a staging directory
beside its target, `.<name>.emla-partial` (a short hashed name where that would be too long), that holds the
output under its final name (so a bag's split files carry the bag's name). The command holds an flock(2) on
that directory from the moment it checks its outputs until it exits, and passes the lock on to a process
that writes for it (the recorder of `emla launch`): a second writer of the same output finds it locked and is
refused; a staging directory left unlocked by a killed writer is removed by the next command that writes in
the same directory.

An output is moved into place only when complete: a file by rename(2), a directory by exchanging it with the
previous one (renameat2 with RENAME_EXCHANGE, atomic), or where the filesystem cannot exchange, by moving the
previous one into the staging directory first (a writer killed between the two renames has the previous
output put back by the next one). Until then the previous output stays as it was.

A directory output holds MARKER: its kind and the files emla wrote into it. `--force` replaces a directory
only if its marker is of the same kind and it holds nothing else, so a file a user keeps in it is never removed.
"""
import atexit
import contextlib
import ctypes
import errno
import fcntl
import hashlib
import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from emla_core.errors import InputError

MARKER = '.emla-output'
SUFFIX = '.emla-partial'
OWNER = 'owner.json'      # in a staging directory: the writer's pid and the target's name
PREVIOUS = 'previous'     # in a staging directory: the previous output, moved aside (no atomic exchange)
NAME_MAX = 255            # bytes of one path component (Linux, most filesystems)
OUTPUT_KINDS = {'bag': 'a bag', 'report': 'a discrepancy report', 'fleet': 'a fleet of bags'}   # marker kinds
SHOWN = 3                 # foreign files named in a refusal


def cannot_write(path, exc):
    """The InputError of an OSError met writing `path`: one line with the system's words."""
    return InputError(f'{path}: cannot write: {exc.strerror or exc}')


def staging_path(target):
    """The staging directory of `target` (a Path), beside it."""
    name = f'.{target.name}{SUFFIX}'
    if len(os.fsencode(name)) > NAME_MAX:
        name = f'.{hashlib.sha256(os.fsencode(target.name)).hexdigest()[:16]}{SUFFIX}'
    return target.parent / name


@dataclass
class Reservation:
    """The right to write `target`: its staging directory, locked through the descriptor `fd`."""

    target: Path
    staging: Path
    fd: int

    @property
    def output(self) -> Path:
        """Where the output is built: the staging directory, under the target's own name."""
        return self.staging / self.target.name

    def clear(self):
        """Remove what was built (not the lock): a failed or published output."""
        _remove(self.output)

    def release(self):
        """Remove the staging directory, then let the lock go."""
        with contextlib.suppress(OSError):
            shutil.rmtree(self.staging)
        os.close(self.fd)


_held: dict = {}   # absolute target -> Reservation, for the life of the process (release_all ends them)
atexit.register(lambda: release_all())   # a caller of the commands' run() other than emla_cli.cli


def reserve(target):
    """The Reservation of `target` (this process's own if it holds one); InputError if another process writes it."""
    target = Path(os.path.abspath(target))
    if target in _held:
        return _held[target]
    try:
        sweep(target.parent)
        reservation = _take(target)
    except OSError as exc:
        raise cannot_write(target, exc) from None
    _held[target] = reservation
    return reservation


def _take(target):
    staging = staging_path(target)
    for _ in range(3):
        try:
            os.mkdir(staging)
        except FileExistsError:
            fd = _lock(staging)
            if fd is None:
                raise InputError(f'{target}: another emla command ({_owner(staging)}) is writing it; wait for it '
                                 f'to end or choose another path') from None
            _recover(staging, target, fd)
            continue
        fd = _lock(staging)
        if fd is None:   # taken for a stale one by a sweep between mkdir and flock: that writer goes on
            break
        reservation = Reservation(target, staging, fd)
        try:
            (staging / OWNER).write_text(json.dumps({'pid': os.getpid(), 'target': target.name}))
        except BaseException:   # a full disk, say: nothing left behind
            reservation.release()
            raise
        return reservation
    raise InputError(f'{target}: another emla command ({_owner(staging)}) is writing it; wait for it to end or '
                     f'choose another path')


def _lock(staging):
    """A descriptor of `staging` holding its exclusive lock, or None when another process holds it (or it went:
    what the caller then finds at the path is another writer's)."""
    try:
        fd = os.open(staging, os.O_RDONLY | os.O_DIRECTORY)
    except FileNotFoundError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        if os.fstat(fd).st_ino == os.stat(staging).st_ino:
            return fd
    except (BlockingIOError, FileNotFoundError):
        pass
    os.close(fd)
    return None


def _owner(staging):
    with contextlib.suppress(OSError, ValueError):
        return f'pid {json.loads((staging / OWNER).read_text())["pid"]}'
    return 'another process'


def _recover(staging, target, fd):
    """With the lock of a writer's staging directory that was left behind: put back the previous output it had
    moved aside (killed between the two renames of a replacement), then remove the rest."""
    try:
        previous = staging / PREVIOUS
        if previous.exists() and not os.path.lexists(target):
            os.rename(previous, target)
        shutil.rmtree(staging)
    finally:
        os.close(fd)


def sweep(directory):
    """Remove the staging directories that killed writers left in `directory` (those no process holds)."""
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return
    own = {r.staging for r in _held.values()}
    for entry in entries:
        if not (entry.name.startswith('.') and entry.name.endswith(SUFFIX)) or Path(entry.path) in own:
            continue
        staging = Path(entry.path)
        try:
            target = json.loads((staging / OWNER).read_text())['target']
        except (OSError, ValueError, KeyError, TypeError):
            continue   # not one of ours, or one being made
        fd = _lock(staging)
        if fd is not None:
            with contextlib.suppress(OSError):
                _recover(staging, staging.parent / target, fd)


def release_all():
    """End every reservation of this process (its staging directories removed)."""
    while _held:
        _held.popitem()[1].release()


def held_descriptors():
    """The locked descriptors of this process's reservations: a child process that writes an output for it
    keeps them open (Popen pass_fds), so the lock lasts as long as the writing does."""
    return tuple(r.fd for r in _held.values())


# ---- markers: what a directory output holds ----

def mark(directory, kind):
    """Write MARKER into the complete output `directory`: its kind and every file in it."""
    directory = Path(directory)
    files = sorted(str(p.relative_to(directory)) for p in directory.rglob('*') if not p.is_dir())
    with open(directory / MARKER, 'w') as f:
        json.dump({'emla_output': kind, 'files': files}, f)
        f.flush()
        os.fsync(f.fileno())


def replaceable(flag, path, kind):
    """InputError unless the existing directory `path` is a previous output of `kind` holding only its files."""
    try:
        marker = json.loads((path / MARKER).read_text())
        written, found = set(marker['files']), marker['emla_output']
    except (OSError, ValueError, KeyError, TypeError):
        raise InputError(f'{flag} {path}: --force replaces only an output emla wrote ({MARKER} in it), and this '
                         f'directory has none; move it or choose another path') from None
    if found != kind:
        raise InputError(f'{flag} {path}: holds {OUTPUT_KINDS.get(found, found)}, not {OUTPUT_KINDS[kind]}; '
                         f'choose another path')
    foreign = sorted(str(p.relative_to(path)) for p in path.rglob('*')
                     if not p.is_dir() and p.name != MARKER and str(p.relative_to(path)) not in written)
    if foreign:
        more = f' and {len(foreign) - SHOWN} more' if len(foreign) > SHOWN else ''
        raise InputError(f'{flag} {path}: holds files emla did not write ({", ".join(foreign[:SHOWN])}{more}); '
                         f'--force replaces only what emla wrote: move them or choose another path')


# ---- moving into place ----

def put_in_place(reservation):
    """Move the complete output of `reservation` to its target, in one step where the filesystem allows."""
    built, target = reservation.output, reservation.target
    if not (built.is_dir() and target.is_dir()):
        os.replace(built, target)
    elif not _exchange(built, target):
        previous = reservation.staging / PREVIOUS
        os.rename(target, previous)
        os.rename(built, target)
    _sync(target.parent)


_RENAME_EXCHANGE, _AT_FDCWD = 2, -100
_renameat2 = getattr(ctypes.CDLL(None, use_errno=True), 'renameat2', None)


def _exchange(a, b):
    """Swap the directories `a` and `b` atomically; False where the kernel or filesystem cannot."""
    if _renameat2 is None:
        return False
    if _renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(b))


def _sync(directory):
    """fsync a directory, so that the renames in it last through a power loss (where the filesystem allows)."""
    with contextlib.suppress(OSError):
        fd = os.open(directory, os.O_RDONLY | os.O_DIRECTORY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _remove(path):
    """Remove the file or directory tree at `path`, if there is one (a symlink itself, not what it points to)."""
    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path)
    elif os.path.lexists(path):
        os.remove(path)
