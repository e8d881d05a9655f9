"""Named columns of measured data from a CSV file or a MATLAB .mat file (v5 with scipy, v7.3 with h5py),
with clear errors: {name: 1-D float array}, all of one length.

CSV files are read as they come from spreadsheets and loggers: a UTF-8 byte order mark (Excel's "CSV UTF-8"),
quoted headers ("t","u"), and ';'- or tab-separated values with decimal commas are recognised from the header
and the first data rows; `delimiter` and `decimal` say it where that guess is not enough. The rows are parsed
by pyarrow in blocks, with a progress bar on a terminal for large files. MATLAB variables are listed from
their headers and only those asked for are loaded.
"""
import csv
import io
import math
import re
import struct
import sys
import zlib
from pathlib import Path
from typing import NamedTuple

import numpy as np

from emla_core.errors import InputError
from emla_core.files import regular_file

DELIMITERS = {',': ',', ';': ';', 'tab': '\t', '\t': '\t', '|': '|'}
DECIMALS = ('.', ',')
MAX_HEADER_CHARS = 1 << 16      # a longer first line is no CSV header (a binary file, or one without newlines)
PROGRESS_BYTES = 64 << 20       # a CSV file from this size shows a progress bar when stderr is a terminal
BLOCK_BYTES = 1 << 20           # of the CSV file pyarrow parses at a time: a longer line cannot be parsed
MAX_MAT_VARIABLES = 10_000
MAX_MAT_VALUES = 500_000_000    # values of the variables read from one MATLAB file together: 4 GB as float64
NUMERIC_CLASSES = ('double', 'single', 'int8', 'uint8', 'int16', 'uint16', 'int32', 'uint32', 'int64', 'uint64')
_HDF5_SIGNATURE = b'\x89HDF\r\n\x1a\n'   # at byte 0, or 512 behind MATLAB's header


def read_csv_columns(path, delimiter=None, decimal=None, progress=None):
    """{header name: column} of a CSV file with a header row and numeric rows; columns without a name (as a
    delimiter at the end of each line makes) are left out.

    Parameters
    ----------
    path : str or Path
        A regular file of UTF-8 text (a byte order mark is skipped).
    delimiter : str, optional
        ',', ';', '|' or 'tab'; found from the header when not given.
    decimal : str, optional
        '.' or ','; when not given, ',' if the delimiter is not one and the first 64 KiB of rows have one.
    progress : bool, optional
        Whether to show a progress bar on stderr; by default only for a file of at least PROGRESS_BYTES when
        stderr is a terminal.

    Returns
    -------
    dict of str to ndarray
        Float columns in header order, all of one length.

    Raises
    ------
    InputError
        Not a regular file, not UTF-8 text, an empty or repeated header, rows of another width, values that
        are not numbers or not finite, or no data rows; the message names the file (and row and column).
    """
    path = regular_file(path, 'CSV file')
    header, rows = _head(path)
    dialect = _dialect(path, header, rows, delimiter, decimal)
    names = [name.strip() for name in next(csv.reader([header], **dialect.csv))]
    named = [name for name in names if name]
    if not named or len(set(named)) != len(named):
        raise InputError(f'{path}: {"repeated" if named else "no"} column names in header {header!r}')
    show = progress if progress is not None else sys.stderr.isatty() and path.stat().st_size >= PROGRESS_BYTES
    columns = _parse(path, names, dialect, show)
    if not len(columns[0]):
        raise InputError(f'{path}: no data rows')
    for name, values in zip(named, columns, strict=True):
        bad = ~np.isfinite(values)
        if bad.any():
            row = int(np.argmax(bad))
            raise InputError(f'{path}: non-finite value {values[row]} in column {name} at data row {row + 1}')
    return dict(zip(named, columns, strict=True))


class _Dialect(NamedTuple):
    """The delimiter and decimal mark of a CSV file."""
    delimiter: str
    decimal: str

    @property
    def csv(self):
        """The options of the csv module's reader for this dialect."""
        return {'delimiter': self.delimiter, 'skipinitialspace': True}


