"""Issue 24, the identifier node takes the actuator family: with `actuator: solenoid` and a solenoid's model file it
follows the coil's resistance online from the voltage balance (emla_identification.solenoid_online) on a
simulated valve's bag played into it, and publishes it on /emla/effects; its last estimate is the offline
ResistanceTracker's on the same samples. With `position_observer` and only the voltage and current played, it
publishes the armature's position (emla_identification.solenoid_observer's causal filter) frame by frame: the
library's on the same samples; within 4 % of the stroke of the bag's measured position (3.3 % measured: the causal
filter has no smoother to correct a flight from the rest at its end; offline, smoothed, 2.2-3.4 %)."""
import dataclasses
import json
import subprocess

import numpy as np
import pytest
import yaml
from ros_isolation import VENV_BIN, processes

from emla_core.bag import read_bag
from emla_core.model_file import Model, read, write
from emla_core.physics.solenoid import SolenoidParameters
from emla_identification.solenoid_observer import PositionObserver, observer_model
from emla_identification.solenoid_online import ResistanceTracker

pytestmark = pytest.mark.timeout(300)
EMLA = str(VENV_BIN / 'emla')
SIGNALS = ('/emla/voltage', '/emla/current', '/emla/position')


def _played(bag, tmp_path, ros_env, **parameters):
    """The last /emla/effects of a solenoid's identifier node (`parameters` beside actuator and sample_period) after
    the bag's measured signals were played into it."""
    params = tmp_path / 'identifier.yaml'
    params.write_text(yaml.safe_dump({'/emla/identifier': {'ros__parameters': {
        'use_sim_time': True, 'actuator': 'solenoid', 'sample_period': 2e-4, **parameters}}}))
    with processes() as start:
        identifier = start([EMLA, 'run', 'identifier', '--params-file', str(params)], env=ros_env)
        play = start([EMLA, 'play', str(bag), '--rate', '0', '--wait', '60', '--topics', *SIGNALS], env=ros_env)
        _, err = play.communicate(timeout=180)
        assert play.returncode == 0, err
        echo = start([EMLA, 'echo', '/emla/effects', '--count', '1', '--timeout', '30'], env=ros_env)
        out, err = echo.communicate(timeout=60)
        assert echo.returncode == 0 and identifier.poll() is None, err
    return next(yaml.safe_load_all(out))


@pytest.fixture(scope='module')
def valve(tmp_path_factory):
    """(bag, model file, identify's JSON) of a simulated valve (1 s), as the command line makes them."""
    where = tmp_path_factory.mktemp('valve')
    bag, model, fit = where / 'valve', where / 'valve.yaml', where / 'fit.json'
    for argv in (['simulate', '--actuator', 'solenoid', '--duration', '1', '--bag', bag],
                 ['identify', bag, '--actuator', 'solenoid', '--model-out', model, '--json', fit]):
        subprocess.run([EMLA, *map(str, argv)], check=True, capture_output=True, timeout=120)
    return bag, model, fit


def test_the_identifier_node_follows_a_solenoids_resistance(tmp_path, ros_env, valve):
    bag, model, _ = valve
    online = _played(bag, tmp_path, ros_env, model_file=str(model))
    assert online['names'] == ['resistance']
    recording = read_bag(bag).recording
    offline = ResistanceTracker(read(model).solenoid(), recording.sample_period, memory_time=1e6)
    offline.update(*(recording.signals[name] for name in ('voltage', 'current', 'position')))
    assert online['values'][0] == pytest.approx(offline.resistance, rel=1e-9)
    assert online['values'][0] == pytest.approx(6.0, rel=1e-3)   # the simulated valve's R


