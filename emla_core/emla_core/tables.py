"""Named columns of measured data from a CSV file or a MATLAB .mat file (v5 with scipy, v7.3 with h5py),
with clear errors: {name: 1-D float array}, all of one length."""
import warnings
from pathlib import Path

import numpy as np

from emla_core.errors import InputError


def read_csv_columns(path):
    """{header name: column} of a CSV file with a header row and numeric rows."""
    path = Path(path)
    try:
        with path.open() as f, warnings.catch_warnings():
            warnings.simplefilter('ignore')      # loadtxt warns on no rows; that case is reported below
            header = f.readline()
            data = np.loadtxt(f, delimiter=',', ndmin=2, dtype=float)
    except FileNotFoundError:
        raise InputError(f'{path}: no such file') from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f'{path}: cannot read as CSV text: {exc}') from None
    except ValueError as exc:
        raise InputError(f'{path}: not numeric CSV: {exc}') from None
    names = [n.strip() for n in header.strip().split(',')]
    if not header.strip():
        raise InputError(f'{path}: empty file')
    if len(set(names)) != len(names):
        raise InputError(f'{path}: repeated column names in header {header.strip()!r}')
    if data.size == 0:
        raise InputError(f'{path}: no data rows')
    if data.shape[1] != len(names):
        raise InputError(f'{path}: {data.shape[1]} values per row but {len(names)} columns in the header')
    bad = ~np.isfinite(data)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise InputError(f'{path}: non-finite value {data[row, col]} in column {names[col]} at data row {row + 1}')
    return {name: data[:, i].copy() for i, name in enumerate(names)}


def read_mat_columns(path):
    """{variable name: vector} of a MATLAB .mat file: every numeric variable that is a vector (1 x N or
    N x 1); other variables are left out. v7.3 files are HDF5 and need h5py."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f'{path}: no such file')
    with path.open('rb') as f:
        hdf5 = f.read(8) == b'\x89HDF\r\n\x1a\n' or (f.seek(512), f.read(8))[1] == b'\x89HDF\r\n\x1a\n'
    variables = _hdf5_variables(path) if hdf5 else _v5_variables(path)
    vectors = {}
    for name, value in variables.items():
        array = np.asarray(value)
        if array.dtype.kind in 'iuf' and array.ndim <= 2 and min(array.shape, default=0) == 1 and array.size > 1:
            vectors[name] = array.astype(float).reshape(-1)
    if not vectors:
        raise InputError(f'{path}: no numeric vector variables (has {", ".join(variables) or "none"})')
    lengths = {len(v) for v in vectors.values()}
    if len(lengths) > 1:
        detail = ', '.join(f'{k} {len(v)}' for k, v in vectors.items())
        raise InputError(f'{path}: vector variables of different lengths ({detail}); name the ones to use with '
                         f'--columns')
    for name, values in vectors.items():
        bad = ~np.isfinite(values)
        if bad.any():
            raise InputError(f'{path}: non-finite value in variable {name} at element {int(np.argmax(bad)) + 1}')
    return vectors


def _v5_variables(path):
    import scipy.io
    try:
        return {k: v for k, v in scipy.io.loadmat(str(path)).items() if not k.startswith('__')}
    except (ValueError, TypeError, OSError, NotImplementedError) as exc:
        raise InputError(f'{path}: not a readable MATLAB file: {" ".join(str(exc).split())}') from None


def _hdf5_variables(path):
    try:
        import h5py
    except ImportError:
        raise InputError(f'{path}: a MATLAB v7.3 (HDF5) file needs h5py; run `make setup`') from None
    try:
        with h5py.File(path, 'r') as f:
            return {name: f[name][()] for name in f if isinstance(f[name], h5py.Dataset)}
    except OSError as exc:
        raise InputError(f'{path}: not a readable MATLAB v7.3 file: {exc}') from None
