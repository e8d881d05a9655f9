"""What the commands share for their output: JSON with non-finite numbers as null, and files that appear
complete under their name or not at all (written to a hidden name beside it, then renamed)."""
import json
import math
import os
import shutil
import sys
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


def stage(path, write):
    """write(temporary) to a hidden file beside `path`; the temporary path, or InputError and nothing left."""
    path = Path(path)
    temporary = path.with_name(f'.{path.name}.{os.getpid()}{path.suffix}')   # same suffix: formats follow it
    try:
        write(temporary)
    except OSError as exc:
        if temporary.exists():
            temporary.unlink()
        raise InputError(f'{path}: cannot write: {exc.strerror or exc}') from None
    return temporary


def publish(staged):
    """Rename each staged (temporary, path) into place; whatever is not renamed is removed."""
    try:
        for temporary, path in staged:
            try:
                os.replace(temporary, path)
            except OSError as exc:
                raise InputError(f'{path}: cannot write: {exc.strerror or exc}') from None
    finally:
        discard(staged)


def discard(staged):
    """Remove the temporaries of staged (temporary, path) pairs that are still there."""
    for temporary, _ in staged:
        if os.path.exists(temporary):
            os.remove(temporary)


def write_file(path, write):
    """write(temporary) then rename to `path`."""
    publish([(stage(path, write), path)])


def emit_json(data, path=None):
    """`data` as JSON to `path` (complete or not at all), or to stdout when no path is given."""
    text = json_text(data)
    if path is None:
        sys.stdout.write(text)
    else:
        write_file(path, lambda temporary: Path(temporary).write_text(text))


def replace_bag(path, force):
    """With `force`, remove the bag at `path` so that a new one can be written there; only a directory that
    holds a bag (metadata.yaml) is removed, never other files."""
    path = Path(path)
    if not (force and path.is_dir() and any(path.iterdir())):
        return
    if not (path / 'metadata.yaml').is_file():
        raise InputError(f'{path}: --force replaces bags only, and this directory holds no metadata.yaml')
    shutil.rmtree(path)