def _head(path):
    """(header line without a byte order mark or line end, up to MAX_HEADER_CHARS of the text after it) of a
    CSV file."""
    try:
        with path.open(encoding='utf-8-sig', newline='') as f:
            header = f.readline(MAX_HEADER_CHARS)
            if len(header) == MAX_HEADER_CHARS and not header.endswith(('\n', '\r')):
                raise InputError(f'{path}: no CSV header: the first line is longer than {MAX_HEADER_CHARS} '
                                 f'characters')
            rows = f.read(MAX_HEADER_CHARS)
    except UnicodeDecodeError as exc:
        raise InputError(f'{path}: cannot read as CSV text: not UTF-8 ({exc.reason})') from None
    except OSError as exc:
        raise InputError(f'{path}: cannot read as CSV text: {exc.strerror or exc}') from None
    if not header.strip():
        raise InputError(f'{path}: empty file')
    return header.rstrip('\r\n'), rows


def _dialect(path, header, rows, delimiter, decimal):
    """The _Dialect given, completed from the header and the first data `rows`: the delimiter that splits the
    header and the first row into the same number of fields, the most (else the header the most); a decimal
    comma where the delimiter is not one and the rows have one."""
    if delimiter is not None and delimiter not in DELIMITERS:
        raise InputError(f'{path}: delimiter {delimiter!r}: use one of , ; | tab')
    if decimal is not None and decimal not in DECIMALS:
        raise InputError(f'{path}: decimal mark {decimal!r}: use . or ,')
    if delimiter is None:
        first = next((line for line in rows.splitlines() if line.strip()), '')

        def fields(line, d):
            return len(next(csv.reader([line], delimiter=d), ()))

        def fit(d):
            return 1 < fields(header, d) == fields(first, d), fields(header, d)
        delimiter = max((d for d in (',', ';', '\t', '|') if d != decimal), key=fit)
    delimiter = DELIMITERS[delimiter]
    if decimal is None:
        decimal = ',' if delimiter != ',' and ',' in rows else '.'
    if delimiter == decimal:
        raise InputError(f'{path}: the delimiter and the decimal mark are both {decimal!r}')
    return _Dialect(delimiter, decimal)


