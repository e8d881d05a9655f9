"""Every model file the suite writes is taken by every command on the record it came from.

`emla discrepancy --model-out` on short records of the independent plant (tests/independent_plant.py) with a hidden
return spring (a CSV) and a hidden Coulomb friction (a bag), and `emla identify --model-out` with each grey-box
model on the sprung record and on force/position data: each file is identified again (`identify --model-file`),
compared (`compare`) and simulated (`simulate`) on its record, as a user runs them one after the other. A file of
one equation is identified; compare takes the mechanical one of force/position data (its record's), and refuses
one equation of coil data in one line naming what it lacks (the exact sampled-data rows of either equation need
both); simulate refuses one equation in one line (the plant needs both).

The commands run in this process through the entry point (emla_cli.cli.main), as their users' shells run them.
"""
import io
import json
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pytest
from independent_plant import CoulombFriction as HiddenFriction
from independent_plant import ReturnSpring as HiddenSpring
from independent_plant import record

from emla_cli.cli import main
from emla_core.bag import write_recording
from emla_core.model_file import Model, ModelEffect, read, write
from emla_core.parameters import TABLE1
from emla_core.physics import CoulombFriction, ReturnSpring, make_effect
from emla_core.recording import Recording, write_csv
from emla_sim.plant import Plant
from emla_sim.sensor import Sensor, SensorConfig

DURATION = 0.3      # s at 10 kHz: the effects below are found on it, the workflow takes some 10 s a record
STIFFNESS, FRICTION = 1500.0, 1.0
WHOLE = ('discrepancy_spring', 'discrepancy_friction', 'identify_full')
ONE_EQUATION = {'identify_electrical': ('mass', 'damping', 'load_force'),
                'identify_mechanical': ('resistance', 'inductance', 'emf_constant'),
                'identify_force': ('resistance', 'inductance', 'emf_constant')}
COIL_EQUATION = ('identify_electrical', 'identify_mechanical')   # compare refuses these on coil data
EFFECT = {'discrepancy_spring': ('return_spring', 'spring_stiffness', STIFFNESS),
          'discrepancy_friction': ('coulomb_friction', 'coulomb_force', FRICTION),
          'identify_full': ('return_spring', 'spring_stiffness', STIFFNESS)}


