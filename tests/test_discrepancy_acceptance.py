"""The discrepancy workflow's acceptance of a candidate (issue 22): a significant candidate that removes most of
the held-out one-step error is named, the share of the disagreement it removes stays within [-100 %, 100 %],
and no output holds NaN or an impossible percentage. Data: the independent RK4 plant (tests/independent_plant.py)
with the issue's pairs of hidden effects; a parameter the data resolve at a sign physics forbids is held at its
bound."""
import dataclasses
import json
import re

import pytest
from independent_plant import make_effect, record

from emla_bench import scenarios
from emla_core.physics import CoulombFriction
from emla_core.physics.candidate import CANDIDATES
from emla_identification.discrepancy import diagnose
from emla_identification.discrepancy.data import Data
from emla_identification.discrepancy.fit import fit
from emla_identification.discrepancy.measures import removed_share
from emla_identification.discrepancy.rank import assess

PERCENT = re.compile(r'(-?\d+(?:\.\d+)?) %')


def test_the_share_removed_is_bounded():
    assert removed_share(10.0, 0.0) == 1.0 and removed_share(10.0, 10.0) == 0.0
    assert removed_share(10.0, 2.5) == pytest.approx(0.75)
    assert removed_share(1.0, 140.0) == pytest.approx(-139.0 / 140.0)   # was 1 - 140 = -13900 %
    assert removed_share(0.0, 0.0) == 0.0


def assert_sensible(diagnosis):
    """No NaN or infinity in the JSON, no percentage below -100 % or above 100 % in any evidence line."""
    text = json.dumps(diagnosis.to_dict())
    assert 'nan' not in text.lower() and 'infinity' not in text.lower()
    for candidate in diagnosis.to_dict()['candidates']:
        assert not re.search(r'\b(nan|inf)\b', candidate['evidence']), candidate['evidence']
        for value in PERCENT.findall(candidate['evidence']):
            assert -100.0 <= float(value) <= 100.0, candidate['evidence']


@pytest.mark.parametrize('effects, delays, named, verdict', [
    (['resistance_drift'], {'current': 3, 'position': 3}, {'sensor_delay', 'resistance_drift'}, 'explained'),
    ([make_effect('inductance_saturation'), make_effect('coulomb_friction', force=1.0)], None,
     {'coulomb_friction', 'inductance_saturation'}, None),
], ids=['drift+delay', 'saturation+friction'])
def test_pairs_of_effects_are_both_named(effects, delays, named, verdict):
    recording, _ = record(duration=2.0, seed=4, effects=effects, delays=delays)
    diagnosis = diagnose(recording)
    result = diagnosis.to_dict()
    assert {e['effect'] for e in result['effects']} == named
    if verdict:
        assert result['verdict'] == verdict
    assert_sensible(diagnosis)


def test_a_continuous_setting_is_refined_between_its_grid_points():
    """The dead-time drop's fade current was taken from a grid of steps of 1.77x: refined continuously it brings the
    drop closer to the truth (0.6 V) and the electrical disagreement down (the grid alone: 0.637 V, ratio 7.2)."""
    recording, _ = record(duration=2.0, seed=4, effects=[make_effect(
        'drive_voltage_error', dead_time_drop=0.6, offset=0.0, current_band=0.05)])
    result = diagnose(recording).to_dict()
    (effect,) = result['effects']
    assert effect['effect'] == 'drive_voltage_error'
    assert abs(effect['parameters']['dead_time_drop'] - 0.6) < 0.01
    assert result['disagreement']['electrical']['ratio'] < 6.0


def test_a_parameter_resolved_at_a_forbidden_sign_is_held_at_its_bound_and_the_rest_refitted():
    """A 0.2 A current-sensor offset beside a force constant varying over the stroke (sweep seed 236): free, the
    drive's dead-time drop came out -3.8 V (it took up Km(x) in the back-EMF) and the candidate was rejected, so
    nothing was named. Held at zero, the bound its sign allows, the offset alone reads the sensor's within 3 sigma."""
    recording, _ = record(duration=1.5, seed=4, effects={
        'current_sensor_offset': {'offset': -0.2},
        'force_constant_variation': {'slope': -14.0, 'curvature': -1.4e4, 'center': 1.2e-3}})
    assessment = assess(fit(Data.from_recording(recording)), CANDIDATES['drive_voltage_error']())
    assert assessment.fit.candidates[-1].pinned == ('dead_time_drop',) and 'held at 0' in assessment.evidence
    assert assessment.significant and assessment.plausible
    assert assessment.parameters['dead_time_drop'] == (0.0, 0.0)
    # the final fit reports it the same way (Diagnosis.added_parameters, the model file): exactly the bound, no std
    _, values, stds = assessment.fit.each_added(assessment.fit.added_std)[-1]
    assert str(values[0]) == '0.0' and stds[0] == 0.0 and values[1] != 0.0 and stds[1] > 0.0
    offset, std = assessment.parameters['equivalent_current_offset']
    assert abs(offset + 0.2) < 3.0 * std < 1e-3


def test_an_effect_that_puts_one_named_before_it_at_a_forbidden_sign_is_not_named():
    """The bench's default record (emla_sim's plant, a 1 N Coulomb friction, 10 kHz closed loop; `make bench` times
    it on 3 s): a 1.92 N smooth friction beside the Coulomb one made the Coulomb level -0.92 N and its contact
    damping negative, and was named beside it (an assessment judged only its own candidate's signs)."""
    scenario = dataclasses.replace(scenarios.get('default'), effects=(CoulombFriction(coulomb_force=1.0),),
                                   cases={'adaptive': (True, True)})
    diagnosis = diagnose(scenario.run_case('adaptive', duration=1.5).recording)
    result = diagnosis.to_dict()
    (effect,) = result['effects']
    assert effect['effect'] == 'coulomb_friction' and result['verdict'] == 'explained'
    force, std = effect['parameters']['coulomb_force'], effect['std']['coulomb_force']
    assert abs(force - 1.0) <= 3.0 * std and std < 0.5
    assert_sensible(diagnosis)
