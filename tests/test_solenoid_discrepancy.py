"""Issue 24, discrepancy for solenoids on the independent generator (tests/solenoid_generator.py, 5 kHz, 2 s, with a
friction of the armature Fc tanh(v / 5 mm/s), an iron saturation I_1 (sinh(psi / psi_1) - psi / psi_1), a residual
magnetism I_r tanh(psi / psi_h) or eddy currents hidden in some records): the solenoid model alone is adequate on a
clean record, a hidden friction is named with its level and the mechanics re-identified within 3 sigma, a hidden
saturation, remanence or eddy current is named by the suite's form and every parameter comes back within 3 sigma,
and the moving coil's analysis of a solenoid's record points at --actuator solenoid."""
import json

import pytest
import solenoid_generator as generator

from emla_cli.cli import main
from emla_core.model_file import read, write
from emla_core.recording import write_csv
from emla_identification.solenoid_discrepancy import diagnose_solenoid

MECHANICS = ('mass', 'damping', 'spring_stiffness', 'spring_preload')


def test_a_clean_valve_is_adequate():
    recording, _ = generator.record(duration=2.0, rate=5000.0, seed=3)
    result = diagnose_solenoid(recording).to_dict()
    assert result['verdict'] == 'adequate' and result['missing_effect'] == 'none' and result['effects'] == []
    assert all(d['adequate'] for d in result['disagreement'].values())


SATURATION = {'iron_flux': 0.02}   # Wb: psi_1 of the generator's iron (the valve shut at 3 A links 35 mWb)


@pytest.mark.parametrize('iron_current, seed', [(0.05, 6), (0.2, 7)])
def test_a_hidden_iron_saturation_is_named_and_every_parameter_comes_back(iron_current, seed, tmp_path):
    """The iron takes 1 % (0.05 A) or 6 % (0.2 A) more current at the valve's largest flux: the nominal model
    bends its inductance curve and mechanics to it (k 7 and 17 sigmas off; 0.05 A leaves both equations within
    their floors), the cubic named explains both equations and brings all eight parameters back within 3 sigma."""
    recording, truth = generator.record(duration=2.0, rate=5000.0, seed=seed,
                                        params=dict(SATURATION, iron_current=iron_current))
    diagnosis = diagnose_solenoid(recording)
    result = diagnosis.to_dict()
    assert result['verdict'] == 'explained' and [e['effect'] for e in result['effects']] == ['iron_saturation']
    for name in generator.TRUTH:
        error = result['reidentified_parameters'][name] - truth[name]
        assert abs(error) < 3.0 * result['reidentified_parameters_std'][name], name
    assert result['gap_after']['current'] < result['gap_before']['current']   # its free run: the model file's
    write(diagnosis.final.model_file('valve.csv', 'emla discrepancy'), tmp_path / 'm.yaml')
    assert read(tmp_path / 'm.yaml').solenoid().saturation_coefficient == \
        result['effects'][0]['parameters']['saturation_coefficient']


REMANENCE = {'remanence_flux': 2e-4}   # Wb: psi_h below which the generator's remanence fades


@pytest.mark.parametrize('remanence, seed', [(0.02, 6), (0.1, 7)])
def test_a_hidden_residual_magnetism_is_named_and_every_parameter_comes_back(remanence, seed):
    """The iron keeps I_r tanh(psi / psi_h) of magnetisation (the suite's candidate: a constant I_r): 0.02 A leaves
    both nominal equations within their floors, 0.1 A takes them to 8 and 11 times; named alone (the saturation,
    significant alone on 0.02 A, is dropped in the joint fit), explained, I_r and all eight parameters within 3
    sigma."""
    recording, truth = generator.record(duration=2.0, rate=5000.0, seed=seed,
                                        params=dict(REMANENCE, remanence_current=remanence))
    result = diagnose_solenoid(recording).to_dict()
    assert result['verdict'] == 'explained' and [e['effect'] for e in result['effects']] == ['residual_magnetism']
    (effect,) = result['effects']
    assert abs(effect['parameters']['remanence_current'] - remanence) < 3.0 * effect['std']['remanence_current']
    for name in generator.TRUTH:
        error = result['reidentified_parameters'][name] - truth[name]
        assert abs(error) < 3.0 * result['reidentified_parameters_std'][name], name


@pytest.mark.parametrize('conductance, lag, seed', [(0.01, 0.0, 6), (0.003, 5e-6, 7), (0.03, 5e-6, 8)])
def test_hidden_eddy_currents_are_named_and_every_parameter_comes_back(conductance, lag, seed, tmp_path):
    """The iron's eddy currents, a branch across the circuit taking G dpsi/dt, in the generator either at once (the
    suite's form, lag 0) or lagging by 5 us as a shorted turn with its own leakage: the electrical equation at 3.7
    (0.003 S) to 34 (0.03 S) times its floor; named alone, explained, G and all eight parameters within 3 sigma."""
    recording, truth = generator.record(duration=2.0, rate=5000.0, seed=seed,
                                        params={'eddy_conductance': conductance, 'eddy_time': lag})
    diagnosis = diagnose_solenoid(recording)
    result = diagnosis.to_dict()
    assert result['verdict'] == 'explained' and [e['effect'] for e in result['effects']] == ['eddy_currents']
    (effect,) = result['effects']
    assert abs(effect['parameters']['eddy_conductance'] - conductance) < 3.0 * effect['std']['eddy_conductance']
    for name in generator.TRUTH:
        error = result['reidentified_parameters'][name] - truth[name]
        assert abs(error) < 3.0 * result['reidentified_parameters_std'][name], name
    write(diagnosis.final.model_file('valve.csv', 'emla discrepancy'), tmp_path / 'm.yaml')   # what simulate runs
    assert read(tmp_path / 'm.yaml').solenoid().eddy_conductance == effect['parameters']['eddy_conductance']


