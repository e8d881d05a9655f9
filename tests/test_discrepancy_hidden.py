"""The discrepancy workflow on records it did not make: tests/independent_plant.py simulates the actuator
(RK4, closed PID loop, 5 mA current noise, 1 um position quantisation) with effects hidden in it, and the
workflow is not told which. Library effects must be named (with the right sign), several at once in turn;
effects the library lacks must leave the verdict `unexplained`, name nothing and be located on the signal
they depend on; a clean record must be `adequate`.
"""
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from independent_plant import random_parameters, record
from ros_isolation import REPO

from emla_core.bag import write_recording
from emla_core.data import load
from emla_identification.discrepancy import CANDIDATES, Candidate, diagnose, register_candidate

NOMINAL = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')


def diagnosed(effects, seed):
    recording, truth = record(3.0, params=random_parameters(seed=seed), effects=effects, seed=seed)
    return diagnose(recording).to_dict(), truth


@pytest.mark.parametrize('seed', [0, 1])
def test_a_clean_record_is_adequate(seed):
    result, _ = diagnosed((), seed)
    assert result['verdict'] == 'adequate' and result['missing_effect'] == 'none' and result['effects'] == []
    assert all(d['adequate'] and d['ratio'] < 1.5 for d in result['disagreement'].values())


@pytest.mark.parametrize('effect, named, check', [
    ('return_spring', 'return_spring', lambda p, s: p['spring_stiffness'] == pytest.approx(1500.0, rel=0.01)),
    ('magnetic_stiffness', 'magnetic_stiffness',    # a force toward the pole: a negative stiffness, named so
     lambda p, s: p['spring_stiffness'] == pytest.approx(-2000.0, rel=0.01)),
    ('coulomb_friction', 'coulomb_friction', lambda p, s: p['coulomb_force'] == pytest.approx(1.0, rel=0.05)),
    ('resistance_drift', 'resistance_drift', lambda p, s: p['resistance_rise'] > 0),
    ('inductance_saturation', 'inductance_saturation',
     lambda p, s: p['equivalent_saturation_current'] == pytest.approx(4.0, rel=0.15)),
    ('force_constant_variation', 'force_constant_variation', lambda p, s: p['emf_constant_curvature'] < 0),
    # a continuous delay (its held-out minimum, not a grid point): 2 samples within 3 of its sigma, itself under
    # 0.02 samples (1.99968 +- 0.0107)
    ('sensor_delay', 'sensor_delay',
     lambda p, s: abs(p['position_delay'] - 2e-4) <= 3 * s['position_delay'] and s['position_delay'] < 2e-6),
    ('drive_voltage_error', 'drive_voltage_error', lambda p, s: p['dead_time_drop'] == pytest.approx(0.5, rel=0.1)),
    # a current-sensor offset is indistinguishable from a constant voltage offset: named as the drive's, read back
    ('current_sensor_offset', 'drive_voltage_error',
     lambda p, s: p['equivalent_current_offset'] == pytest.approx(0.05, rel=0.05)),
])
def test_a_library_effect_is_named(effect, named, check):
    result, _ = diagnosed((effect,), 0)
    assert result['missing_effect'] == named, result['candidates']
    assert result['effects'][0]['effect'] == named and result['verdict'] in ('explained', 'unexplained')
    assert check(result['added_parameters'], result['added_parameters_std']), \
        (result['added_parameters'], result['added_parameters_std'])


@pytest.mark.parametrize('seed', [0, 1])
def test_two_effects_are_both_named_and_the_joint_model_is_right(seed):
    result, truth = diagnosed(('return_spring', 'resistance_drift'), seed)
    assert result['verdict'] == 'explained'
    assert sorted(e['effect'] for e in result['effects']) == ['resistance_drift', 'return_spring']
    assert result['added_parameters']['spring_stiffness'] == pytest.approx(1500.0, rel=0.05)
    final, std = result['reidentified_parameters'], result['reidentified_parameters_std']
    for name in NOMINAL:   # the nominal parameters re-identified jointly with both effects
        assert final[name] == pytest.approx(truth[name], rel=0.05)
        assert abs(final[name] - truth[name]) <= 3 * std[name], (name, final[name], truth[name], std[name])
    gaps = [e['gap_after'] for e in result['effects']]
    assert gaps[-1]['position'] < 0.5 * result['gap_before']['position']