def emla(*args):
    """(exit status, stdout, stderr) of `emla ARGS` run by the entry point."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        status = main([str(a) for a in args])
    assert 'Traceback' not in err.getvalue(), err.getvalue()
    return status, out.getvalue(), err.getvalue()


def one_line_error(result, command, *names):
    status, out, err = result
    lines = err.strip().splitlines()
    assert status == 2 and out == '' and len(lines) == 1 and lines[0].startswith(f'emla {command}: error: '), err
    assert all(name in lines[0] for name in names), lines[0]


@pytest.fixture(scope='module')
def written(tmp_path_factory):
    """{name: (the record, the model file written from it)}."""
    folder = tmp_path_factory.mktemp('roundtrip')
    sprung, _ = record(DURATION, effects=[HiddenSpring(stiffness=STIFFNESS)], seed=1)
    rubbing, _ = record(DURATION, effects=[HiddenFriction(force=FRICTION)], seed=2)
    write_csv(sprung, folder / 'sprung.csv')
    write_recording(rubbing, folder / 'rubbing')
    force = {'force': TABLE1.emf_constant * rubbing.signals['current'], 'position': rubbing.signals['position']}
    write_csv(Recording(rubbing.sample_period, force), folder / 'force.csv')
    files = {'discrepancy_spring': folder / 'sprung.csv', 'discrepancy_friction': folder / 'rubbing',
             **{f'identify_{m}': folder / 'sprung.csv' for m in ('full', 'electrical', 'mechanical')},
             'identify_force': folder / 'force.csv'}
    for name, data in files.items():
        command, model = name.split('_')
        options = ['--model', model] if model in ('full', 'electrical', 'mechanical') else []
        status, _, err = emla(command, data, *options, '--model-out', folder / f'{name}.yaml', '--json',
                              folder / f'{name}.json')
        assert status == 0, err
    return {name: (data, folder / f'{name}.yaml') for name, data in files.items()}


@pytest.mark.parametrize('name', WHOLE)
def test_the_effect_found_is_in_the_model_file(written, name):
    effect, parameter, truth = EFFECT[name]
    model = read(written[name][1])
    (entry,) = model.effects
    assert entry.effect == effect and entry.values()[parameter] == pytest.approx(truth, rel=0.05)
    assert set(model.parameters) == set(TABLE1.physical())


@pytest.mark.parametrize('name', WHOLE + tuple(ONE_EQUATION))
def test_identify_takes_the_model_file_on_its_record(written, name):
    data, path = written[name]
    status, out, err = emla('identify', data, '--model-file', path)
    assert status == 0, err
    result, model = json.loads(out), read(path)
    assert [e['effect'] for e in result.get('effects', [])] == [e.effect for e in model.effects]
    for key, (value, std) in model.parameters.items():   # the same record: the same model, within its sigmas
        assert result['parameters'][key] == pytest.approx(value, abs=3 * std), key
    for found, entry in zip(result.get('effects', []), model.effects):
        for key, (value, std) in entry.parameters.items():
            assert found['parameters'][key] == pytest.approx(value, abs=3 * std), key
    assert 'unresolved' in result


@pytest.mark.parametrize('name', WHOLE + ('identify_force',))
def test_compare_predicts_its_record_with_the_model_file(written, name):
    data, path = written[name]
    status, out, err = emla('compare', data, '--model-file', path)
    assert status == 0, err
    fit = json.loads(out)['fit_percent']
    if name == 'identify_force':   # the position from the force: the nominal model, without the friction
        assert set(fit) == {'position'} and 0.0 < fit['position'] < 90.0, fit
    else:
        assert fit['current'] > 99.0 and fit['position'] > 90.0, fit


@pytest.mark.parametrize('name', ONE_EQUATION)
def test_simulate_and_compare_on_coil_data_refuse_a_model_of_one_equation_in_one_line(written, name, tmp_path):
    data, path = written[name]
    one_line_error(emla('simulate', 'default', '--duration', '0.01', '--model-file', path, '--bag', tmp_path / 'b'),
                   'simulate', *ONE_EQUATION[name])
    if name in COIL_EQUATION:
        one_line_error(emla('compare', data, '--model-file', path), 'compare', *ONE_EQUATION[name])


@pytest.mark.parametrize('name', WHOLE)
def test_the_model_files_twin_compares_as_the_model_does_on_its_record(written, name, tmp_path):
    """`emla simulate --model-file` runs the model the file describes: compared with the same file, the twin's
    record is predicted about as well as the record the model came from."""
    data, path = written[name]
    status, _, err = emla('simulate', 'default', '--duration', '0.3', '--model-file', path, '--bag', tmp_path / 'twin')
    assert status == 0, err
    own, twin = (json.loads(emla('compare', source, '--model-file', path)[1])['fit_percent']['position']
                 for source in (data, tmp_path / 'twin'))
    assert twin > min(own, 97.0) - 1.0, (own, twin)


def open_loop(stiffness, rate=2000.0, duration=1.0, seed=1):
    """Open-loop voltage steps (random levels in +-3 V held 2-40 ms) on Table 1 with a return spring, by the suite's
    plant, 1 mA current noise and 1 um position steps: a record the nominal model alone gives no estimate from."""
    rng = np.random.default_rng(seed)
    ts = 1.0 / rate
    n = round(duration * rate)
    voltage = np.repeat(rng.uniform(-3.0, 3.0, n), rng.integers(round(2e-3 / ts), round(40e-3 / ts), n))[:n]
    plant = Plant(TABLE1.replace(load_force=0.0), effects=[ReturnSpring(spring_stiffness=stiffness)])
    truth = plant.run(voltage, ts, sampling='start')
    current, position = Sensor(SensorConfig(sample_period=ts, current_noise_std=1e-3, seed=seed)).measure(
        truth['current'], truth['position'])
    return Recording(ts, {'voltage': voltage, 'current': current, 'position': position}, source='open loop')


def test_a_sprung_models_file_is_identified_where_the_nominal_model_alone_is_not(tmp_path):
    """The model file's effects are added to the nominal model as the discrepancy workflow fits it: about the start
    its spring gives (the grey-box identification with the spring's column) where the nominal model alone gives no
    estimate, as on open-loop steps against a stiff spring."""
    write_csv(open_loop(8000.0), tmp_path / 'steps.csv')
    status, _, err = emla('identify', tmp_path / 'steps.csv', '--model', 'full')
    assert status == 2 and 'no finite estimate' in err, err
    model = Model(5e-4, {k: (1.05 * v, None) for k, v in TABLE1.physical().items()},
                  [ModelEffect('return_spring', 'return_spring', {'spring_stiffness': (7500.0, None)},
                               {'spring_center': 0.0})])
    write(model, tmp_path / 'sprung.yaml')
    status, out, err = emla('identify', tmp_path / 'steps.csv', '--model-file', tmp_path / 'sprung.yaml')
    assert status == 0, err
    result = json.loads(out)
    assert result['effects'][0]['parameters']['spring_stiffness'] == pytest.approx(8000.0, rel=0.01)
    for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping'):
        assert result['parameters'][name] == pytest.approx(getattr(TABLE1, name), rel=0.03), name


def test_the_plants_elastic_contact_holds_a_force_below_breakaway_on_its_stiffness_and_slides_above():
    params = TABLE1.replace(load_force=0.0)
    friction = CoulombFriction(coulomb_force=FRICTION, presliding_damping=50.0, presliding_displacement=5e-6)
    for force in (0.5, -0.3):   # N from a steady current: a spring Fc / delta within the band
        plant = Plant(params, effects=[friction])
        rows = plant.advance(force * params.resistance / params.emf_constant, 1e-4, 3000)
        assert rows['position'][-1] == pytest.approx(force / FRICTION * friction.presliding_displacement, rel=1e-3)
        assert abs(rows['velocity'][-1]) < 1e-6
    rigid = Plant(params, effects=[CoulombFriction(coulomb_force=FRICTION)])
    assert rigid.advance(0.5 * params.resistance / params.emf_constant, 1e-4, 3000)['position'][-1] == 0.0
    sliding = Plant(params, effects=[friction]).advance(2.0, 1e-4, 3000)
    speed = sliding['velocity'][-1]   # steady: Km (u - Km v) / R = B v + Fc
    assert params.emf_constant * (2.0 - params.emf_constant * speed) / params.resistance == pytest.approx(
        params.damping * speed + FRICTION, rel=1e-3)
    assert np.all(np.diff(sliding['position'][100:]) > 0)


def test_the_elastic_contact_beside_an_effect_the_hooks_integrate_is_the_same():
    friction = CoulombFriction(coulomb_force=FRICTION, presliding_damping=50.0, presliding_displacement=5e-6)
    neutral = make_effect('position_inductance', inductance_slope=0.0, inductance_curvature=0.0)
    compiled, hooked = Plant(TABLE1, effects=[friction]), Plant(TABLE1, effects=[friction, neutral])
    assert (compiled.integration, hooked.integration) == ('rk4', 'rk4-python')
    voltage = np.repeat(np.random.default_rng(0).uniform(-1.0, 1.0, 20), 10)   # reversals within the band
    a, b = compiled.run(voltage, 1e-4), hooked.run(voltage, 1e-4)
    np.testing.assert_allclose(b['position'], a['position'], rtol=0, atol=1e-12)




@pytest.fixture(scope='module')
def elastic_twin(tmp_path_factory):
    """(a model file whose friction's stuck contact is elastic, as the discrepancy workflow finds on
    bags/example_discrepancy, and 0.5 s of its twin's record)."""
    folder = tmp_path_factory.mktemp('elastic')
    model = Model(1e-4, {k: (v, 0.01 * abs(v)) for k, v in TABLE1.physical().items()},
                  [ModelEffect('coulomb_friction', 'coulomb_friction',
                               {'coulomb_force': (1.005, 0.0013), 'presliding_damping': (32.0, 5.1)},
                               {'presliding_displacement': 6.93e-6, 'rigid_sticking': False})])
    write(model, folder / 'friction.yaml')
    status, _, err = emla('simulate', 'default', '--duration', '0.5', '--model-file', folder / 'friction.yaml',
                          '--bag', folder / 'twin')
    assert status == 0, err
    return folder / 'friction.yaml', folder / 'twin'


def test_the_twin_of_an_elastic_contact_compares_as_its_model(elastic_twin):
    path, twin = elastic_twin
    fit = json.loads(emla('compare', twin, '--model-file', path)[1])['fit_percent']
    assert fit['position'] > 98.0, fit


def test_the_twin_of_an_elastic_contact_gives_its_friction_back(elastic_twin):
    path, twin = elastic_twin
    status, out, err = emla('identify', twin, '--model-file', path)
    assert status == 0, err
    result = json.loads(out)
    (found,) = result['effects']
    for key, value in read(path).effects[0].values().items():   # resolved, and within its sigmas
        assert key not in result['unresolved'], found
        assert found['parameters'][key] == pytest.approx(value, abs=3 * found['std'][key]), found

