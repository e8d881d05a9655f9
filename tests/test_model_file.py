"""One model everywhere: what `emla discrepancy` learns is written as a model file, identified again on new
data, compared with measurements and simulated (the plant runs it), on two records of one actuator (random
parameters around Table 1) with a Coulomb friction the workflow is not told about.

The records come from the suite's plant (emla_sim.datasets), whose friction sticks rigidly, as the
workflow's candidate models it. On the independent plant (tests/independent_plant.py), whose stuck contact
is compliant (LuGre-like), the friction is found within 1 % but the residue at the breakaways biases the
re-identified mass by some 3 % (tests/test_discrepancy_hidden.py covers that plant)."""
import json
import subprocess

import numpy as np
import pytest
import yaml
from ros_isolation import VENV_BIN

from emla_bench import scenarios
from emla_bench.node_parameters import scenario_parameters
from emla_core.bag import write_recording
from emla_core.model_file import read
from emla_core.physics import CoulombFriction
from emla_sim.datasets import closed_loop, random_parameters

NOMINAL = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')
PARAMS = random_parameters(np.random.default_rng(4), spread=0.2)     # one actuator, two records of it


def emla(*args):
    out = subprocess.run([str(VENV_BIN / 'emla'), *map(str, args)], capture_output=True, text=True, timeout=180)
    assert 'Traceback' not in out.stderr, out.stderr
    return out


@pytest.fixture(scope='module')
def learned(tmp_path_factory):
    """Records A and B of the same actuator with a 1 N friction; the model file learned from A."""
    tmp = tmp_path_factory.mktemp('model')
    truths = {}
    for name, seed, duration in (('A', 0, 1.5), ('B', 1, 3.0)):   # A: the discrepancy's, kept short
        recording, params = closed_loop(PARAMS, duration=duration, seed=seed,
                                        effects=(CoulombFriction(coulomb_force=1.0),))
        truths[name] = params.physical()
        write_recording(recording, tmp / name)
    out = emla('discrepancy', tmp / 'A', '--model-out', tmp / 'M.yaml')
    assert out.returncode == 0, out.stderr
    return tmp, truths['B']


def test_the_model_file_holds_the_nominal_model_and_the_effect_found(learned):
    tmp, _ = learned
    model = read(tmp / 'M.yaml')
    assert [e.effect for e in model.effects] == ['coulomb_friction']
    assert model.effects[0].values()['coulomb_force'] == pytest.approx(1.0, rel=0.05)
    assert set(model.parameters) >= set(NOMINAL) and all(std > 0 for _, std in model.parameters.values())
    assert model.provenance['command'].startswith('emla discrepancy') and model.sample_period == 1e-4


def test_identify_with_the_model_file_recovers_the_effect_on_new_data(learned):
    tmp, truth = learned
    out = emla('identify', tmp / 'B', '--model-file', tmp / 'M.yaml', '--model-out', tmp / 'B.yaml')
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    (effect,) = result['effects']
    assert effect['effect'] == 'coulomb_friction'
    assert effect['parameters']['coulomb_force'] == pytest.approx(1.0, rel=0.05)
    for name in NOMINAL:
        assert result['parameters'][name] == pytest.approx(truth[name], rel=0.02), name
    assert read(tmp / 'B.yaml').effects[0].values() == effect['parameters']


def test_compare_shows_the_augmented_model_fitting_better_than_the_nominal(learned, tmp_path):
    tmp, _ = learned
    assert emla('identify', tmp / 'B', '--model-out', tmp_path / 'N.yaml').returncode == 0   # nominal only
    out = emla('compare', tmp / 'B', '--model-file', tmp_path / 'N.yaml', '--model-file', tmp / 'M.yaml',
               '--plot', tmp_path / 'compare.png', '--json', tmp_path / 'compare.json')
    assert out.returncode == 0, out.stderr
    result = json.loads((tmp_path / 'compare.json').read_text())
    nominal, augmented = (result['fit_percent'][str(p)] for p in (tmp_path / 'N.yaml', tmp / 'M.yaml'))
    assert augmented['position'] > nominal['position'] + 20 and augmented['position'] > 90
    assert augmented['current'] == pytest.approx(nominal['current'], abs=1.0)
    assert result['horizon']['position']['seconds'] == pytest.approx(0.01)
    assert (tmp_path / 'compare.png').stat().st_size > 10_000