@pytest.mark.parametrize('effect, signal', [
    pytest.param('quadratic_drag', 'velocity', marks=pytest.mark.xfail(strict=True, reason=(
        'a known regression since the discrepancy fit moved to the exact rows (issue 22, open): the drag is left '
        'unexplained, but located on position (0.40 explained) a hair before velocity (0.40)'))),
    ('cogging', 'position'),
    ('time_varying_load', 'time'),
    ('force_saturation', 'current'),
])
def test_an_effect_the_library_lacks_is_unexplained_and_located(effect, signal):
    result, _ = diagnosed((effect,), 0)
    assert result['verdict'] == 'unexplained' and result['missing_effect'] == 'unexplained'
    assert result['effects'] == [] and result['added_parameters'] == {}
    mechanical = result['disagreement']['mechanical']
    assert not mechanical['adequate'] and mechanical['size'] > 5 * mechanical['noise_floor']
    assert mechanical['depends_on'][0]['signal'] == signal, mechanical['depends_on']
    assert result['disagreement']['electrical']['adequate']     # where it is not


@pytest.fixture
def cogging_candidate():
    """The candidate a user writes after `emla discrepancy` located a disagreement on the position."""
    @register_candidate
    class Cogging(Candidate):
        name = 'cogging'
        parameters = ('cogging_sine', 'cogging_cosine')
        units = ('N', 'N')
        acts_on = ('mechanical', 'force')
        signs = (0, 0)

        def force(self, s):
            phase = 2 * np.pi * s.position / 1.3e-3
            return np.stack((np.sin(phase), np.cos(phase)))
    yield Cogging
    del CANDIDATES[Cogging.name]


def test_a_registered_candidate_explains_what_was_unexplained(cogging_candidate):
    result, _ = diagnosed(('cogging',), 0)
    assert result['verdict'] == 'explained' and result['missing_effect'] == 'cogging'
    assert result['added_parameters']['cogging_sine'] == pytest.approx(1.5, rel=0.05)


UNEXPLAINED = Path(__file__).resolve().parent.parent / 'bags' / 'example_unexplained'


def unexplained_recording():
    """The bundled bag's record: 1 s of an actuator with a cogging force the library has no candidate for."""
    return record(1.0, params=random_parameters(seed=3), effects=('cogging',), seed=3)[0]


def test_the_bundled_unexplained_bag_is_what_the_generator_writes():
    bundled, fresh = load(UNEXPLAINED), unexplained_recording()
    for name, values in fresh.signals.items():
        np.testing.assert_array_equal(bundled.signals[name], values)


def test_the_readme_walkthrough_of_an_unexplained_disagreement_runs():
    """The README's Python block: `unexplained`, located on the position; a user's candidate then named."""
    readme = (REPO / 'README.md').read_text()
    section = readme[readme.index('### Find what the model is missing'):readme.index('### The ROS 2 graph')]
    code = re.search(r'```python\n(.*?)```', section, re.S).group(1)
    out = subprocess.run([sys.executable, '-c', code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ['unexplained', 'position', 'explained', 'cogging']


if __name__ == '__main__':   # regenerate the bundled bag
    shutil.rmtree(UNEXPLAINED, ignore_errors=True)
    write_recording(unexplained_recording(), UNEXPLAINED, custom_data={
        'hidden_effect': 'cogging (1.5 N, pitch 1.3 mm; not in the library)',
        'generator': 'tests/test_discrepancy_hidden.py'})
    print(f'wrote {UNEXPLAINED}')
