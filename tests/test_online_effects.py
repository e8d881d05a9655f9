"""Effects estimated online with the nominal parameters (emla_identification.online_effects), judged against
the true parameters of closed-loop records with current noise and 1 um position quantisation: the independent
plant (tests/independent_plant.py: a dithered PID loop, an elasto-plastic friction) and emla_sim's.
"""
import numpy as np
import pytest
from independent_plant import make_effect, record

from emla_bench import scenarios
from emla_core.errors import InputError
from emla_core.model_file import Model, ModelEffect
from emla_identification.online import OnlineIdentifier
from emla_identification.online_effects import EffectColumns, columns_for
from emla_identification.regressors import RowStream

EFFECTS = ('coulomb_friction', 'return_spring')
FRAME = 500


def feed(identifier, recording, frame=FRAME):
    s = recording.signals
    for start in range(0, len(recording), frame):
        identifier.update(*(s[name][start:start + frame] for name in ('voltage', 'current', 'position')))
    return identifier


@pytest.fixture(scope='module')
def independent():
    return record(duration=3.0, effects=[make_effect('coulomb_friction', force=1.0),
                                         make_effect('return_spring', stiffness=1500.0, rest_position=1e-3)], seed=1)


def test_friction_and_spring_converge_to_the_truth_on_independent_data(independent):
    recording, truth = independent
    values, std = feed(OnlineIdentifier(recording.sample_period, effects=EFFECTS), recording).estimate()
    assert values['coulomb_force'] == pytest.approx(1.0, rel=0.05)
    assert values['spring_stiffness'] == pytest.approx(1500.0, rel=0.05)
    for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping'):
        assert values[name] == pytest.approx(truth[name], rel=0.05), name
    # the spring's centre merges with the load force: reported as the total at x = 0, Fl - k x0
    assert values['load_force'] == pytest.approx(truth['load_force'] - 1500.0 * 1e-3, abs=0.15)
    for name in ('coulomb_force', 'spring_stiffness', 'load_force'):
        assert 0.0 < std[name] < 0.05 * max(abs(values[name]), 1.0), name


def test_friction_and_spring_converge_on_emla_sim_closed_loop_data():
    scenario = scenarios.get('friction_and_spring')
    recording = scenario.run_case('adaptive_nominal_model', duration=3.0).recording
    values, std = feed(OnlineIdentifier(recording.sample_period, effects=EFFECTS), recording).estimate()
    assert values['coulomb_force'] == pytest.approx(1.0, rel=0.05)
    assert values['spring_stiffness'] == pytest.approx(1500.0, rel=0.05)
    assert values['mass'] == pytest.approx(scenario.params.mass, rel=0.02)
    assert abs(values['coulomb_force'] - 1.0) < 4 * std['coulomb_force']


def test_with_forgetting_one_the_estimate_is_the_batch_solution_with_the_added_columns(independent):
    recording, _ = independent
    online = feed(OnlineIdentifier(recording.sample_period, effects=EFFECTS), recording, frame=333)
    stream = RowStream(('mechanical',), recording.sample_period)
    phi, y, zeta = stream.rows(recording.signals)['mechanical']
    extra, skipped = EffectColumns(columns_for(EFFECTS, 1.0), recording.sample_period).rows(
        recording.signals['position'], ('mechanical',))
    columns, instruments = extra['mechanical']
    # instrumental variables: the friction's column is its own instrument, the spring's x_k-2
    assert np.array_equal(instruments[:, 0], columns[:, 0]) and EFFECTS[1] == 'return_spring'
    phi, zeta, y = np.hstack((phi, columns))[~skipped], np.hstack((zeta, instruments))[~skipped], y[~skipped]
    # the recursion's prior (theta 0, covariance 1e6 I) is the ridge term 1e-6 I of the normal equations
    batch = np.linalg.solve(zeta.T @ phi + 1e-6 * np.eye(phi.shape[1]), zeta.T @ y)
    assert online._rls['mechanical'].theta == pytest.approx(batch, rel=1e-6)


def test_without_effects_nothing_changes(independent):
    recording, _ = independent
    plain = feed(OnlineIdentifier(recording.sample_period), recording).estimate()
    empty = feed(OnlineIdentifier(recording.sample_period, effects=()), recording).estimate()
    assert plain == empty and set(plain[0]) == {'resistance', 'inductance', 'emf_constant', 'mass', 'damping',
                                                'load_force'}


def test_a_model_file_names_the_effects_and_a_gap_restarts_their_rows(independent):
    recording, _ = independent
    model = Model(1e-4, {}, [ModelEffect('coulomb_friction', 'coulomb_friction', {'coulomb_force': (1.0, 0.01)}),
                             ModelEffect('magnetic_stiffness', 'return_spring', {'spring_stiffness': (-5.0, 1.0)})])
    identifier = OnlineIdentifier(recording.sample_period, effects=model)
    assert identifier.effects == ('coulomb_force', 'spring_stiffness')
    half = len(recording) // 2
    s = recording.signals
    identifier.update(*(s[name][:half] for name in ('voltage', 'current', 'position')))
    identifier.gap()
    identifier.update(*(s[name][half + 100:] for name in ('voltage', 'current', 'position')))
    assert identifier.values()['coulomb_force'] == pytest.approx(1.0, rel=0.05)


def test_resistance_drift_is_followed_by_forgetting():
    assert OnlineIdentifier(1e-4, memory_time=0.5, effects=['resistance_drift']).effects == ()
    with pytest.raises(InputError, match='resistance_drift is followed online by forgetting'):
        OnlineIdentifier(1e-4, effects=['resistance_drift'])


@pytest.mark.parametrize('effect, reason', [
    ('inductance_saturation', 'saturation current is not a linear parameter'),
    ('sensor_delay', 'not a linear parameter'),
    ('drive_voltage_error', 'current scale is not a linear parameter'),
    ('cogging', 'unknown'),
])
def test_effects_that_cannot_run_online_are_refused_by_name(effect, reason):
    with pytest.raises(InputError, match=f'cannot estimate online: {effect} .*{reason}'):
        OnlineIdentifier(1e-4, effects=['coulomb_friction', effect])
