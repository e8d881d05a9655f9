"""A trend's recordings as a table (pyarrow), one row per recording, and back (for --resume).

Columns: path, start (s, null without a time), duration (s); each parameter `<name>` and its one-sigma
`<name>_std` (SI); the fit block flattened as `fit.<equation>.<figure>` (`fit.electrical.ratio`,
`fit.mechanical.whiteness.max_correlation`; a list, depends_on, as JSON text); warnings_count and warnings (the
lines joined by newlines); and `true_<name>` where the recordings carry their true parameters (simulated ones).
Written as Parquet, or CSV for a name ending in .csv.
"""
import json
import math
from pathlib import Path

import pyarrow as pa

from emla_core.errors import InputError

FIT_PREFIX = 'fit.'
TRUE_PREFIX = 'true_'
FIXED = ('path', 'start', 'duration')
WARNINGS = ('warnings_count', 'warnings')
TABLE_SUFFIXES = ('.parquet', '.csv')


def recordings_table(recordings: list) -> pa.Table:
    """The pyarrow Table of identified recordings (dicts as identify_recording returns them), one row each.

    Parameters
    ----------
    recordings : list of dict
        With path, start, duration, parameters, std, fit, warnings and (optionally) truth.

    Returns
    -------
    pyarrow.Table
        The columns of the module doc, in that order; a figure a recording lacks is null.
    """
    names = _ordered(name for r in recordings for name in r['parameters'])
    fits = _ordered(key for r in recordings for key in _flat(r.get('fit') or {}, FIT_PREFIX))
    truths = _ordered(name for r in recordings for name in (r.get('truth') or {}))
    flat = [_flat(r.get('fit') or {}, FIT_PREFIX) for r in recordings]
    columns = {
        'path': pa.array([str(r['path']) for r in recordings], pa.string()),
        'start': pa.array([_number(r.get('start')) for r in recordings], pa.float64()),
        'duration': pa.array([_number(r.get('duration')) for r in recordings], pa.float64()),
    }
    for name in names:
        columns[name] = pa.array([_number(r['parameters'].get(name)) for r in recordings], pa.float64())
        columns[f'{name}_std'] = pa.array([_number(r['std'].get(name)) for r in recordings], pa.float64())
    for key in fits:
        values = [f.get(key) for f in flat]
        kind = next((type(v) for v in values if v is not None), float)
        if kind is bool:
            columns[key] = pa.array(values, pa.bool_())
        elif kind is str:
            columns[key] = pa.array(values, pa.string())
        else:
            columns[key] = pa.array([_number(v) for v in values], pa.float64())
    columns['warnings_count'] = pa.array([len(r.get('warnings') or ()) for r in recordings], pa.int64())
    columns['warnings'] = pa.array(['\n'.join(r.get('warnings') or ()) for r in recordings], pa.string())
    for name in truths:
        columns[TRUE_PREFIX + name] = pa.array([_number((r.get('truth') or {}).get(name)) for r in recordings],
                                               pa.float64())
    return pa.table(columns)


def table_recordings(table: pa.Table) -> list:
    """The recordings (dicts as recordings_table takes them) of a table it wrote: the inverse, for --resume."""
    rows = table.to_pylist()
    columns = table.column_names
    if not set(FIXED) <= set(columns):
        raise InputError(f'the table has no {", ".join(sorted(set(FIXED) - set(columns)))} column: not a trend table')
    names = [c for c in columns if f'{c}_std' in columns and c not in FIXED]
    recordings = []
    for row in rows:
        fit: dict[str, dict] = {}
        for key in (c for c in columns if c.startswith(FIT_PREFIX)):
            value = row[key]
            if value is None:
                continue
            if key.endswith('.depends_on') and isinstance(value, str):
                value = json.loads(value)
            _nest(fit, key[len(FIT_PREFIX):].split('.'), value)
        recordings.append({
            'path': row['path'], 'start': _number(row['start']), 'duration': _number(row['duration']),
            'parameters': {n: _number(row[n]) for n in names if row[n] is not None},
            'std': {n: _number(row[f'{n}_std']) for n in names if row[n] is not None},
            'fit': fit, 'warnings': [w for w in (row.get('warnings') or '').split('\n') if w],
            'truth': {c[len(TRUE_PREFIX):]: row[c] for c in columns
                      if c.startswith(TRUE_PREFIX) and row[c] is not None}})
    return recordings


def write_table(table: pa.Table, path: str | Path) -> None:
    """Write `table` as Parquet, or as CSV when `path` ends in .csv (any other name: Parquet)."""
    path = Path(path)
    if path.suffix.lower() == '.csv':
        from pyarrow import csv
        csv.write_csv(table, path)
    else:
        import pyarrow.parquet as pq
        pq.write_table(table, path)


def read_table(path: str | Path) -> pa.Table:
    """The table at `path` (CSV when it ends in .csv, else Parquet); InputError when it cannot be read."""
    path = Path(path)
    try:
        if path.suffix.lower() == '.csv':
            from pyarrow import csv
            return csv.read_csv(path, parse_options=csv.ParseOptions(newlines_in_values=True),
                                convert_options=csv.ConvertOptions(
                                    column_types={'path': pa.string(), 'warnings': pa.string(),
                                                  'start': pa.float64()}, strings_can_be_null=False))
        import pyarrow.parquet as pq
        return pq.read_table(path)
    except (OSError, pa.ArrowException) as exc:
        raise InputError(f'{path}: cannot read the table: {_first_line(exc)}') from None


def _first_line(exc):
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


def _ordered(names):
    """The distinct names in the order of first appearance."""
    return list(dict.fromkeys(names))


def _number(value):
    """A float, or None for a missing or non-finite value (null in the table and the JSON)."""
    if value is None or isinstance(value, bool):
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _flat(block, prefix):
    """{prefix + 'a.b': value} of a nested dict; lists as JSON text."""
    out = {}
    for key, value in block.items():
        if isinstance(value, dict):
            out.update(_flat(value, f'{prefix}{key}.'))
        elif isinstance(value, (list, tuple)):
            out[f'{prefix}{key}'] = json.dumps(value)
        else:
            out[f'{prefix}{key}'] = value
    return out


def _nest(block, keys, value):
    for key in keys[:-1]:
        block = block.setdefault(key, {})
    block[keys[-1]] = value