def _parse(path, names, dialect, show):
    """The data rows of a CSV file as float columns (of the named ones among `names`), parsed by pyarrow block
    by block into arrays sized from the first MiB's rows (so the file is held once, as floats, not once more
    as blocks)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    from tqdm import tqdm
    size = path.stat().st_size
    named = [name for name in names if name]
    options = dict(
        # unnamed columns get names no header holds, and are not converted
        read_options=pacsv.ReadOptions(column_names=[name or f'\0{i}' for i, name in enumerate(names)],
                                       skip_rows=1, block_size=BLOCK_BYTES),
        parse_options=pacsv.ParseOptions(delimiter=dialect.delimiter),
        convert_options=pacsv.ConvertOptions(column_types={name: pa.float64() for name in named},
                                             include_columns=named, null_values=[],
                                             decimal_point=dialect.decimal))
    with path.open('rb') as f:
        sample = f.read(1 << 20)
    capacity = int(size * (sample.count(b'\n') + 1) / max(len(sample), 1) * 1.05) + 1024
    columns = [np.empty(capacity) for _ in named]
    rows = 0
    # An arrow file, not a Python one: arrow's I/O threads must not need the GIL, which they cannot take
    # while the interpreter shuts down (std::terminate, exit 134).
    try:
        with pa.OSFile(str(path)) as f, tqdm(total=size, unit='B', unit_scale=True, desc=path.name,
                                             file=sys.stderr, disable=not show, leave=False) as bar:
            for batch in pacsv.open_csv(f, **options):
                if rows + batch.num_rows > capacity:
                    capacity = (rows + batch.num_rows) * 3 // 2
                    for column in columns:
                        column.resize(capacity, refcheck=False)
                for column, values in zip(columns, batch.columns, strict=True):
                    column[rows:rows + batch.num_rows] = values.to_numpy()
                rows += batch.num_rows
                bar.update(f.tell() - bar.n)
    except pa.ArrowInvalid as exc:
        raise InputError(_parse_error(path, names, dialect, str(exc))) from None
    except OSError as exc:
        raise InputError(f'{path}: cannot read as CSV text: {exc}') from None
    for column in columns:
        column.resize(rows, refcheck=False)
    return columns


def _parse_error(path, names, dialect, message):
    """One line for pyarrow's error `message`, with the data row it is about (found by reading the file again
    up to it: this costs time only when the file is refused)."""
    width = re.search(r'Expected (\d+) columns, got (\d+)', message)
    # (pyarrow names the row too in some runs: "column #1: Row #3: CSV conversion error ...")
    value = re.search(r"column #(\d+): (?:Row #\d+: )?CSV conversion error to double: invalid value '(.*)'", message)
    if 'straddl' in message:   # pyarrow's "straddling object straddles two block boundaries"
        return _long_line(path)
    if width:
        row = _find_row(path, dialect, lambda fields: len(fields) != len(names))
        return f'{path}: {width.group(2)} values per row but {len(names)} columns in the header{row}'
    if value:
        index, text = int(value.group(1)), value.group(2)
        row = _find_row(path, dialect, lambda fields: len(fields) > index and fields[index].strip() == text)
        hint = (f' (read with decimal mark {dialect.decimal!r})' if dialect.decimal != '.'
                else ' (a decimal comma? give --decimal ,)' if ',' in text else '')
        return f'{path}: not numeric CSV: {text!r} in column {names[index]}{row}{hint}'
    return f'{path}: not a readable CSV file: {" ".join(message.split())}'


def _long_line(path):
    """The message for a CSV file with a line longer than BLOCK_BYTES: which line (1 is the header) and how long,
    found by reading the file again block by block (never a whole line at once)."""
    def message(where):
        return (f'{path}: not a readable CSV file: {where}, more than the {BLOCK_BYTES >> 20} MiB a line may have '
                f'(a damaged file, or one without line ends?)')
    number, length = 1, 0
    with path.open('rb') as f:
        while block := f.read(BLOCK_BYTES):
            start = 0
            while (end := block.find(b'\n', start)) >= 0:
                length += end - start
                if length > BLOCK_BYTES:
                    return message(f'line {number} has {length:,} bytes')
                number, length, start = number + 1, 0, end + 1
            length += len(block) - start
    return message(f'line {number} has {length:,} bytes' if length > BLOCK_BYTES else 'a line is longer')


def _find_row(path, dialect, wrong):
    """' at data row N' of the first data row (blank lines not counted) whose fields are `wrong`; '' if none."""
    with path.open(encoding='utf-8-sig', newline='', errors='replace') as f:
        rows = (fields for fields in csv.reader(f, **dialect.csv) if fields)
        next(rows, None)
        return next((f' at data row {number}' for number, fields in enumerate(rows, 1) if wrong(fields)), '')


def mat_vectors(path):
    """{name: length} of the numeric vector variables (1 x N or N x 1, N > 1, real) of a MATLAB file, read
    from the variables' headers: no variable is loaded.

    Parameters
    ----------
    path : str or Path
        A MATLAB .mat file: v4, v5/v7 (read with scipy) or v7.3 (HDF5, read with h5py).

    Returns
    -------
    dict of str to int

    Raises
    ------
    InputError
        Not a regular file, empty, not a MATLAB file, more than MAX_MAT_VARIABLES variables, or no numeric
        vector among them.
    """
    return {name: length for name, (length, _) in _vectors(path)[1].items()}


def read_mat_columns(path, names=None):
    """{variable name: vector} of the numeric vector variables `names` of a MATLAB file (default: all); the
    other variables are not loaded (nor decompressed). v7.3 files are HDF5 and need h5py.

    Parameters
    ----------
    path : str or Path
        A MATLAB .mat file.
    names : iterable of str, optional
        The variables to load, among `mat_vectors(path)`; all of those by default.

    Returns
    -------
    dict of str to ndarray
        Float vectors of one length, in the order of `names`.

    Raises
    ------
    InputError
        As for `mat_vectors`; a name that is no numeric vector, more than MAX_MAT_VALUES values together,
        vectors of different lengths or non-finite values.
    """
    version, vectors = _vectors(path)
    path = Path(path)
    names = list(vectors if names is None else dict.fromkeys(names))
    missing = [name for name in names if name not in vectors]
    if missing:
        raise InputError(f'{path}: no numeric vector variable {", ".join(missing)} (has {", ".join(vectors)})')
    lengths = {name: vectors[name][0] for name in names}
    if sum(lengths.values()) > MAX_MAT_VALUES:
        raise InputError(f'{path}: {", ".join(names)} hold {sum(lengths.values()):.3g} values, more than the '
                         f'{MAX_MAT_VALUES:.3g} the suite reads from a MATLAB file')
    if len(set(lengths.values())) > 1:
        detail = ', '.join(f'{name} {length}' for name, length in lengths.items())
        raise InputError(f'{path}: vector variables of different lengths ({detail}); name the ones to use with '
                         f'--columns')
    load = {'hdf5': _hdf5_load, 'v5': _v5_load, 'v4': _v4_load}[version]
    loaded = load(path, {name: vectors[name][1] for name in names})
    return {name: _vector(path, name, loaded.get(name)) for name in names}


def mat_scalars(path, select=None):
    """{variable name: value} of the real numeric scalar variables (1 x 1) of a MATLAB file whose names
    `select` accepts (all by default); only those are loaded.

    Parameters
    ----------
    path : str or Path
        A MATLAB .mat file: v4, v5/v7 (read with scipy) or v7.3 (HDF5, read with h5py).
    select : callable, optional
        select(name) -> bool: which scalars to load.

    Returns
    -------
    dict of str to float
        In the file's order; a value may be NaN or infinite as the file has it.

    Raises
    ------
    InputError
        As for `mat_vectors`, or a chosen scalar whose data do not match its header (a damaged file).
    """
    version, listing = _listing(path)
    path = Path(path)
    scalars = {name: where for name, shape, kind, where in listing
               if kind in NUMERIC_CLASSES and math.prod(shape) == 1 and (select is None or select(name))}
    if not scalars:
        return {}
    loaded = {'hdf5': _hdf5_load, 'v5': _v5_load, 'v4': _v4_load}[version](path, scalars)
    values = {}
    for name in scalars:
        try:
            value = np.asarray(loaded.get(name), dtype=float).reshape(-1)
        except (TypeError, ValueError):
            value = np.empty(0)
        if value.size != 1:
            raise InputError(f'{path}: variable {name} is not the numeric scalar its header says: a damaged file')
        values[name] = float(value[0])
    return values


def _vector(path, name, value):
    """The variable `name` as a finite float vector; a damaged file whose data do not match its header
    (as a flipped bit makes) as one line."""
    try:
        values = np.asarray(value, dtype=float).reshape(-1)     # None (not loaded) gives one NaN
    except (TypeError, ValueError):
        values = np.empty(0)
    if values.size < 2:
        raise InputError(f'{path}: variable {name} is not the numeric vector its header says: a damaged file')
    bad = ~np.isfinite(values)
    if bad.any():
        raise InputError(f'{path}: non-finite value in variable {name} at element {int(np.argmax(bad)) + 1}')
    return values


def _vectors(path):
    """(format: 'hdf5', 'v5' or 'v4'; {name: (length, where)}) of the numeric vectors of a MATLAB file;
    `where` is what the format's loader needs to find the variable (the bytes of a v5 one)."""
    version, listing = _listing(path)
    vectors = {name: (int(np.prod(shape)), where) for name, shape, kind, where in listing
               if kind in NUMERIC_CLASSES and len(shape) <= 2 and min(shape, default=0) == 1 and np.prod(shape) > 1}
    if not vectors:
        shown = ', '.join(name for name, *_ in listing[:20]) + (', ...' if len(listing) > 20 else '')
        raise InputError(f'{path}: no numeric vector variables (has {shown or "none"})')
    return version, vectors


