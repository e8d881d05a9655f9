"""A trend's time axis: each recording's time from its first sample (the default), its file's modification time,
a column of absolute time or a date in its name (`emla trend --time-from`, fleet.recording_time); one warning line
when every recording has the same time (CSV records that all begin at t = 0); --start/--end on every record; and
records with missing samples identified in segments, as `emla identify` takes them.

The records are 1 s of tests/independent_data.py's actuator at 5 kHz. The Dask runs share one LocalCluster of two
worker processes (closed at the end of the module), and the command's own runs are subprocesses with a timeout."""
import json
import os
import subprocess
from datetime import datetime, timezone

import numpy as np
import pytest
from independent_data import TRUTH, simulate
from ros_isolation import VENV_BIN

from emla_core.data import load
from emla_core.errors import InputError
from emla_identification.fleet import recording_time, trend

pytestmark = pytest.mark.timeout(120)
PERIOD = 2e-4
SAMPLES = 5000                       # 1 s
GAP = (2000, 50)                     # the first sample after the gap (t = 0.4 s), samples missing
HEADER = 't,voltage,current,position'
ENV = {**os.environ, 'OPENBLAS_NUM_THREADS': '1', 'OMP_NUM_THREADS': '1', 'MKL_NUM_THREADS': '1'}
NAMES = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')


def write_record(path, seed=1, stamp=None, gap=None):
    """A CSV record of 1 s from t = 0 (t, voltage, current, position in SI); with `stamp` (s since 1970) a column
    `stamp` of each row's absolute time too; with `gap` (first, count) those samples left out (a logger that
    dropped them)."""
    t, voltage, current, position = simulate(duration=SAMPLES * PERIOD, sample_period=PERIOD, seed=seed)
    columns, header = [t, voltage, current, position], HEADER
    if stamp is not None:
        columns.append(stamp + t)
        header += ',stamp'
    table = np.column_stack(columns)
    if gap is not None:
        table = np.delete(table, np.s_[gap[0]:gap[0] + gap[1]], axis=0)
    np.savetxt(path, table, delimiter=',', header=header, comments='', fmt='%.15g')
    return path


def utc(*fields):
    return datetime(*fields, tzinfo=timezone.utc).timestamp()


def emla(*args, timeout=90):
    return subprocess.run([str(VENV_BIN / 'emla'), 'trend', *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=ENV)


@pytest.fixture(scope='module')
def client():
    """A LocalCluster of two single-threaded worker processes for the module's trends (closed after them)."""
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host='127.0.0.1', dashboard_address=None,
                      scheduler_kwargs={'dashboard': False}) as cluster, \
            Client(cluster, timeout=30, set_as_default=False) as local:
        local.wait_for_workers(2, timeout=60)
        yield local


@pytest.fixture
def at_zero(tmp_path):
    """Three CSV records that all begin at t = 0, their modification times not in the order of their names."""
    mtimes = {'run_a.csv': utc(2024, 3, 1, 9), 'run_b.csv': utc(2024, 3, 1, 7), 'run_c.csv': utc(2024, 2, 28, 23)}
    directory = tmp_path / 'runs'
    directory.mkdir()
    for seed, (name, mtime) in enumerate(mtimes.items()):
        path = write_record(directory / name, seed=seed)
        os.utime(path, (mtime, mtime))
    return directory, mtimes


# ---- recording_time alone (no Dask) ----

@pytest.mark.parametrize('name, how, expected', [
    ('run_20240131T120000.csv', 'pattern:run_%Y%m%dT%H%M%S', utc(2024, 1, 31, 12)),
    ('unit7_2024-02-29_0630.csv', r'pattern:unit\d+_%Y-%m-%d_%H%M', utc(2024, 2, 29, 6, 30)),
    ('day_20231105.mcap', 'pattern:_%Y%m%d', utc(2023, 11, 5)),
    ('x_20240131_120000_25.csv', 'pattern:%Y%m%d_%H%M%S_%f', utc(2024, 1, 31, 12) + 0.25),
    ('log_1718000000.5.csv', 'pattern:log_%s', 1718000000.5),
    ('run_2024.01.31.csv', r'pattern:run_(?P<Y>\d{4})\.(?P<m>\d\d)\.(?P<d>\d\d)', utc(2024, 1, 31)),
    ('at_100%_20240131.csv', 'pattern:100%%_%Y%m%d', utc(2024, 1, 31)),
])
def test_a_pattern_reads_the_date_and_time_in_the_name_as_utc(tmp_path, name, how, expected):
    assert recording_time(tmp_path / 'fleet' / name, how) == pytest.approx(expected, abs=1e-6)


