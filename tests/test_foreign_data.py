"""Data the suite did not make (tests/independent_data.py: an actuator simulated independently of emla_sim),
in a user's own files: a CSV in their names and units, MATLAB files, a bag of standard messages with
jittered log times. Each identifies the true parameters; wrong units or signs are warned about."""
import json
import subprocess

import numpy as np
import pytest
from independent_data import EXAMPLES, TRUTH, simulate, write_bag, write_csv, write_mat
from ros_isolation import VENV_BIN

from emla_core.errors import InputError
from emla_core.sampling import align, steady_period
from emla_core.units import parse_unit, split_header

CORE = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')
BAG_TOPICS = 'voltage=/drive/voltage,current=/drive/current,position=/joint_states:position[slider]'
MAT_COLUMNS = 't=time,voltage=coil_voltage,current=coil_current,position=stroke'


def emla(*args):
    return subprocess.run([str(VENV_BIN / 'emla'), *map(str, args)], capture_output=True, text=True, timeout=120)


def identified(*args):
    out = emla('identify', *args)
    assert out.returncode == 0, out.stderr
    assert 'Traceback' not in out.stderr
    return json.loads(out.stdout), out.stderr


def assert_truth(result, rel=0.02):
    for name in CORE:
        assert result['parameters'][name] == pytest.approx(TRUTH[name], rel=rel), name


@pytest.fixture(scope='module')
def data():
    return simulate(duration=0.3)


def test_a_csv_in_the_loggers_names_and_units(tmp_path):
    result, _ = identified(EXAMPLES / 'logger.csv')        # time_ms,u_V,i_mA,x_mm: understood from the header
    assert_truth(result)
    assert result['inputs']['current'] == {'source': 'i_mA', 'unit': 'mA', 'scale': 1e-3, 'unit_from': 'header'}
    assert result['inputs']['t']['unit'] == 'ms' and result['sampling']['period'] == pytest.approx(1e-4)
    flagged, _ = identified(EXAMPLES / 'logger.csv', '--columns', 't=time_ms,voltage=u_V,current=i_mA,position=x_mm',
                            '--units', 't=ms,current=mA,position=mm')
    assert flagged['parameters'] == result['parameters'] and flagged['inputs']['position']['unit_from'] == '--units'


@pytest.mark.parametrize('hdf5', [False, True], ids=['v5', 'v7.3'])
def test_a_matlab_file(tmp_path, data, hdf5):
    path = tmp_path / 'scope.mat'
    write_mat(path, *data, hdf5=hdf5)
    result, _ = identified(path, '--columns', MAT_COLUMNS)
    assert_truth(result)
    untimed, _ = identified(path, '--columns', MAT_COLUMNS.replace('t=time,', ''), '--sample-period', '1e-4')
    assert untimed['parameters'] == pytest.approx(result['parameters'], rel=1e-9, abs=1e-9)   # (Fl about 0 N)


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_a_bag_of_joint_states_and_float64_with_jittered_log_times(tmp_path, data, storage):
    bag = EXAMPLES / 'drive_bag' if storage == 'mcap' else tmp_path / 'bag'
    if storage != 'mcap':
        write_bag(bag, *data, storage=storage)
    result, err = identified(bag, '--topics', BAG_TOPICS)
    assert_truth(result)
    assert 0.03 < result['sampling']['jitter'] < 0.06 and 'jitter by up to' in err   # +-5 % log-time jitter
    assert result['inputs']['voltage']['time'] == 'log time'
    assert result['inputs']['position']['time'] == 'header stamps'
    csv, _ = identified(EXAMPLES / 'logger.csv')
    assert result['parameters'] == pytest.approx(csv['parameters'], rel=1e-6)   # the same samples


def test_a_bag_without_a_mapping_lists_its_topics_and_the_flag():
    out = emla('identify', EXAMPLES / 'drive_bag')
    assert out.returncode == 2 and out.stderr.count('\n') == 1 and 'Traceback' not in out.stderr
    assert '/joint_states (sensor_msgs/msg/JointState' in out.stderr and '--topics' in out.stderr


def test_discrepancy_and_import_take_the_same_flags(tmp_path):
    out = emla('discrepancy', EXAMPLES / 'drive_bag', '--topics', BAG_TOPICS)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)['inputs']['position']['topic'] == '/joint_states'
    out = emla('import', EXAMPLES / 'scope.mat', tmp_path / 'bag', '--columns', MAT_COLUMNS)
    assert out.returncode == 0, out.stderr
    assert_truth(identified(tmp_path / 'bag')[0])
    assert emla('import', EXAMPLES / 'scope.mat', tmp_path / 'bag', '--columns', MAT_COLUMNS).returncode == 2
    assert emla('import', EXAMPLES / 'scope.mat', tmp_path / 'bag', '--columns', MAT_COLUMNS,
                '--force').returncode == 0


