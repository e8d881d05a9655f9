"""Two limits every reader and writer of the suite shares.

Documents read whole (model files, ROS params files, `--observer-from` JSON) are small text files; one larger
than MAX_DOCUMENT_BYTES is refused in one line, checked with os.stat before a byte is read (a 3 GiB sparse file
took 22 s to refuse and an 8 GiB one ran out of memory), and so are devices, FIFOs and directories
(emla_core.files.regular_file).

A message's stamp (builtin_interfaces/Time) holds its seconds in a signed 32-bit integer, so the latest time it
can hold is 2^31 s - 1 ns after the epoch (2038-01-19 03:14:08 UTC); a later one would wrap to a negative
second. Every stamp the suite builds goes through check_stamp, which refuses it in one line instead.
"""
from __future__ import annotations

import os
from pathlib import Path

from emla_core.errors import InputError
from emla_core.files import regular_file

# Some thousand times what the suite itself writes: a model file is about 1 KiB, an identification's JSON
# about 2 KiB, the largest params file of a launch (a valve's resistance steps) about 14 KiB.
MAX_DOCUMENT_BYTES = 4 << 20
MAX_NESTING = 100   # levels of a document's collections (the suite's own have four); deeper is refused

STAMP_LIMIT_S = 2**31                              # s: the first time a stamp cannot hold
MAX_STAMP_NS = STAMP_LIMIT_S * 1_000_000_000 - 1   # ns: the last time it can
STAMP_LIMIT = f'{STAMP_LIMIT_S} s (2038-01-19 03:14:08 UTC)'


def read_document(path: Path | str, what: str) -> str:
    """The text of the document `what` (a 'model file', ...) at `path`, read whole once it is known to be a
    regular file of at most MAX_DOCUMENT_BYTES; InputError in one line naming the path otherwise (missing,
    unreadable, not a regular file, too large, not UTF-8)."""
    path = Path(path)
    try:
        os.stat(path)
    except FileNotFoundError:
        raise InputError(f'{path}: no such {what}') from None
    except OSError:
        pass   # regular_file says what
    except ValueError:   # a NUL byte in it
        raise InputError(f'{str(path)!r}: not a path (it holds a NUL character)') from None
    regular_file(path, what, MAX_DOCUMENT_BYTES)
    try:
        with path.open('rb') as f:
            data = f.read(MAX_DOCUMENT_BYTES + 1)   # a file grown since the check is not read on
    except OSError as exc:
        raise InputError(f'{path}: cannot read: {exc.strerror or exc}') from None
    if len(data) > MAX_DOCUMENT_BYTES:
        raise InputError(f'{path}: more than the {MAX_DOCUMENT_BYTES >> 20} MiB a {what} may have')
    try:
        return data.decode('utf-8-sig')
    except UnicodeDecodeError as exc:
        raise InputError(f'{path}: not UTF-8 text (byte {exc.start}); a {what} is text') from None


def check_stamp(ns: int, what: str = 'a time') -> int:
    """`ns` (an int of nanoseconds) if a message's stamp can hold it (0 to MAX_STAMP_NS); InputError in one
    line naming `what` and the limit otherwise."""
    if not 0 <= ns <= MAX_STAMP_NS:
        raise InputError(f'{what} of {ns * 1e-9:.10g} s cannot be stamped: a ROS time stamp holds 0 to '
                         f'{STAMP_LIMIT} (a signed 32-bit second)')
    return ns