def _listing(path):
    """(format: 'hdf5', 'v5' or 'v4'; [(name, shape, class, where)]) of the variables of a MATLAB file."""
    path = regular_file(path, 'MATLAB file')
    with path.open('rb') as f:
        head = f.read(528)
    if not head:
        raise InputError(f'{path}: empty file')
    version = ('hdf5' if _HDF5_SIGNATURE in (head[:8], head[512:520])
               else 'v5' if head.startswith(b'MATLAB') or head[126:128] in (b'IM', b'MI') else 'v4')
    listing = {'hdf5': _hdf5_listing, 'v5': _v5_listing, 'v4': _v4_listing}[version](path)
    if len(listing) > MAX_MAT_VARIABLES:
        raise InputError(f'{path}: {len(listing)} variables, more than the {MAX_MAT_VARIABLES} the suite reads '
                         f'from a MATLAB file')
    return version, listing


# MATLAB v5 (and v7) files: a 128-byte header, then one element per variable, miMATRIX or miCOMPRESSED (a
# zlib stream of a miMATRIX). scipy's whosmat and loadmat read every variable's header through a stream that
# decompresses 128 KiB blocks at a time: hundreds of MB for a well compressed matrix that is not even used.
# So the headers are parsed here from a few KiB of each, and only the chosen variables' bytes go to loadmat.
_MI_MATRIX, _MI_COMPRESSED = 14, 15
_MX_CLASSES = {6: 'double', 7: 'single', 8: 'int8', 9: 'uint8', 10: 'int16', 11: 'uint16', 12: 'int32',
               13: 'uint32', 14: 'int64', 15: 'uint64', 4: 'char', 1: 'cell', 2: 'struct', 5: 'sparse'}