def test_simulate_runs_the_model_and_its_effect_is_found_again(learned, tmp_path):
    tmp, _ = learned
    out = emla('simulate', 'default', '--duration', '2', '--model-file', tmp / 'M.yaml', '--bag', tmp_path / 'twin')
    assert out.returncode == 0, out.stderr
    result = json.loads(emla('identify', tmp_path / 'twin', '--model-file', tmp / 'M.yaml').stdout)
    wanted = read(tmp / 'M.yaml')
    assert result['effects'][0]['parameters']['coulomb_force'] == pytest.approx(
        wanted.effects[0].values()['coulomb_force'], rel=0.05)
    for name in NOMINAL:   # the damping, the weakest, within 5 %: the law now compensates the friction
        assert result['parameters'][name] == pytest.approx(wanted.values()[name], rel=0.05 if name == 'damping'
                                                           else 0.02), name


def test_launch_gives_the_plant_node_the_models_effects(learned):
    tmp, _ = learned
    scenario = scenarios.get('default').with_model(read(tmp / 'M.yaml'))
    plant = scenario_parameters(scenario)['plant']
    assert plant['effects'] == ['coulomb_friction']
    assert plant['resistance'] == read(tmp / 'M.yaml').values()['resistance']
    assert any(p.startswith('coulomb_friction.coulomb_force=') for p in plant['effect_parameters'])
    controller = scenario_parameters(scenario)['controller']    # and the controller compensates it
    assert controller['coulomb_force'] == read(tmp / 'M.yaml').effects[0].values()['coulomb_force']


@pytest.mark.parametrize('text, problem', [
    ('{not yaml', 'not YAML'),
    ('parameters: {}\n', 'not an emla model file'),
    ('emla_model: 1\nsample_period: 1e-4\ncolour: red\n', 'unknown key(s) colour'),
    ('emla_model: 1\nsample_period: 1e-4\nparameters: {resistence: 4}\n', 'unknown parameter(s) resistence'),
    ('emla_model: 1\nsample_period: fast\n', 'sample_period must be a finite number'),
    ('emla_model: 1\nsample_period: -1e-4\n', 'sample_period must be within (0, 10] s'),
    ('emla_model: 1\nsample_period: 1e-4\nparameters: {resistance: 4, inductance: 0.002, emf_constant: 10}\n'
     'effects: [{effect: gremlins, parameters: {x: 1}}]\n',
     "no candidate 'gremlins'"),
    # nonsense the physics layer's bounds refuse (issue 19)
    ('emla_model: 1\nsample_period: 1e-4\nparameters: {resistance: -4}\n', 'parameters.resistance -4 is outside'),
    ('emla_model: 1\nsample_period: 1e-4\nparameters: {mass: 1e308}\n', 'parameters.mass 1e+308 is outside'),
    ('emla_model: 1\nsample_period: 1e-4\nparameters: {damping: {value: 2, std: -1}}\n', 'std must be >= 0'),
    ('emla_model: 1\nsample_period: 1e-4\neffects: [{effect: coulomb_friction, parameters: {coulomb_force: 2}},'
     ' {effect: coulomb_friction, parameters: {coulomb_force: -1}}]\n', 'coulomb_friction is given twice'),
    ('emla_model: 1\nsample_period: 1e-4\neffects: [{effect: coulomb_friction, parameters: {coulomb_force: -1}}]\n',
     'coulomb_force must be within [0, inf] N'),
    ('emla_model: 1\nsample_period: 1e-4\neffects: [{effect: return_spring, parameters: {spring_stiffness: 1},'
     ' settings: {colour: red}}]\n', 'unknown setting(s) colour'),
    ('emla_model: 1\nsample_period: 1e-4\neffects: [{effect: return_spring, parameters: {stiffness: 1}}]\n',
     'it needs spring_stiffness'),
    ('emla_model: 1\nsample_period: 1e-4\nparameters: ' + '[' * 5000 + ']' * 5000 + '\n', 'nested too deeply'),
])
def test_a_bad_model_file_is_one_line(learned, tmp_path, text, problem):
    tmp, _ = learned
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    out = emla('identify', tmp / 'B', '--model-file', path)
    assert out.returncode == 2 and problem in out.stderr and out.stderr.count('\n') == 1, out.stderr


def test_the_model_file_format_round_trips(tmp_path):
    from emla_core.model_file import Model, ModelEffect, write
    model = Model(1e-4, {'resistance': (4.0, 0.01), 'inductance': (0.002, None), 'emf_constant': (10.0, 0.1),
                         'mass': (0.036, None)},
                  [ModelEffect('magnetic_stiffness', 'return_spring', {'spring_stiffness': (-2000.0, 3.0)},
                               {'spring_center': 0.001})], {'data': 'x', 'command': 'test'})
    write(model, tmp_path / 'm.yaml')
    assert read(tmp_path / 'm.yaml') == model
    assert yaml.safe_load((tmp_path / 'm.yaml').read_text())['effects'][0]['effect'] == 'magnetic_stiffness'
