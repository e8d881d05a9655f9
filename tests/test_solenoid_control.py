"""Issue 24, control: the solenoid's online resistance estimate on the independent generator, and the adaptive
valve scenario (emla_bench.valve) with R +30 %."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import solenoid_generator as generator

from emla_bench.scenarios import run_scenario
from emla_bench.valve import VALVE_REFERENCE
from emla_control.solenoid import SolenoidController
from emla_core.physics.solenoid import SolenoidParameters
from emla_identification.solenoid_online import ResistanceTracker
from emla_sim.sensor import Sensor, SensorConfig
from emla_sim.solenoid import SolenoidPlant

EMLA = Path(sys.executable).parent / 'emla'


def _tracked(recording, params, memory_time, frame=250):
    tracker = ResistanceTracker(SolenoidParameters(**params), recording.sample_period, memory_time=memory_time)
    s = recording.signals
    for a in range(0, len(recording), frame):
        tracker.update(s['voltage'][a:a + frame], s['current'][a:a + frame], s['position'][a:a + frame])
    return tracker


@pytest.mark.parametrize('seed', [0, 1])
def test_the_resistance_estimate_is_the_generators_within_its_sigma(seed):
    """Constant R (5 kHz, 2 s, 5 mA noise and a 4.9 mA ADC step), a memory far longer than the record: the
    weighted batch estimate of the voltage balance, within 0.05 % and 3 sigma of the truth."""
    recording, truth = generator.record(duration=2.0, rate=5000.0, seed=seed)
    tracker = _tracked(recording, {k: truth[k] for k in generator.TRUTH}, memory_time=100.0)
    assert abs(tracker.resistance / truth['resistance'] - 1.0) < 5e-4
    assert abs(tracker.resistance - truth['resistance']) < 3.0 * tracker.std


def test_the_resistance_estimate_follows_a_warming_coil_with_its_memory_time():
    """R rising 20 % over 2 s: with a 0.1 s memory the estimate at the end is R as it was one memory time
    earlier (the lag of exponential forgetting on a ramp), within 0.2 %."""
    recording, truth = generator.record(duration=2.0, rate=5000.0, seed=0, resistance_rise=0.2)
    tracker = _tracked(recording, {k: truth[k] for k in generator.TRUTH}, memory_time=0.1)
    lagged = truth['resistance'] * (1.0 + 0.2 * (2.0 - 0.1) / 2.0)
    assert abs(tracker.resistance / lagged - 1.0) < 2e-3


@pytest.fixture(scope='module')
def valve():
    return run_scenario('valve_resistance_rise')


def test_the_adaptive_valve_tracks_within_ten_percent_of_its_unchanged_plant_error(valve):
    """Issue 24: after R +30 % the adaptive case tracks within 10 % of the unchanged plant's error, where the
    fixed controller is at least twice as far off (the flux loop settles tau (R' - R) I from its command)."""
    rms = {case: m['rms_tracking_error'] for case, m in valve.metrics.items()}
    assert rms['changed_adaptive'] <= 1.1 * rms['nominal']
    assert rms['changed_fixed'] >= 2.0 * rms['changed_adaptive']
    assert rms['nominal'] < 10e-6   # m, on the 0.6 mm stroke


def test_the_valve_controller_ends_with_the_warm_coils_resistance(valve):
    run = valve.runs['changed_adaptive']
    true, used = run.true_parameters['resistance'][-1], run.model['resistance'][-1]
    assert true == pytest.approx(1.3 * 6.0)
    assert used == pytest.approx(true, rel=2e-3)
    assert valve.runs['changed_fixed'].model['resistance'][-1] == 6.0


def test_emla_scenario_runs_the_valve_and_simulate_refuses_it_in_one_line(tmp_path):
    out = subprocess.run([EMLA, 'scenario', 'valve_resistance_rise', '--json', tmp_path / 'v.json', '--plot',
                          tmp_path / 'v.png'], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    cases = json.loads((tmp_path / 'v.json').read_text())['cases']
    assert set(cases) == {'nominal', 'changed_fixed', 'changed_adaptive'}
    assert all(np.isfinite(v) for m in cases.values() for v in m.values())
    assert (tmp_path / 'v.png').stat().st_size > 10000
    out = subprocess.run([EMLA, 'simulate', 'valve_resistance_rise', '--bag', tmp_path / 'bag'],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 2 and out.stderr.count('\n') == 1 and 'emla scenario valve_resistance_rise' in out.stderr


@pytest.fixture(scope='module')
def valves(tmp_path_factory):
    """Four 2 s records of the independent generator at 5 kHz, an hour apart, the coil's R 0-15 % warmer."""
    directory = tmp_path_factory.mktemp('valves')
    truths = []
    for k in range(4):
        recording, truth = generator.record(duration=2.0, rate=5000.0, seed=40 + k,
                                            params={'resistance': 6.0 * (1.0 + 0.05 * k)})
        s = recording.signals
        t = k * 3600.0 + recording.sample_period * np.arange(len(recording))
        np.savetxt(directory / f'valve_{k}.csv', np.column_stack((t, s['voltage'], s['current'], s['position'])),
                   delimiter=',', header='t,voltage,current,position', comments='', fmt='%.15g')
        truths.append(truth)
    return directory, truths


def test_a_fleet_of_valves_is_trended_with_the_solenoids_parameters(valves):
    """`emla trend --actuator solenoid`'s library call: each recording identified as `emla identify --actuator
    solenoid` does, in time order, R within 0.05 % and 3 sigma of each one's truth."""
    from emla_identification.fleet import trend
    directory, truths = valves
    result = trend([directory], actuator='solenoid', workers=1)
    assert result.failed == [] and len(result.recordings) == 4
    for record, truth in zip(result.recordings, truths):
        assert set(record['parameters']) == set(generator.TRUTH)
        r, s = record['parameters']['resistance'], record['std']['resistance']
        assert abs(r / truth['resistance'] - 1.0) < 5e-4 and abs(r - truth['resistance']) < 3.0 * s
    assert 'resistance' in result.table.column_names


def test_trend_refuses_the_moving_coils_options_for_a_solenoid(valves):
    from emla_core.errors import InputError
    from emla_identification.fleet import trend
    with pytest.raises(InputError, match='--model and --model-file apply to the moving coil'):
        trend([valves[0]], actuator='solenoid', model='full')
    with pytest.raises(InputError, match="--actuator 'stepper'"):
        trend([valves[0]], actuator='stepper')



def _valve_loop(law, delayed, duration=0.6, ts=1e-4):
    """The valve's loop on the nominal plant, the voltage from `law(controller, current, position, reference)`
    held over the interval it is computed for or, `delayed`, over the one after (a graph's computational delay:
    the reference is then that interval's); the true position's RMS error from 0.2 s on, m."""
    params, reference = SolenoidParameters(), VALVE_REFERENCE
    start = float(np.mean(reference(0.0)[0]))
    plant, sensor = SolenoidPlant(params, initial_state=(0.0, start, 0.0)), Sensor(SensorConfig(sample_period=ts))
    controller = SolenoidController(params, control_period=ts)
    controller.reset(start)
    n = round(duration / ts)
    references = np.column_stack(reference(controller.midpoint_times(ts * np.arange(n + 1)))).tolist()
    positions, voltage = np.empty(n), 0.0
    for k in range(n):
        positions[k] = plant.position
        current, position = sensor.measure(plant.current, plant.position)
        if delayed:
            applied, voltage = voltage, law(controller, current, position, references[k + 1])
        else:
            applied = law(controller, current, position, references[k])
        plant.step(applied, ts)
    late = slice(round(0.2 / ts), n)
    return float(np.sqrt(np.mean((positions[late] - reference(ts * np.arange(n))[0][late]) ** 2)))


def test_step_ahead_makes_up_for_one_interval_of_delay():
    """A graph's controller commands the interval after the next: from the state its observer and its flux
    predict for then, the valve tracks within 5 % of the undelayed loop's error (3 um); the law on the stale
    state does more than twice as badly."""
    undelayed = _valve_loop(SolenoidController.step, False)
    assert undelayed < 5e-6
    assert _valve_loop(SolenoidController.step_ahead, True) < 1.05 * undelayed
    assert _valve_loop(SolenoidController.step, True) > 2.0 * undelayed