_MI_SIZES = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 9: 8, 12: 8, 13: 8}   # bytes of the numeric data types
_V5_HEADER_BYTES = 4096    # of a variable's element: enough for its flags, dimensions, name and data tag


def _v5_listing(path):
    """[(name, shape, class, (start, end) of its bytes)] of the variables of a v5/v7 MATLAB file."""
    size = path.stat().st_size
    if size < 128:
        raise InputError(f'{path}: not a readable MATLAB file: truncated in its 128-byte header')
    with path.open('rb') as f:
        order = '<' if f.read(128)[126:128] == b'IM' else '>'
        listing, start = [], 128
        while start + 8 <= size:
            f.seek(start)
            mdtype, count = struct.unpack(order + 'II', f.read(8))
            end = start + 8 + count
            if end > size or mdtype not in (_MI_MATRIX, _MI_COMPRESSED):
                raise InputError(f'{path}: not a readable MATLAB file: damaged or truncated at byte {start}')
            head = f.read(min(count, _V5_HEADER_BYTES))
            try:
                body = (zlib.decompressobj().decompress(head, _V5_HEADER_BYTES) if mdtype == _MI_COMPRESSED
                        else struct.pack(order + 'II', mdtype, count) + head)
                listing.append((*_v5_header(body, order), (start, end)))
            except (zlib.error, struct.error, UnicodeDecodeError):
                raise InputError(f'{path}: not a readable MATLAB file: damaged variable at byte {start}') from None
            start = end
    return listing