@pytest.mark.parametrize('name, how, words', [
    ('run.csv', 'when', ['--time-from when', 'pattern:FORMAT']),
    ('run.csv', 'column:', ['--time-from column:', 'column:NAME']),
    ('run.csv', 'mtime:x', ['--time-from mtime:x']),
    ('run.csv', 'pattern:run_%Q', ['%Q is none of', '%Y']),
    ('run.csv', 'pattern:run_(%Y', ['not a regular expression']),
    ('run.csv', 'pattern:run_%H%M', ['no date in it']),
    ('run_0130.csv', 'pattern:run_%Y%m%d', ['run_0130.csv', 'does not match']),
    ('run_20241301.csv', 'pattern:run_%Y%m%d', ['run_20241301.csv', 'month must be in 1..12']),
])
def test_a_bad_time_from_or_a_name_it_misses_is_one_line(tmp_path, name, how, words):
    with pytest.raises(InputError) as raised:
        recording_time(tmp_path / name, how)
    message = str(raised.value)
    assert '\n' not in message and '--time-from' in message
    for word in words:
        assert word in message


def test_the_modification_time_and_a_column_of_absolute_time(tmp_path):
    stamp = utc(2024, 5, 6, 7, 8, 9)
    path = write_record(tmp_path / 'logger.csv', stamp=stamp)
    os.utime(path, (utc(2024, 5, 6, 8), utc(2024, 5, 6, 8)))
    assert recording_time(path) == 0.0                                      # its own start: t = 0
    assert recording_time(path, 'mtime') == utc(2024, 5, 6, 8)
    assert recording_time(path, 'column:stamp') == pytest.approx(stamp, abs=1e-6)
    windowed = load(path, start=0.5)                                        # the window's first row
    assert recording_time(path, 'column:stamp', windowed) == pytest.approx(stamp + 0.5, abs=1e-6)
    assert recording_time(path, 'start', windowed) == pytest.approx(0.5)
    assert recording_time(path, 'start', load(path, columns='t=stamp')) == pytest.approx(stamp, abs=1e-6)
    with pytest.raises(InputError, match=r'column:unix: no such column beside the signals \(has stamp\)'):
        recording_time(path, 'column:unix')
    untimed = tmp_path / 'untimed.csv'
    untimed.write_text('voltage,current,position\n' + '1,0.1,0\n' * 50)
    assert recording_time(untimed, 'start', load(untimed, sample_period=PERIOD)) is None


# ---- trend on Dask: the warning, the times it reports, gaps and windows ----

def test_csv_records_all_at_zero_are_warned_about_and_mtime_orders_them(client, at_zero):
    directory, mtimes = at_zero
    plain = trend([directory], client=client)
    assert plain.failed == [] and [r['start'] for r in plain.recordings] == [0.0, 0.0, 0.0]
    assert [os.path.basename(r['path']) for r in plain.recordings] == sorted(mtimes)     # by path, then
    assert len(plain.warnings) == 1
    warning = plain.warnings[0]
    assert '\n' not in warning and 'all 3 recordings have the same time, 0 s' in warning and '--time-from' in warning

    dated = trend([directory], time_from='mtime', client=client)
    order = sorted(mtimes, key=mtimes.get)
    assert [os.path.basename(r['path']) for r in dated.recordings] == order == ['run_c.csv', 'run_b.csv', 'run_a.csv']
    assert [r['start'] for r in dated.recordings] == [mtimes[name] for name in order]
    assert dated.warnings == []
    assert dated.table.column('start').to_pylist() == [mtimes[name] for name in order]
    for mine, theirs in zip(sorted(plain.recordings, key=lambda r: r['path']),
                            sorted(dated.recordings, key=lambda r: r['path'])):
        assert mine['parameters'] == theirs['parameters']      # the time moves them, the estimates stay

    os.utime(directory / 'run_b.csv', (mtimes['run_a.csv'],) * 2)
    os.utime(directory / 'run_c.csv', (mtimes['run_a.csv'],) * 2)   # copied together: one mtime again
    (again,) = trend([directory], time_from='mtime', client=client).warnings
    assert '(--time-from mtime)' in again


