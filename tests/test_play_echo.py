"""`emla simulate`, `emla play` into a live identifier node (grey box and ARX), and `emla echo`."""
import json
import subprocess

import numpy as np
import pytest
import yaml
from ros_isolation import VENV_BIN, processes

from emla_core.bag import read_bag

pytestmark = pytest.mark.timeout(300)
EMLA = str(VENV_BIN / 'emla')
SIGNALS = ('/emla/voltage', '/emla/current', '/emla/position')


@pytest.fixture(scope='module')
def simulated(tmp_path_factory):
    bag = tmp_path_factory.mktemp('simulate') / 'bag'
    subprocess.run([EMLA, 'simulate', '--duration', '1', '--bag', str(bag)], check=True, capture_output=True,
                   timeout=120)
    return bag


def test_simulate_writes_the_scenario_with_estimates_and_truth(simulated):
    contents = read_bag(simulated)
    assert len(contents.recording) == 10000         # 1 s at 10 kHz, as the graph records it
    assert {'voltage', 'current', 'position', 'reference', 'plant/current'} <= set(contents.recording.signals)
    assert contents.metadata['scenario'] == 'default' and float(contents.metadata['true_mass']) == 0.036
    assert contents.estimates[-1][1]['resistance'] == pytest.approx(4.0, rel=0.03)
    assert contents.truth[-1][1]['resistance'] == 4.0


def as_sqlite3(bag, path):
    """A copy of the MCAP bag `bag` in sqlite3 storage, written by rosbags (as `ros2 bag` writes by default
    before Jazzy)."""
    from rosbags.rosbag2 import Reader, StoragePlugin, Writer
    with Reader(bag) as reader, Writer(path, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        copies = {c.id: writer.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data, rihs01=c.digest,
                                              offered_qos_profiles=c.ext.offered_qos_profiles)
                  for c in reader.connections}
        for connection, stamp, data in reader.messages():
            writer.write(copies[connection.id], stamp, data)
    return path


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_a_live_identifier_fed_by_play_agrees_with_offline_identification(simulated, tmp_path, ros_env, storage):
    bag = simulated if storage == 'mcap' else as_sqlite3(simulated, tmp_path / 'sqlite3')
    params = tmp_path / 'identifier.yaml'
    params.write_text(yaml.safe_dump({'/emla/identifier': {'ros__parameters': {'use_sim_time': True}}}))
    with processes() as start:
        identifier = start([EMLA, 'run', 'identifier', '--params-file', str(params)], env=ros_env)
        play = start([EMLA, 'play', str(bag), '--rate', '0', '--wait', '60', '--topics', *SIGNALS], env=ros_env)
        _, err = play.communicate(timeout=180)
        assert play.returncode == 0, err
        assert 'paced by the live identifier' in err
        echo = start([EMLA, 'echo', '/emla/parameters', '--count', '1', '--timeout', '30'], env=ros_env)
        out, err = echo.communicate(timeout=60)
        assert echo.returncode == 0 and identifier.poll() is None, err
    online = next(yaml.safe_load_all(out))
    assert online['header']['stamp'] == {'sec': 1, 'nanosec': 0} and online['samples_used'] == 10000
    offline = json.loads(subprocess.run([EMLA, 'identify', str(simulated)], check=True, capture_output=True,
                                        text=True, timeout=120).stdout)
    # the same minimum-distance fit, started from the last estimate online and cold offline: the two runs of
    # Levenberg-Marquardt stop within 1e-8 of each other (the uncertainties are some 1e-4 of the values)
    for name, value in offline['parameters'].items():
        assert online[name] == pytest.approx(value, rel=1e-7, abs=1e-9)   # (a load force near 0 N)