def test_a_saturation_and_a_friction_together_are_both_named():
    recording, _ = generator.record(duration=2.0, rate=5000.0, seed=9,
                                    params=dict(SATURATION, iron_current=0.2, friction_force=0.2))
    result = diagnose_solenoid(recording).to_dict()
    assert result['verdict'] == 'explained'
    assert {e['effect'] for e in result['effects']} == {'friction', 'iron_saturation'}


def _diagnosed(force, seed):
    recording, truth = generator.record(duration=2.0, rate=5000.0, seed=seed, params={'friction_force': force})
    result = diagnose_solenoid(recording).to_dict()
    assert result['verdict'] == 'explained' and result['missing_effect'] == 'friction', result['candidates']
    return result, truth


@pytest.mark.parametrize('force, seed', [(0.05, 8), (0.1, 4)])
def test_a_hidden_friction_is_named_and_the_mechanics_come_back(force, seed):
    """0.05 N left the nominal force balance within its noise floor (damping and preload 7 and 8 sigmas off): the
    friction is tried on every record and named where it is significant."""
    result, truth = _diagnosed(force, seed)
    (effect,) = result['effects']
    assert abs(effect['parameters']['coulomb_force'] - force) < 3.0 * effect['std']['coulomb_force']
    assert effect['settings']['friction_speed'] > 0.0   # the smooth form found (v_s itself is loosely fixed)
    for name in MECHANICS:
        error = result['reidentified_parameters'][name] - truth[name]
        assert abs(error) < 3.0 * result['reidentified_parameters_std'][name], name
    assert result['gap_after']['position'] < result['gap_before']['position']


def test_a_strong_friction_closes_the_force_balance_with_its_level_within_its_sigma():
    """0.3 N: the force balance from 79 times its noise floor (power) to within it, Fc within 5 % and 3 sigma. The
    armature's path between the samples carries the smooth friction it is fitted with, and v_s's own uncertainty
    enters Fc's sigma (before: the path's friction was the dry, sticking one, 0.2893 +- 0.0027 N, 4.0 sigma low, v_s
    4.5 mm/s). v_s comes out 10-20 % high: the 1 um position steps put 2 mm/s of noise on the path's velocity, which
    smears the tanh (docs/physics.md §9.5)."""
    result, _ = _diagnosed(0.3, 5)
    assert result['disagreement_nominal']['mechanical']['ratio'] > 10.0
    assert result['disagreement']['mechanical']['adequate']
    assert result['gap_after']['position'] < 0.5 * result['gap_before']['position']
    (effect,) = result['effects']
    assert effect['parameters']['coulomb_force'] == pytest.approx(0.3, rel=0.05)
    assert abs(effect['parameters']['coulomb_force'] - 0.3) < 3.0 * effect['std']['coulomb_force']
    assert effect['settings']['friction_speed'] == pytest.approx(5e-3, rel=0.3)


def test_the_cli_gives_the_json_and_the_moving_coil_points_at_the_solenoid(tmp_path, capsys):
    recording, _ = generator.record(duration=1.0, rate=5000.0, seed=4, params={'friction_force': 0.1})
    path = tmp_path / 'valve.csv'
    write_csv(recording, path)
    assert main(['discrepancy', str(path), '--actuator', 'solenoid', '--json', str(tmp_path / 's.json'),
                 '--model-out', str(tmp_path / 'm.yaml')]) == 0
    result = json.loads((tmp_path / 's.json').read_text())
    assert result['actuator'] == 'solenoid' and result['missing_effect'] == 'friction'
    (effect,) = result['effects']   # what it learned is the model file: the solenoid with its friction
    learned = read(tmp_path / 'm.yaml')
    assert [e.effect for e in learned.effects] == ['friction']
    solenoid = learned.solenoid()
    assert solenoid.friction_force == effect['parameters']['coulomb_force']
    assert solenoid.friction_speed == effect['settings']['friction_speed']
    assert solenoid.mass == result['reidentified_parameters']['mass']
    capsys.readouterr()
    assert main(['discrepancy', str(path), '--actuator', 'solenoid', '--report', str(tmp_path / 'r')]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and '--report applies to the moving coil' in err[0]
    clean, _ = generator.record(duration=1.0, rate=5000.0, seed=3)   # the valve as the moving coil sees it
    write_csv(clean, tmp_path / 'clean.csv')
    assert main(['discrepancy', str(tmp_path / 'clean.csv'), '--json', str(tmp_path / 'm.json')]) == 0
    moving = json.loads((tmp_path / 'm.json').read_text())
    assert moving['verdict'] == 'unexplained'
    assert any('--actuator solenoid' in line for line in moving['warnings']), moving['warnings']