def test_the_identifier_node_estimates_a_solenoids_position_from_its_coil(tmp_path, ros_env, valve):
    bag, model, fit = valve
    _, noise = observer_model(json.loads(fit.read_text()))
    params = tmp_path / 'identifier.yaml'
    params.write_text(yaml.safe_dump({'/emla/identifier': {'ros__parameters': {
        'use_sim_time': True, 'actuator': 'solenoid', 'model_file': str(model), 'sample_period': 2e-4,
        'position_observer': True, 'current_noise': noise}}}))
    with processes() as start:
        identifier = start([EMLA, 'run', 'identifier', '--params-file', str(params)], env=ros_env)
        frames = start([EMLA, 'echo', '/emla/position_estimate', '--count', '20', '--full-length', '--timeout', '90'],
                       env=ros_env)
        play = start([EMLA, 'play', str(bag), '--rate', '0', '--wait', '60', '--topics', *SIGNALS[:2]], env=ros_env)
        _, err = play.communicate(timeout=180)
        assert play.returncode == 0, err
        out, err = frames.communicate(timeout=60)
        assert frames.returncode == 0, err
        echo = start([EMLA, 'echo', '/emla/effects', '--count', '1', '--timeout', '30'], env=ros_env)
        effects, err = echo.communicate(timeout=60)
        assert echo.returncode == 0 and identifier.poll() is None, err
    recording = read_bag(bag).recording
    observer = PositionObserver(read(model).solenoid(), recording.sample_period, current_noise=noise)
    offline, _ = observer.update(recording.signals['voltage'], recording.signals['current'])
    frames = [frame for frame in yaml.safe_load_all(out) if frame]
    assert len(frames) == 20
    for frame in frames:
        stamp = frame['header']['stamp']
        first = round((stamp['sec'] + 1e-9 * stamp['nanosec'] - recording.start_time) / recording.sample_period)
        assert frame['data'] == pytest.approx(offline[first:first + len(frame['data'])], rel=1e-9, abs=1e-12)
    assert next(yaml.safe_load_all(effects))['values'][0] == pytest.approx(observer.resistance, rel=1e-9)
    stroke = observer.params.stroke_max - observer.params.stroke_min
    assert np.sqrt(np.mean((offline - recording.signals['position']) ** 2)) < 0.02 * stroke   # 0.50 % measured


@pytest.fixture
def solenoid_model(tmp_path):
    """A solenoid's model file of the default parameters (as `emla identify --actuator solenoid` writes one)."""
    path = tmp_path / 'valve.yaml'
    values = dataclasses.asdict(SolenoidParameters())
    write(Model(2e-4, {k: (float(v), 0.0) for k, v in values.items()}, actuator='solenoid'), path)
    assert read(path).solenoid() == SolenoidParameters()
    return path


@pytest.mark.parametrize('parameters, named', [
    ({'actuator': 'solenoid'}, 'model_file'),
    ({'position_observer': True}, 'position_observer is for actuator solenoid'),
    ({'actuator': 'solenoid', 'model_file': 'MODEL', 'position_observer': True}, 'needs current_noise')])
def test_a_solenoid_identifier_set_up_wrong_is_one_line(tmp_path, ros_env, solenoid_model, parameters, named):
    params = tmp_path / 'identifier.yaml'
    parameters = {k: str(solenoid_model) if v == 'MODEL' else v for k, v in parameters.items()}
    params.write_text(yaml.safe_dump({'/emla/identifier': {'ros__parameters': parameters}}))
    out = subprocess.run([EMLA, 'run', 'identifier', '--params-file', str(params)], capture_output=True, text=True,
                         timeout=60, env=ros_env)
    assert out.returncode != 0 and named in out.stderr and 'Traceback' not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr


def test_the_identifier_node_identifies_a_whole_solenoid_online(tmp_path, ros_env):
    """online_model: the whole model over a moving window (2 s, refitted every second) of a simulated valve's bag
    (2 s at 5 kHz) played into the node: its last estimate on /emla/effects holds the eight parameters within 2 %
    and 3 sigma of the plant's."""
    bag = tmp_path / 'valve'
    subprocess.run([EMLA, 'simulate', '--actuator', 'solenoid', '--duration', '2', '--bag', str(bag)], check=True,
                   capture_output=True, timeout=120)
    online = _played(bag, tmp_path, ros_env, online_model=True, window_time=2.0, refit_period=1.0)
    truth = SolenoidParameters().identified()
    assert online['names'] == list(truth)
    for name, value, std in zip(online['names'], online['values'], online['std']):
        assert abs(value - truth[name]) < min(3 * std, 0.02 * truth[name]), name
