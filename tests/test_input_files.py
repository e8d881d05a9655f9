"""The readers of a user's own files (issue 19): CSV as spreadsheets and loggers write it (byte order mark,
quoted headers, ';' with decimal commas, --delimiter/--decimal), MATLAB files that load only the variables
used, inputs that are no regular file, and values too large to compute with. Each problem is one line
(exit 2 through the CLI), never a traceback nor a read that does not end."""
import os
import struct
import subprocess
import tracemalloc

import numpy as np
import pytest
import scipy.io
from ros_isolation import VENV_BIN

from emla_core import tables
from emla_core.data import load
from emla_core.errors import InputError
from emla_core.tables import read_csv_columns

pytestmark = pytest.mark.timeout(300)
NAMES = ('t', 'voltage', 'current', 'position')


def emla(*args, timeout=120):
    return subprocess.run([str(VENV_BIN / 'emla'), *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)


def refused(out, *words):
    """Assert `out` is one error line on stderr, exit 2, naming `words`."""
    assert out.returncode == 2, out.stderr
    assert 'Traceback' not in out.stderr and out.stderr.count('\n') == 1, out.stderr
    assert out.stdout == ''
    for word in words:
        assert word in out.stderr, out.stderr


@pytest.fixture(scope='module')
def rows():
    """40 samples at 1 kHz of values with decimals (and exponents), as text of 10 significant digits."""
    k = np.arange(40)
    table = np.column_stack((k * 1e-3, 12 * np.sin(k / 5), 1.5e-3 * np.cos(k / 7) + 0.25, -k * 2.5e-5))
    return [[f'{value:.10g}' for value in row] for row in table]


def write(path, rows, delimiter=',', decimal='.', header=NAMES, bom=False, newline='\n', end=''):
    lines = [delimiter.join(header) + end] + [delimiter.join(v.replace('.', decimal) for v in row) + end
                                              for row in rows]
    path.write_text(newline.join(lines) + newline, encoding='utf-8-sig' if bom else 'utf-8')
    return path


def assert_same(recording, reference):
    assert recording.sample_period == reference.sample_period
    assert recording.start_time == reference.start_time
    assert recording.signals.keys() == reference.signals.keys()
    for name, values in reference.signals.items():
        np.testing.assert_array_equal(recording.signals[name], values, err_msg=name)


@pytest.mark.parametrize('kind', ['bom', 'quoted', 'semicolon', 'tab', 'excel', 'trailing'])
def test_spreadsheet_csv_gives_the_recording_of_the_plain_one(tmp_path, rows, kind):
    reference = load(write(tmp_path / 'plain.csv', rows))
    quoted = [f'"{name}"' for name in NAMES]
    variant = {'bom': dict(bom=True), 'quoted': dict(header=quoted), 'semicolon': dict(delimiter=';', decimal=','),
               'tab': dict(delimiter='\t'), 'trailing': dict(delimiter=';', decimal=',', end=';'),
               'excel': dict(bom=True, header=quoted, delimiter=';', decimal=',', newline='\r\n')}[kind]
    assert_same(load(write(tmp_path / f'{kind}.csv', rows, **variant)), reference)


def test_a_header_quoting_the_delimiter_is_read_by_its_fields(tmp_path, rows):
    path = write(tmp_path / 'units.csv', rows, delimiter=';', decimal=',',
                 header=('"t [s]"', '"voltage [V, rms]"', 'current', 'position'))
    assert list(read_csv_columns(path)) == ['t [s]', 'voltage [V, rms]', 'current', 'position']


def test_delimiter_and_decimal_flags(tmp_path, rows):
    # Integers in the first 64 KiB of rows give no sign of a decimal comma: --decimal says it.
    text = 't;voltage\n' + ''.join(f'{k};{k % 7}\n' for k in range(10_000)) + '10000;1,5\n'
    path = tmp_path / 'late.csv'
    path.write_text(text)
    with pytest.raises(InputError, match=r"'1,5' in column voltage at data row 10001 .*--decimal ,"):
        load(path, units='t=ms')
    assert load(path, units='t=ms', decimal=',').signals['voltage'][-1] == 1.5
    semicolon = write(tmp_path / 'semicolon.csv', rows, delimiter=';', decimal=',')
    assert_same(load(semicolon, delimiter=';', decimal=','), load(write(tmp_path / 'plain.csv', rows)))
    with pytest.raises(InputError, match='both'):
        load(semicolon, delimiter=',', decimal=',')
    with pytest.raises(InputError, match='2 values per row but 1 columns in the header at data row 1'):
        load(semicolon, delimiter=',')
    bag = tmp_path / 'bag'
    out = emla('import', semicolon, bag, '--delimiter', ';', '--decimal', ',')
    assert out.returncode == 0 and out.stdout.startswith(f'{bag}: 40 samples'), out.stderr
    matlab = mat(tmp_path / 'x.mat', {'t': np.arange(3.0)})
    refused(emla('import', matlab, tmp_path / 'other', '--decimal', ','), 'x.mat: --decimal applies to CSV files')


@pytest.mark.parametrize('text, problem', [
    ('t,voltage\n0,1\n0.1,abc\n', "not numeric CSV: 'abc' in column voltage at data row 2"),
    ('t,voltage\n0,1\n\n0.1,\n', "not numeric CSV: '' in column voltage at data row 2"),
    ('t,voltage\n0,1\n0.1,1,2\n', '3 values per row but 2 columns in the header at data row 2'),
    ('t,voltage\n0,1\n0.1,1e400\n', 'non-finite value inf in column voltage at data row 2'),
    ('\ufeff', 'empty file'),
    ('t,voltage\n0,1\n0.1,\xff\n', 'not UTF-8'),
])
def test_bad_rows_are_named(tmp_path, text, problem):
    path = tmp_path / 'bad.csv'
    path.write_bytes(text.encode('utf-8' if '\xff' not in text else 'latin-1'))
    with pytest.raises(InputError, match=problem) as err:
        read_csv_columns(path)
    assert str(err.value).startswith(f'{path}: ') and '\n' not in str(err.value)


def test_a_binary_file_is_no_csv_header(tmp_path):
    path = tmp_path / 'blob.csv'
    path.write_bytes(b'a' * (tables.MAX_HEADER_CHARS + 10))
    with pytest.raises(InputError, match='no CSV header'):
        read_csv_columns(path)


def test_progress_only_on_request_or_a_terminal_and_only_on_stderr(tmp_path, rows, capsys):
    path = write(tmp_path / 'run.csv', rows)
    read_csv_columns(path)        # stderr is no terminal here
    assert capsys.readouterr() == ('', '')
    read_csv_columns(path, progress=True)
    out, err = capsys.readouterr()
    assert out == '' and 'run.csv: ' in err and 'B/s' in err


def test_a_large_csv_is_read_whole(tmp_path):
    """More rows than the first MiB suggests (short rows after long ones): the arrays grow as needed."""
    k = np.arange(200_000)
    head = ''.join(f'{i * 1e-3:.12f},{i:.12f}\n' for i in k[:30_000])
    tail = ''.join(f'{i * 1e-3:g},{i}\n' for i in k[30_000:])
    path = tmp_path / 'long.csv'
    path.write_text('t,voltage\n' + head + tail)
    columns = read_csv_columns(path)
    np.testing.assert_allclose(columns['t'], k * 1e-3, rtol=1e-5)
    np.testing.assert_array_equal(columns['voltage'], k)


def mat(path, variables, **options):
    scipy.io.savemat(path, variables, do_compression=True, **options)
    return path


@pytest.fixture
def scope(tmp_path):
    """A MATLAB file with an unused, well compressed 2000 x 2000 matrix (32 MB) and a long unused vector
    before the used vectors."""
    k = np.arange(500)
    return mat(tmp_path / 'scope.mat', {
        'junk': np.zeros((2000, 2000)), 'spare': np.zeros(4_000_000), 'time': k * 1e-4, 'u': np.sin(k),
        'coil_current': np.cos(k), 'x': k * 1e-6})


def test_a_matlab_file_loads_only_the_variables_used(scope, monkeypatch):
    loaded = []
    original = scipy.io.loadmat

    def spy(*args, **kwargs):
        result = original(*args, **kwargs)
        loaded.extend(name for name in result if not name.startswith('__'))
        return result
    monkeypatch.setattr(scipy.io, 'loadmat', spy)
    monkeypatch.setattr(scipy.io, 'whosmat', None)       # lists by decompressing 128 KiB blocks: not used
    tracemalloc.start()
    try:
        recording = load(scope, columns='current=coil_current')
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert sorted(loaded) == ['coil_current', 'time', 'u', 'x']
    assert set(recording.signals) == {'voltage', 'current', 'position'}
    np.testing.assert_array_equal(recording.signals['current'], np.cos(np.arange(500)))
    assert peak < 4e6, peak      # the 32 MB matrix and 32 MB vector are neither loaded nor decompressed


def v5_vector(order, name, values):
    """An uncompressed miMATRIX element of a real double row vector, as the MAT-file format describes it: array
    flags, dimensions, name (in the small data element form up to 4 characters), real part."""
    raw = name.encode()
    named = (struct.pack(order + 'I', len(raw) << 16 | 1) + raw.ljust(4, b'\0') if len(raw) <= 4
             else struct.pack(order + 'II', 1, len(raw)) + raw.ljust((len(raw) + 7) // 8 * 8, b'\0'))
    body = (struct.pack(order + 'IIII', 6, 8, 6, 0) + struct.pack(order + 'IIii', 5, 8, 1, len(values)) + named
            + struct.pack(order + 'II', 9, 8 * len(values)) + np.asarray(values, dtype=order + 'f8').tobytes())
    return struct.pack(order + 'II', 14, len(body)) + body


@pytest.mark.parametrize('order, mark', [('<', b'IM'), ('>', b'MI')], ids=['little-endian', 'big-endian'])
def test_matlab_v5_headers_of_either_byte_order(tmp_path, order, mark):
    path = tmp_path / 'hand.mat'
    header = b'MATLAB 5.0 MAT-file'.ljust(116) + bytes(8) + struct.pack(order + 'H', 0x0100) + mark
    path.write_bytes(header + v5_vector(order, 't', [0.0, 1e-3, 2e-3]) + v5_vector(order, 'voltage', [3, 4, 5]))
    assert tables.mat_vectors(path) == {'t': 3, 'voltage': 3}
    np.testing.assert_array_equal(load(path).signals['voltage'], [3, 4, 5])
    damaged = bytearray(path.read_bytes())
    damaged[128 + 48 + (1 if order == '<' else 2)] ^= 2    # the real part's data type: 9 (double) -> 521
    path.write_bytes(damaged)
    with pytest.raises(InputError, match='damaged variable at byte 128'):   # scipy would crash on it
        load(path)


def test_a_matlab_v73_file_reads_only_the_datasets_used(tmp_path, monkeypatch):
    h5py = pytest.importorskip('h5py')
    path = tmp_path / 'scope73.mat'
    k = np.arange(300)
    variables = {'junk': np.zeros((300, 300)), 'spare': np.zeros((1, 1000)), 'time': k[None] * 1e-4,
                 'voltage': np.sin(k)[None], 'current': np.cos(k)[None], 'position': k[None] * 1e-6}
    with h5py.File(path, 'w', userblock_size=512) as f:
        for name, values in variables.items():
            f[name] = values
    read = []
    original = h5py.Dataset.__getitem__
    monkeypatch.setattr(h5py.Dataset, '__getitem__', lambda self, key: read.append(self.name) or original(self, key))
    recording = load(path)
    assert sorted(read) == ['/current', '/position', '/time', '/voltage']
    np.testing.assert_array_equal(recording.signals['voltage'], np.sin(k))
    path.write_bytes(path.read_bytes()[:3000])
    with pytest.raises(InputError, match='not a readable MATLAB v7.3 file'):
        load(path)


def test_matlab_limits_and_damage_are_one_line(scope, tmp_path, monkeypatch):
    monkeypatch.setattr(tables, 'MAX_MAT_VARIABLES', 5)
    with pytest.raises(InputError, match='6 variables, more than the 5'):
        load(scope)
    monkeypatch.setattr(tables, 'MAX_MAT_VARIABLES', 100)
    with pytest.raises(InputError, match='different lengths'):
        tables.read_mat_columns(scope)
    monkeypatch.setattr(tables, 'MAX_MAT_VALUES', 1000)
    with pytest.raises(InputError, match='time, u, x hold 1.5e\\+03 values, more than the 1e\\+03'):
        load(scope)
    truncated = tmp_path / 'truncated.mat'
    truncated.write_bytes(scope.read_bytes()[:5000])
    with pytest.raises(InputError, match='damaged or truncated at byte'):
        load(truncated)
    truncated.write_bytes(scope.read_bytes()[:121])
    with pytest.raises(InputError, match='truncated in its 128-byte header'):
        load(truncated)
    for name, content in (('text.mat', b't,voltage\n0,1\n'), ('noise.mat', np.random.default_rng(5).bytes(36))):
        (tmp_path / name).write_bytes(content)
        with pytest.raises(InputError, match='not a readable MATLAB file'):
            load(tmp_path / name)


def test_an_empty_matlab_file_is_one_line(tmp_path):
    path = tmp_path / 'file.mat'
    path.touch()
    refused(emla('identify', path), 'file.mat: empty file')


@pytest.mark.parametrize('name', ['fifo.csv', 'fifo.mat', 'fifo'])
def test_a_fifo_is_refused_at_once(tmp_path, name):
    path = tmp_path / name
    os.mkfifo(path)
    refused(emla('identify', path, timeout=60), 'is a FIFO')


def test_a_device_is_refused_at_once():
    refused(emla('identify', '/dev/zero', timeout=60), 'is a device')


@pytest.mark.parametrize('case, args, place', [
    ('csv', (), 'column current at data row 3 is 1e+308'),
    ('mat', (), 'column current at element 3 is 1e+200'),
    ('units', ('--units', 'current=1e308'), 'column current at data row 1'),
    ('overflow', ('--units', 'current=1e90'), 'column current at data row 3 is inf in SI (1e+300 times'),
])
def test_values_beyond_what_the_suite_computes_with_are_refused(tmp_path, rows, case, args, place):
    if case == 'mat':
        k = np.arange(40)
        current = np.ones(40)
        current[2] = 1e200
        path = mat(tmp_path / 'big.mat', {'t': k * 1e-3, 'voltage': np.sin(k), 'current': current, 'position': k})
    else:
        changed = [list(row) for row in rows]
        changed[2][2] = '1e308' if case == 'csv' else '1e300' if case == 'overflow' else changed[2][2]
        path = write(tmp_path / 'big.csv', changed)
    out = emla('identify', path, *args)
    refused(out, place, 'beyond the 1e+100')


def test_import_of_data_before_time_zero_is_one_line(tmp_path, rows):
    """A scope's pre-trigger samples (t < 0) identify, but a bag cannot stamp them."""
    shifted = [[f'{float(row[0]) - 0.01:.10g}', *row[1:]] for row in rows]
    path = write(tmp_path / 'pretrigger.csv', shifted)
    assert load(path).start_time == pytest.approx(-0.01)
    refused(emla('import', path, tmp_path / 'bag'), 'pretrigger.csv: the data run from t = -0.01 s')
    assert not (tmp_path / 'bag').exists()
