"""A MATLAB file without a time vector gives its sample period in a scalar variable (Ts or dt in s, fs in Hz)
(issue 21): `emla identify file.mat` uses it, `--columns t=NAME` names it, and a --sample-period that
disagrees with it is refused rather than chosen silently."""
import json
import subprocess

import numpy as np
import pytest
import scipy.io
from independent_data import TRUTH, simulate
from ros_isolation import VENV_BIN

from emla_core.data import load
from emla_core.errors import InputError

PERIOD = 1e-4    # the independent generator's sample period


@pytest.fixture(scope='module')
def data():
    return simulate(duration=0.3, sample_period=PERIOD)


def write(path, data, scalars, hdf5=False, time=False):
    """A MATLAB file of the vectors voltage, current, position (and time if `time`) and the `scalars`."""
    t, voltage, current, position = data
    vectors = {'voltage': voltage, 'current': current, 'position': position, **({'time': t} if time else {})}
    if hdf5:
        import h5py
        with h5py.File(path, 'w', userblock_size=512) as f:    # MATLAB v7.3: a 512-byte header, then HDF5
            for name, values in vectors.items():
                f[name] = values[None, :]
            for name, value in scalars.items():
                f[name] = np.array([[value]])                    # MATLAB stores a scalar as 1 x 1
                f[name].attrs['MATLAB_class'] = np.bytes_('double')
    else:
        scipy.io.savemat(path, {**{k: v[:, None] for k, v in vectors.items()}, **scalars})
    return path


def emla(*args):
    return subprocess.run([str(VENV_BIN / 'emla'), *map(str, args)], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize('hdf5', [False, True], ids=['v5', 'v7.3'])
@pytest.mark.parametrize('name, value', [('Ts', PERIOD), ('dt', PERIOD), ('fs', 1 / PERIOD), ('Fs', 1 / PERIOD),
                                         ('TS', PERIOD), ('Ts_ms', PERIOD * 1e3)])
def test_the_scalar_is_the_sample_period(tmp_path, data, hdf5, name, value):
    recording = load(write(tmp_path / 'bench.mat', data, {name: value, 'gain': 7.0}, hdf5=hdf5))
    assert recording.sample_period == pytest.approx(PERIOD, rel=1e-12)
    assert len(recording) == len(data[0]) and recording.start_time == 0.0
    assert recording.inputs['t']['source'] == name and name in recording.sampling['how']
    np.testing.assert_array_equal(recording.signals['current'], data[2])


@pytest.mark.parametrize('hdf5', [False, True], ids=['v5', 'v7.3'])
def test_identify_runs_on_vectors_and_ts(tmp_path, data, hdf5):
    path = write(tmp_path / 'scope.mat', data, {'Ts': PERIOD}, hdf5=hdf5)
    out = emla('identify', path)
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert result['sample_period'] == pytest.approx(PERIOD, rel=1e-12)
    assert result['sampling']['how'] == 'sample period from MAT variable Ts'
    for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping'):
        assert result['parameters'][name] == pytest.approx(TRUTH[name], rel=0.02), name


def test_columns_names_the_scalar(tmp_path, data):
    path = write(tmp_path / 'scope.mat', data, {'period_s': PERIOD, 'Ts': 5 * PERIOD})
    recording = load(path, columns='t=period_s')           # named: wins over the Ts the names would find
    assert recording.sample_period == pytest.approx(PERIOD, rel=1e-12)
    assert recording.inputs['t']['source'] == 'period_s'
    halved = load(path, columns='t=period_s', units='t=0.5')
    assert halved.sample_period == pytest.approx(PERIOD / 2, rel=1e-12)
    out = emla('identify', path, '--columns', 't=period_s')
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)['sample_period'] == pytest.approx(PERIOD, rel=1e-12)


def test_an_agreeing_sample_period_is_used_a_disagreeing_one_refused(tmp_path, data):
    path = write(tmp_path / 'scope.mat', data, {'Ts': PERIOD})
    same = load(path, sample_period=PERIOD * (1 + 1e-7))
    assert same.sample_period == PERIOD * (1 + 1e-7) and '--sample-period' in same.sampling['how']
    with pytest.raises(InputError, match=r'--sample-period 0\.0002 s disagrees with the file\'s Ts'):
        load(path, sample_period=2 * PERIOD)
    out = emla('identify', path, '--sample-period', 2 * PERIOD)
    assert out.returncode != 0 and 'Traceback' not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and 'disagrees' in out.stderr


def test_a_time_vector_wins_over_the_scalar(tmp_path, data):
    path = write(tmp_path / 'scope.mat', data, {'Ts': 3 * PERIOD}, time=True)
    recording = load(path)
    assert recording.sample_period == pytest.approx(PERIOD, rel=1e-9)
    assert recording.inputs['t']['source'] == 'time'


@pytest.mark.parametrize('scalars, message', [
    ({'Ts': 0.0}, 'variable Ts = 0 is no sample period'),
    ({'fs': -5.0}, 'variable fs = -5 is no sample rate'),
    ({'Ts': PERIOD, 'fs': 5000.0}, 'variables Ts and fs give different sample periods'),
    ({'gain': 3.0}, 'missing column t'),                        # a scalar of another name is no period
])
def test_unusable_periods_are_one_line(tmp_path, data, scalars, message):
    path = write(tmp_path / 'scope.mat', data, scalars)
    with pytest.raises(InputError, match=message):
        load(path)
    out = emla('identify', path)
    assert out.returncode != 0 and 'Traceback' not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and message in out.stderr