def plain_csv(path, t, voltage, current, position):
    np.savetxt(path, np.column_stack((t, voltage, current, position)), delimiter=',',
               header='t,voltage,current,position', comments='', fmt='%.9g')


@pytest.mark.parametrize('change, flag, cause', [
    (lambda t, u, i, x: (t, u, -i, x), None, '--units current=-A'),
    (lambda t, u, i, x: (t, u, i, x * 1e3), None, '--units position=mm'),
    (lambda t, u, i, x: (t * 1e3, u, i, x), None, '--units t=ms'),
    (lambda t, u, i, x: (t, u, -i, x), '--units=current=-A', None),
], ids=['negated current', 'position in mm', 'time in ms', 'negated current, flipped back'])
def test_a_unit_or_sign_slip_is_warned_about_with_its_fix(tmp_path, data, change, flag, cause):
    path = tmp_path / 'run.csv'
    plain_csv(path, *change(*data))
    result, err = identified(path, *([flag] if flag else []))
    if cause is None:
        assert result['warnings'] == [] and 'warning' not in err
        assert_truth(result)
    else:
        assert any(cause in w for w in result['warnings']), result['warnings']
        assert 'emla identify: warning: ' in err and cause in err


def test_missing_samples_are_named_not_bridged(tmp_path, data):
    """The grey-box models take the record in segments (no row spans the gap); ARX, which would bridge it,
    names the gap."""
    t, *signals = data
    keep = np.ones(len(t), bool)
    keep[1234:1236] = False
    write_csv(tmp_path / 'gap.csv', t[keep], *(s[keep] for s in signals))
    result, _ = identified(tmp_path / 'gap.csv')
    assert [s['samples'] for s in result['segments']] == [1234, len(t) - 1236]
    assert [g['missing'] for g in result['gaps']] == [2] and result['gaps'][0]['start'] == pytest.approx(0.1234)
    assert_truth(result)
    out = emla('identify', tmp_path / 'gap.csv', '--model', 'arx')
    assert out.returncode == 2 and out.stderr.count('\n') == 1
    assert 'gap' in out.stderr and 't = 0.1233 s' in out.stderr and '2 sample(s) missing' in out.stderr


def test_units_and_headers():
    assert parse_unit('current', 'mA') == (1e-3, 'mA')
    assert parse_unit('current', '-A') == (-1.0, '-A')
    assert parse_unit('position', 'deg')[0] == pytest.approx(np.pi / 180)
    assert parse_unit('voltage', '0.5') == (0.5, '0.5')
    with pytest.raises(InputError, match='not a number nor one of'):
        parse_unit('current', 'mm')
    assert split_header('x_mm') == ('x', 'mm') and split_header('x [mm]') == ('x', 'mm')
    assert split_header('x (mm)') == ('x', 'mm') and split_header('coil_current') == ('coil_current', None)


def test_jittered_stamps_give_the_steady_grid_and_rates_are_aligned():
    rng = np.random.default_rng(0)
    true = 0.25 + 1e-3 * np.arange(2000)
    period, start, jitter, gaps = steady_period(true + rng.uniform(-1e-4, 1e-4, 2000), 'x')
    assert period == pytest.approx(1e-3, rel=1e-5) and start == pytest.approx(0.25, abs=1e-5)
    assert 0.09 < jitter < 0.12 and gaps == ()
    # one signal at 1 kHz, one at 250 Hz starting later: the slow one interpolated onto the fast grid
    fast_t, slow_t = 1e-3 * np.arange(1000), 0.0105 + 4e-3 * np.arange(200)
    _, start, values, sampling = align({'a': (fast_t, np.sin(fast_t)), 'b': (slow_t, 2 * slow_t)}, 'x')
    grid = start + 1e-3 * np.arange(len(values['a']))
    assert start == pytest.approx(0.011) and grid[-1] <= slow_t[-1] + 1e-12
    np.testing.assert_allclose(values['a'], np.sin(grid), atol=1e-12)
    np.testing.assert_allclose(values['b'], 2 * grid, atol=1e-12)
    assert 'b interpolated linearly' in sampling['how']