def test_names_and_columns_give_each_recording_its_time(client, tmp_path):
    stamps = [utc(2024, 1, 31, 12), utc(2024, 1, 30, 6, 15), utc(2024, 2, 1)]
    for seed, stamp in enumerate(stamps):
        name = datetime.fromtimestamp(stamp, timezone.utc).strftime('run_%Y%m%dT%H%M%S.csv')
        write_record(tmp_path / name, seed=seed, stamp=stamp + 0.125)
    named = trend([tmp_path], time_from='pattern:run_%Y%m%dT%H%M%S', client=client)
    assert [r['start'] for r in named.recordings] == sorted(stamps) and named.warnings == []
    columned = trend([tmp_path], time_from='column:stamp', client=client)
    assert [r['start'] for r in columned.recordings] == pytest.approx([s + 0.125 for s in sorted(stamps)], abs=1e-6)
    assert [r['path'] for r in columned.recordings] == [r['path'] for r in named.recordings]
    (tmp_path / 'other.csv').write_bytes((tmp_path / os.listdir(tmp_path)[0]).read_bytes())
    with pytest.raises(InputError, match=r'--time-from pattern:run_%Y%m%dT%H%M%S: 1 recording name\(s\) do not '
                                         r'match it, the first other.csv'):
        trend([tmp_path], time_from='pattern:run_%Y%m%dT%H%M%S', client=client)


def test_a_record_with_missing_samples_is_identified_in_segments_and_windows_cut_every_record(client, tmp_path):
    gapped = write_record(tmp_path / 'run_0_gapped.csv', seed=3, gap=GAP)
    whole = write_record(tmp_path / 'run_1_whole.csv', seed=4)
    result = trend([gapped, whole], client=client)
    assert result.failed == [] and [r['path'] for r in result.recordings] == [str(gapped), str(whole)]
    first, second = result.recordings
    assert first['duration'] == pytest.approx((SAMPLES - GAP[1]) * PERIOD)      # every sample but the missing
    assert second['duration'] == pytest.approx(SAMPLES * PERIOD)
    for record in result.recordings:
        assert record['warnings'] == []
        for name in NAMES:
            assert record['parameters'][name] == pytest.approx(TRUTH[name], rel=1e-2), (record['path'], name)

    cut = trend([gapped, whole], start=0.2, end=0.8, client=client)
    assert cut.failed == [] and [r['start'] for r in cut.recordings] == pytest.approx([0.2, 0.2])
    assert [r['duration'] for r in cut.recordings] == pytest.approx([0.6 - GAP[1] * PERIOD, 0.6])
    for record in cut.recordings:
        assert record['parameters']['resistance'] == pytest.approx(TRUTH['resistance'], rel=1e-2)
    assert len(cut.warnings) == 1 and 'same time, 0.2 s' in cut.warnings[0]
    with pytest.raises(InputError, match='--start 0.8 s must be before --end 0.2 s'):
        trend([gapped], start=0.8, end=0.2, client=client)


# ---- the command ----

def test_the_command_warns_in_one_line_and_takes_each_recordings_time(at_zero, tmp_path):
    directory, mtimes = at_zero
    out = emla(directory, '--workers', '1', '--json', tmp_path / 'zero.json')
    assert out.returncode == 0, out.stderr
    warnings = [line for line in out.stderr.splitlines() if 'warning' in line]
    assert len(warnings) == 1 and warnings[0].startswith('emla trend: warning: all 3 recordings have the same time')
    assert '--time-from' in warnings[0] and 'Traceback' not in out.stderr

    out = emla(directory, '--workers', '1', '--time-from', 'mtime', '--start', '0.1', '--end', '0.6',
               '--json', tmp_path / 'dated.json')
    assert out.returncode == 0, out.stderr
    assert 'warning' not in out.stderr
    dated = json.loads((tmp_path / 'dated.json').read_text())['recordings']
    assert [r['start'] for r in dated] == sorted(mtimes.values())
    assert [r['duration'] for r in dated] == pytest.approx([0.5] * 3)

    for args, words in ((['--time-from', 'pattern:unit_%Y'], '--time-from pattern:unit_%Y: 3 recording name(s)'),
                        (['--time-from', 'hour'], '--time-from hour: give start, mtime'),
                        (['--start', '0.5', '--end', '0.5'], '--start 0.5 s must be before --end 0.5 s')):
        out = emla(directory, '--workers', '1', *args, '--json', tmp_path / 'never.json', timeout=60)
        assert out.returncode == 2 and out.stdout == '', out
        lines = out.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith('emla trend: error: ') and words in lines[0], out.stderr
        assert not (tmp_path / 'never.json').exists()
