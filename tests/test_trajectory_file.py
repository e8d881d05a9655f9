"""`emla identify --trajectory FILE.csv` (issue 21): the estimates over time, one row per interval, columns t
then each parameter and its _std in SI units; the last row is the JSON's result; with forgetting on a record
whose resistance drifts (simulated here, independently of emla_sim), the rows follow the drift."""
import json
import subprocess

import numpy as np
import pytest
from independent_data import TRUTH, simulate
from ros_isolation import VENV_BIN
from scipy.linalg import expm

from emla_identification.greybox import Trajectory
from emla_identification.trajectory_file import MAX_ROWS, trajectory_points, trajectory_table, write_trajectory

TS = 1e-4
NAMES = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping', 'load_force')


def emla(*args):
    return subprocess.run([str(VENV_BIN / 'emla'), *map(str, args)], capture_output=True, text=True, timeout=120)


def write_csv(path, t, voltage, current, position):
    np.savetxt(path, np.column_stack((t, voltage, current, position)), delimiter=',',
               header='t,voltage,current,position', comments='', fmt='%.12g')
    return path


def read_rows(path):
    """(header, rows as a float array) of a trajectory file; empty cells as NaN."""
    lines = path.read_text().splitlines()
    rows = [[float(cell) if cell else np.nan for cell in line.split(',')] for line in lines[1:]]
    return lines[0].split(','), np.array(rows)


def identified(tmp_path, data, *flags):
    """(JSON result, header, rows) of `emla identify DATA --trajectory ...`."""
    out = emla('identify', data, '--json', tmp_path / 'r.json', '--trajectory', tmp_path / 'trajectory.csv', '--force',
               *flags)
    assert out.returncode == 0 and 'Traceback' not in out.stderr, out.stderr
    return (json.loads((tmp_path / 'r.json').read_text()), *read_rows(tmp_path / 'trajectory.csv'))


@pytest.fixture(scope='module')
def steady(tmp_path_factory):
    """A CSV of 0.5 s of the independent actuator at 10 kHz."""
    return write_csv(tmp_path_factory.mktemp('steady') / 'steady.csv', *simulate(duration=0.5, sample_period=TS))


def test_the_last_row_is_the_result_and_time_increases(tmp_path, steady):
    result, header, rows = identified(tmp_path, steady)
    assert header == ['t'] + [c for name in NAMES for c in (name, f'{name}_std')]
    assert 190 <= len(rows) <= 210                           # the default: about 200 rows
    time = rows[:, 0]
    assert np.all(np.diff(time) > 0) and 0.0 < time[0] and time[-1] == pytest.approx(0.5 - TS, abs=TS)
    for j, name in enumerate(NAMES):                          # exactly the JSON's figures (both round-trip floats)
        assert rows[-1, 1 + 2 * j] == result['parameters'][name], name
        assert rows[-1, 2 + 2 * j] == result['std'][name], name
    final = rows[-1, 1::2]
    assert final[:5] == pytest.approx([TRUTH[name] for name in NAMES[:5]], rel=0.02)


def test_one_row_per_interval(tmp_path, steady):
    _, _, rows = identified(tmp_path, steady, '--trajectory-interval', 0.05)
    steps = np.diff(rows[:, 0])
    assert len(rows) in (10, 11)                              # ceil(0.5 / 0.05) estimates (and the final one)
    assert steps[:9] == pytest.approx(0.05, rel=0.01)


