"""The experiments a user runs first, on records from an independent generator (bench_experiments.py, exact
ZOH by scipy): open-loop voltage steps on a sprung actuator, a PD loop on a plain encoder.

The truth is the generator's; each estimate must sit within 1 % (sprung) and within 3 of its own sigmas."""
import numpy as np
import pytest
from bench_experiments import encoder_loop, open_loop_steps
from independent_plant import record

from emla_identification.greybox import identify

COIL = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')


def _errors(result, truth, names):
    """{name: (relative error, error in sigmas)}."""
    return {n: ((result.parameters[n] - truth[n]) / truth[n], (result.parameters[n] - truth[n]) / result.std[n])
            for n in names}


@pytest.mark.parametrize('rate,seed', [(1000.0, 2), (2000.0, 1), (10000.0, 3)])
def test_open_loop_steps_on_a_sprung_actuator_give_every_parameter_and_the_spring(rate, seed):
    rec, truth = open_loop_steps(rate=rate, duration=3.0, spring=2000.0, seed=seed)
    result = identify(rec)
    errors = _errors(result, truth, COIL + ('spring_stiffness',))
    assert all(abs(rel) < 0.01 and abs(sig) < 3.0 for rel, sig in errors.values()), errors
    assert result.fit['mechanical'].adequate and result.fit['electrical'].adequate
    assert any('return spring' in note for note in result.notes)
    assert all(np.isfinite(list(result.std.values())))


@pytest.mark.parametrize('seed', [1, 2])
def test_without_the_spring_the_misfit_or_the_impossible_estimate_is_said(seed):
    rec, _ = open_loop_steps(rate=2000.0, duration=3.0, spring=2000.0, seed=seed)
    result = identify(rec, spring=False, points=1)
    assert 'spring_stiffness' not in result.parameters and result.warnings()


@pytest.mark.parametrize('effects', [(), ('coulomb_friction',)])
def test_no_spring_is_added_where_there_is_none(effects):
    rec, truth = record(effects=list(effects), seed=3)
    result = identify(rec)
    assert 'spring_stiffness' not in result.parameters and not result.notes


def test_the_electrical_model_of_a_sprung_record_is_not_corrupted():
    rec, truth = open_loop_steps(rate=2000.0, duration=3.0, spring=2000.0, seed=3)
    result = identify(rec, model='electrical')
    errors = _errors(result, truth, ('resistance', 'inductance', 'emf_constant'))
    assert all(abs(rel) < 0.01 and abs(sig) < 3.0 for rel, sig in errors.values()), errors


@pytest.mark.parametrize('duration', [10.0, pytest.param(60.0, marks=pytest.mark.slow),
                                      pytest.param(240.0, marks=pytest.mark.slow)])
def test_a_pd_loop_on_a_noiseless_one_micron_encoder_leaves_the_damping_within_its_sigmas(duration):
    rec, truth = encoder_loop(rate=10000.0, duration=duration, resolution=1e-6, current_noise=1e-3, seed=1)
    result = identify(rec)
    errors = _errors(result, truth, COIL)
    assert all(abs(sig) < 3.0 for _, sig in errors.values()), errors
    assert abs(errors['damping'][0]) < 0.02, errors


def test_noise_on_a_logged_voltage_is_named_as_a_possible_cause_and_an_effect_is_not():
    """30 mV on the logged voltage (the noise model takes the voltage as exact): the electrical equation's low band
    is above its floor, but no signal explains what is left, and the warning says what may; an iron saturating
    leaves a residual that is a function of the current's rate, and its warning names that instead."""
    rec, _ = encoder_loop(rate=10000.0, duration=10.0, voltage_noise=0.03, current_noise=1e-3, seed=1)
    (noisy,) = [w for w in identify(rec, points=1).warnings() if 'electrical equation' in w]
    assert 'a function of no single signal' in noisy and 'voltage is a measured one' in noisy
    rec, _ = record(duration=3.0, effects=['inductance_saturation'], seed=3)
    (saturated,) = [w for w in identify(rec, points=1).warnings() if 'electrical equation' in w]
    assert 'most of it a function of' in saturated and 'voltage is a measured one' not in saturated