def _v5_header(body, order):
    """(name, shape, class) of a miMATRIX element that starts `body`: its array flags, dimensions and name
    subelements. Of a numeric variable, the real part's size must be what the dimensions say (scipy's reader
    crashes on a type or size that a flipped bit made).

    Raises
    ------
    struct.error
        The header is cut short or inconsistent.
    """
    flags = struct.unpack_from(order + 'I', body, 16)[0]
    kind = ('complex' if flags & 0x800 else 'logical' if flags & 0x200
            else _MX_CLASSES.get(flags & 0xFF, 'other'))
    _, dims_bytes, at, after = _v5_tag(body, 24, order)
    shape = struct.unpack_from(f'{order}{dims_bytes // 4}i', body, at)
    _, length, at, after = _v5_tag(body, after, order)
    if at + length > len(body):
        raise struct.error('name beyond the header')
    if kind in NUMERIC_CLASSES:
        data_type, count, data_at, _ = _v5_tag(body, after, order)
        element_end = 8 + struct.unpack_from(order + 'I', body, 4)[0]
        if count != _MI_SIZES.get(data_type, -1) * math.prod(shape) or data_at + count > element_end:
            raise struct.error('real part of another size than the dimensions say')
    return body[at:at + length].decode('latin-1'), shape, kind


def _v5_tag(body, at, order):
    """(data type, byte count, offset of the data, offset of the next subelement) of the subelement whose tag
    is at `at`, in the full form or the 'small data element' one (up to 4 bytes of data inside the tag)."""
    word = struct.unpack_from(order + 'I', body, at)[0]
    if word >> 16:
        return word & 0xFFFF, word >> 16, at + 4, at + 8
    count = struct.unpack_from(order + 'I', body, at + 4)[0]
    return word, count, at + 8, at + 8 + (count + 7) // 8 * 8


def _v5_load(path, spans):
    """{name: array} of the variables at `spans` {name: (start, end)}: their bytes behind the file's header,
    as a file of their own for scipy."""
    import scipy.io
    with path.open('rb') as f:
        parts = [f.read(128)]
        for start, end in spans.values():
            f.seek(start)
            parts.append(f.read(end - start))
    return _scipy_call(path, lambda: scipy.io.loadmat(io.BytesIO(b''.join(parts))))


def _v4_listing(path):
    import scipy.io
    return _scipy_call(path, lambda: [(name, tuple(shape), kind, None)
                                      for name, shape, kind in scipy.io.whosmat(str(path))])


def _v4_load(path, names):
    import scipy.io
    return _scipy_call(path, lambda: scipy.io.loadmat(str(path), variable_names=list(names)))


def _scipy_call(path, read):
    """read() with scipy's errors on a damaged or foreign file as one line."""
    from scipy.io.matlab import MatReadError
    try:
        return read()
    except (MatReadError, ValueError, TypeError, IndexError, KeyError, OverflowError, OSError,
            NotImplementedError) as exc:
        raise InputError(f'{path}: not a readable MATLAB file: {" ".join(str(exc).split())}') from None


def _hdf5_listing(path):
    """[(name, shape, MATLAB class, key)] of the datasets at the top of a v7.3 file; the class from the
    MATLAB_class attribute, else from the dtype (files written by other HDF5 tools); the key as h5py gives
    it (bytes where the name is not UTF-8)."""
    def kind(dataset):
        matlab = dataset.attrs.get('MATLAB_class')
        if matlab is not None:
            return matlab.decode() if isinstance(matlab, bytes) else str(matlab)
        return 'double' if dataset.dtype.kind in 'iuf' else str(dataset.dtype)
    return _hdf5_call(path, lambda f, h5py: [
        (key.decode('latin-1') if isinstance(key, bytes) else key, f[key].shape, kind(f[key]), key)
        for key in f if isinstance(f[key], h5py.Dataset)])


def _hdf5_load(path, keys):
    """{name: array} of the datasets `keys` {name: key}."""
    return _hdf5_call(path, lambda f, h5py: {name: f[key][()] for name, key in keys.items()})


def _hdf5_call(path, read):
    """read(open h5py.File, h5py module), with h5py missing or the file unreadable (HDF5 reports damage
    as any of several exceptions) as one line."""
    try:
        import h5py
    except ImportError:
        raise InputError(f'{path}: a MATLAB v7.3 (HDF5) file needs h5py; run `make setup`') from None
    try:
        with h5py.File(path, 'r') as f:
            return read(f, h5py)
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:   # UnicodeDecodeError too
        raise InputError(f'{path}: not a readable MATLAB v7.3 file: {" ".join(str(exc).split())}') from None