def drifting(duration=1.0, rise=0.1, steps=100, seed=5):
    """(t, voltage, current, position, true resistance) of the independent actuator whose coil resistance rises
    by `rise` of its value over the record in `steps` equal steps (a coil warming up), under a PD position loop
    with dither; each sample interval discretised exactly (zero-order hold) at its resistance."""
    ind, km, m, b = (TRUTH[k] for k in ('inductance', 'emf_constant', 'mass', 'damping'))
    n = int(round(duration / TS))
    resistance = TRUTH['resistance'] * (1 + rise * np.floor(np.arange(n) * steps / n) / steps)
    rng = np.random.default_rng(seed)
    state, previous = np.zeros(3), 0.0
    voltage, current, position = np.empty(n), np.empty(n), np.empty(n)
    augmented = np.zeros((4, 4))
    augmented[0, 2], augmented[1, 2], augmented[2, 0], augmented[2, 1] = -km / ind, 1.0, km / m, 0.0
    augmented[2, 2], augmented[0, 3] = -b / m, 1 / ind
    discrete = {}
    for k in range(n):
        current[k] = state[0] + 5e-3 * rng.standard_normal()
        position[k] = np.round(state[1] / 1e-6) * 1e-6
        target = 2e-3 if (k * TS) % 0.04 < 0.02 else 0.0
        speed, previous = (position[k] - previous) / TS, position[k]
        voltage[k] = np.clip(8000.0 * (target - position[k]) - 20.0 * speed + 0.5 * rng.standard_normal(), -24, 24)
        if resistance[k] not in discrete:
            augmented[0, 0] = -resistance[k] / ind
            discrete[resistance[k]] = expm(augmented * TS)    # [[Ad, Bd], [0, 1]]
        step = discrete[resistance[k]]
        state = step[:3, :3] @ state + step[:3, 3] * voltage[k]
    return TS * np.arange(n), voltage, current, position, resistance


def test_with_forgetting_the_resistance_follows_its_drift(tmp_path):
    t, voltage, current, position, resistance = drifting()
    data = write_csv(tmp_path / 'warming.csv', t, voltage, current, position)
    _, header, rows = identified(tmp_path, data, '--memory-time', 0.05, '--trajectory-interval', 0.01)
    time, estimate = rows[:, 0], rows[:, header.index('resistance')]
    true = np.interp(time, t, resistance)
    settled = time > 0.15                                     # three memory times
    assert np.max(np.abs(estimate[settled] / true[settled] - 1)) < 0.01   # the issue: within 1 % after convergence
    rise = estimate[-1] - estimate[np.argmax(settled)]
    assert rise == pytest.approx(true[-1] - true[np.argmax(settled)], rel=0.25)
    # without forgetting the estimate settles on the mean instead of following
    _, _, plain = identified(tmp_path, data, '--trajectory-interval', 0.01)
    assert abs(plain[-1, 1] - resistance.mean()) < abs(plain[-1, 1] - resistance[-1])


def test_write_trajectory_and_its_table(tmp_path):
    trajectory = Trajectory(time=np.array([0.01, 0.02]), parameters={'resistance': np.array([4.1, 4.000000000000001])},
                            std={'resistance': np.array([np.nan, 1e-5])})
    write_trajectory(trajectory, tmp_path / 't.csv')
    text = 't,resistance,resistance_std\n0.01,4.1,\n0.02,4.000000000000001,1e-05\n'   # NaN: an empty cell
    assert (tmp_path / 't.csv').read_text() == text
    table = trajectory_table(trajectory)
    assert table.column_names == ['t', 'resistance', 'resistance_std']
    assert table.column('resistance_std').to_pylist() == [None, 1e-5]


def test_trajectory_points():
    assert trajectory_points(0.5, 0.05, TS) == 10 and trajectory_points(0.5, 0.03, TS) == 17
    assert trajectory_points(0.5, 2.0, TS) == 1 and trajectory_points(0.5, TS, TS) == 5000
    with pytest.raises(ValueError, match='shorter than the sample period'):
        trajectory_points(0.5, TS / 2, TS)
    with pytest.raises(ValueError, match=f'more than the {MAX_ROWS} a trajectory file holds: choose at least 0.0002'):
        trajectory_points(2.0, TS, TS)


@pytest.mark.parametrize('flags, message', [
    (['--trajectory-interval', '1e-5'], 'shorter than the sample period'),
    (['--trajectory-interval', '-1'], 'must be a number in (0, 1e+06] s'),
    (['--model', 'arx'], '--trajectory applies to the grey-box models'),
])
def test_bad_trajectory_options_are_one_line(tmp_path, steady, flags, message):
    out = emla('identify', steady, '--trajectory', tmp_path / 'x.csv', *flags)
    assert out.returncode == 2 and 'Traceback' not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and message in out.stderr
    assert not (tmp_path / 'x.csv').exists()
    alone = emla('identify', steady, '--trajectory-interval', '0.1')
    assert alone.returncode == 2 and '--trajectory-interval goes with --trajectory' in alone.stderr
    onto = emla('identify', steady, '--trajectory', steady)
    assert onto.returncode == 2 and 'an output never replaces an input' in onto.stderr