def test_a_live_identifier_in_arx_mode_ends_with_the_offline_arx_model(simulated, tmp_path, ros_env):
    orders, forgetting, signals = [4, 3, 1], 0.9995, ('voltage', 'position')  # the DC-motor paper's orders
    params = tmp_path / 'identifier.yaml'
    params.write_text(yaml.safe_dump({'/emla/identifier': {'ros__parameters': {
        'use_sim_time': True, 'model': 'arx', 'orders': orders, 'forgetting': forgetting,
        'input': signals[0], 'output': signals[1]}}}))
    with processes() as start:
        identifier = start([EMLA, 'run', 'identifier', '--params-file', str(params)], env=ros_env)
        play = start([EMLA, 'play', str(simulated), '--rate', '0', '--wait', '60',
                      '--topics', *(f'/emla/{name}' for name in signals)], env=ros_env)
        _, err = play.communicate(timeout=180)
        assert play.returncode == 0, err
        assert 'paced by the live identifier' in err and 'no subscriber' not in err
        echo = start([EMLA, 'echo', '/emla/arx_model', '--count', '1', '--timeout', '30'], env=ros_env)
        out, err = echo.communicate(timeout=60)
        assert echo.returncode == 0 and identifier.poll() is None, err
    online = next(yaml.safe_load_all(out))
    assert online['header']['stamp'] == {'sec': 1, 'nanosec': 0}
    assert (online['input_signal'], online['output_signal']) == signals
    assert [online['na'], online['nb'], online['nk']] == orders and online['forgetting'] == forgetting
    assert online['samples_used'] == 10000 - 4 and online['sample_period'] == 1e-4
    offline = json.loads(subprocess.run(
        [EMLA, 'identify', str(simulated), '--model', 'arx', '--orders', *map(str, orders), '--forgetting',
         str(forgetting), '--input', signals[0], '--output', signals[1]],
        check=True, capture_output=True, text=True, timeout=120).stdout)
    assert online['a'] == pytest.approx(offline['a'], rel=1e-9) and online['b'] == pytest.approx(offline['b'], rel=1e-9)
    for roots in ('poles', 'zeros'):
        pairs = np.column_stack((online[f'{roots}_real'], online[f'{roots}_imag']))
        assert pairs == pytest.approx(np.array(offline[roots]), rel=1e-9, abs=1e-12), roots
    assert online['fit_percent'] == pytest.approx(offline['fit_percent'], rel=1e-6)
    assert online['mse'] == pytest.approx(offline['mse'], rel=1e-6)
    assert abs(online['prediction_error']) < 10 * offline['mse'] ** 0.5


def test_echo_prints_yaml_documents_with_long_arrays_shortened(simulated, ros_env):
    with processes() as start:
        echo = start([EMLA, 'echo', '/emla/current', '--count', '3', '-l', '5', '--timeout', '60'], env=ros_env)
        full = start([EMLA, 'echo', '/emla/position', '--count', '2', '-l', '5', '--full-length', '--timeout', '60'],
                     env=ros_env)
        play = start([EMLA, 'play', str(simulated), '--rate', '1', '--wait', '60',
                      '--topics', '/emla/current', '/emla/position'], env=ros_env)
        outputs = [proc.communicate(timeout=120) for proc in (echo, full, play)]
    assert [p.returncode for p in (echo, full, play)] == [0, 0, 0], outputs
    docs = [d for d in yaml.safe_load_all(outputs[0][0]) if d]
    assert len(docs) == 3 and outputs[0][0].count('---\n') == 3
    assert docs[0]['sample_period'] == 1e-4 and docs[0]['header']['stamp'] == {'sec': 0, 'nanosec': 0}
    assert len(docs[0]['data']) == 1 and docs[1]['data'][-1] == '...' and len(docs[1]['data']) == 6
    first, second = [d for d in yaml.safe_load_all(outputs[1][0]) if d]
    assert len(first['data']) == 1 and len(second['data']) == 10    # the state at t = 0, then a 1 ms frame


def test_echo_without_a_publisher_is_one_clear_line(ros_env):
    with processes() as start:
        echo = start([EMLA, 'echo', '/emla/nothing', '--timeout', '1'], env=ros_env)
        out, err = echo.communicate(timeout=60)
    assert echo.returncode == 1 and out == ''
    assert err.strip().count('\n') == 0 and 'no publisher of /emla/nothing within 1 s' in err


def test_play_of_an_unreadable_bag_is_one_clear_line(tmp_path):
    (tmp_path / 'metadata.yaml').write_text('{not yaml')
    out = subprocess.run([EMLA, 'play', str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and 'Traceback' not in out.stderr and str(tmp_path) in out.stderr
