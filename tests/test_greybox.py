"""Grey-box identification against independent truth: closed-loop runs of the plant it has never seen.

Truth is the plant's parameters (emla_sim.datasets); tolerances are the issue's: R, L, Km, m, B within 2 %
and Fl within 0.1 N on noisy data, 0.1 % on noise-free data (discretisation consistency).
"""
import dataclasses
import math

import numpy as np
import pytest
from actuators import ACTUATORS
from independent_plant import random_parameters as independent_parameters
from independent_plant import record as independent_record

from emla_bench import scenarios
from emla_core.errors import InputError
from emla_core.parameters import TABLE1
from emla_core.recording import Recording
from emla_identification.greybox import identify
from emla_identification.online import OnlineIdentifier
from emla_sim.datasets import TABLE2, closed_loop, force_driven, random_parameters
from emla_sim.effects import ParameterChange


def assert_close(parameters, truth, relative, load_force):
    for name, value in parameters.items():
        if name == 'load_force':
            assert abs(value - truth[name]) < load_force, (name, value, truth[name])
        else:
            assert abs(value / truth[name] - 1) < relative, (name, value, truth[name])


@pytest.mark.parametrize('params', [
    TABLE1.replace(load_force=5.0),
    TABLE1.replace(resistance=8.0, inductance=0.8e-3, load_force=-10.0),   # R Ts / L = 1
    random_parameters(np.random.default_rng(7), load_force=3.0),
], ids=['table1', 'fast-coil', 'random'])
def test_noise_free_data_identify_to_a_thousandth(params):
    recording, _ = closed_loop(params, duration=0.5, current_noise=0.0, resolution=0.0)
    assert_close(identify(recording).parameters, params.physical(), 1e-3, 1e-3)


@pytest.mark.parametrize('seed', range(8))
def test_noisy_closed_loop_random_parameters(seed):
    rng = np.random.default_rng(100 + seed)
    params = random_parameters(rng, load_force=rng.uniform(-10.0, 10.0))
    recording, _ = closed_loop(params, duration=1.0, dither=0.2, seed=seed)
    result = identify(recording)
    assert result.model == 'full' and result.samples == len(recording)
    assert_close(result.parameters, params.physical(), 0.02, 0.1)


@pytest.mark.parametrize('seed', [11, 12])
def test_current_fed_back_into_the_voltage_does_not_bias_the_estimates(seed):
    """Under the suite's inverse-system controller at 10 kHz the voltage carries the noise of the measured
    current it was computed from; least squares gave L 0.4 % low there (17 standard deviations). Every
    parameter must lie within 3.5 of its reported standard deviations (and L within 0.15 %)."""
    scenario = dataclasses.replace(scenarios.get('default'), seed=seed, duration=2.0)
    result = identify(scenario.run_case('adaptive').recording)
    truth = scenario.params.physical()
    for name, value in result.parameters.items():
        assert abs(value - truth[name]) < 3.5 * result.std[name], (name, value, truth[name], result.std[name])
    assert abs(result.parameters['inductance'] / truth['inductance'] - 1) < 1.5e-3


@pytest.mark.parametrize('condition', TABLE2, ids=lambda c: '-'.join(f'{k}={v}' for k, v in c.items()))
def test_paper_table2_conditions(condition):
    """The paper's simulation conditions (its B was 17 % off and collapsed under load); no dither here."""
    params = TABLE1.replace(**condition)
    recording, _ = closed_loop(params, duration=1.0, seed=3)
    assert_close(identify(recording).parameters, params.physical(), 0.02, 0.1)


@pytest.mark.parametrize('offset, rate', [(0.275, 20e3), (-0.1, 5e3)])
def test_a_current_sensor_offset_leaves_the_coil_and_mass_within_their_sigma_and_the_fit_says_so(offset, rate):
    """A current sensor reading I + I0 (the independent plant, another integrator): the electrical regression's
    constant I0 (1 - a) is one the physics cannot meet. Fixed to it, the fit gave R = 8.7e6 ohm and a negative
    inductance on the way (the issue-22 sweep's seed 110); freed, R, L, Km, m, B keep to their sigma, and the
    electrical equation's misfit is reported instead."""
    params = independent_parameters(seed=110, base=ACTUATORS['voice_coil'])   # a small, fast voice coil (L/R 0.15 ms)
    recording, _ = independent_record(1.0, params=params, effects=[('current_sensor_offset', {'offset': offset})],
                                      seed=3, sample_period=1.0 / rate)
    result = identify(recording, points=8)
    for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping'):
        assert abs(result.parameters[name] - params[name]) < 3.0 * result.std[name], (name, result.parameters[name])
        assert np.all(result.trajectory.parameters[name] > 0), name
    assert not result.fit['electrical'].adequate and result.warnings()


@pytest.mark.parametrize('noisy', [False, True])
def test_mechanical_only_force_data(noisy):
    for k, truth in enumerate([dict(), dict(load_force=10.0, damping=4.0), dict(mass=0.072, load_force=-20.0)]):
        options = {} if noisy else dict(force_noise=0.0, resolution=0.0)
        recording, truth = force_driven(**truth, seed=k, **options)
        result = identify(recording)
        assert result.model == 'mechanical' and set(result.parameters) == {'mass', 'damping', 'load_force'}
        assert_close(result.parameters, truth, 0.02 if noisy else 1e-3, 0.1 if noisy else 1e-3)


def test_models_report_their_parameters_only():
    params = TABLE1.replace(load_force=-5.0)
    recording, _ = closed_loop(params, duration=0.5, dither=0.2, seed=1)
    full = identify(recording)
    electrical = identify(recording, 'electrical')
    mechanical = identify(recording, 'mechanical')
    assert list(electrical.parameters) == ['resistance', 'inductance', 'emf_constant']
    assert list(mechanical.parameters) == ['mass', 'damping', 'load_force']
    for part in (electrical, mechanical):
        assert set(part.std) == set(part.parameters)
        for name, value in part.parameters.items():
            assert value == pytest.approx(full.parameters[name], rel=1e-12)
            assert 0 < part.std[name] < math.inf
    assert_close(full.parameters, params.physical(), 0.02, 0.1)


def test_convergence_trajectory_ends_at_the_estimate():
    recording, _ = closed_loop(TABLE1, duration=0.3, dither=0.2)
    result = identify(recording, points=50)
    trajectory = result.trajectory
    assert np.all(np.diff(trajectory.time) > 0)
    assert trajectory.time[-1] == pytest.approx(recording.time[-1])
    assert 45 <= len(trajectory.time) <= 60
    for name, value in result.parameters.items():
        assert trajectory.parameters[name][-1] == value
        assert trajectory.std[name][-1] == result.std[name]


def feed(identifier, recording, sizes):
    """Feed the recording in frames whose lengths cycle through `sizes`."""
    start, j = 0, 0
    signals = recording.signals
    while start < len(recording):
        stop = start + sizes[j % len(sizes)]
        identifier.update(**{name: values[start:stop] for name, values in signals.items()})
        start, j = stop, j + 1


@pytest.mark.parametrize('memory', [None, 0.1], ids=['no-forgetting', 'memory-0.1s'])
def test_online_final_estimate_equals_offline(memory):
    recording, _ = closed_loop(TABLE1.replace(load_force=5.0), duration=0.5, dither=0.2, seed=2)
    forgetting = 1.0 if memory is None else 1.0 - recording.sample_period / memory
    offline = identify(recording, forgetting=forgetting)
    for sizes in ([100], [1, 2, 3, 37, 250, 5]):
        online = OnlineIdentifier(recording.sample_period, memory_time=memory)
        feed(online, recording, sizes)
        values, std = online.estimate()
        assert online.samples == len(recording)
        for name, value in offline.parameters.items():
            assert values[name] == pytest.approx(value, rel=1e-8), name
            # the noise model inverts nearly collinear normal equations (see test_streaming.assert_same_result)
            assert std[name] == pytest.approx(offline.std[name], rel=1e-5), name


def test_online_memory_follows_a_resistance_rise():
    """R +50 % (coil heating, as in the paper's scenario) mid-run: a 50 ms memory follows it."""
    params = TABLE1.replace(load_force=5.0)
    recording, _ = closed_loop(params, duration=0.6, dither=0.2,
                               changes=[ParameterChange(0.3, 'resistance', 1.5)])
    online = OnlineIdentifier(recording.sample_period, memory_time=0.05)
    signals = recording.signals
    for start in range(0, len(recording), 100):
        online.update(**{name: values[start:start + 100] for name, values in signals.items()})
        _, std = online.estimate()
        assert all(0 < s < math.inf for s in std.values()), (start, std)  # no negative variance from forgetting
    values, _ = online.estimate()
    assert_close(values, params.scaled(resistance=1.5).physical(), 0.02, 0.1)


def test_online_mechanical_only_and_reset():
    recording, truth = force_driven(seed=4)
    online = OnlineIdentifier(recording.sample_period, 'mechanical', signals=('force', 'position'))
    feed(online, recording, [100])
    values, _ = online.estimate()
    assert values == pytest.approx(identify(recording).parameters, rel=1e-8)
    assert math.isnan(online.residual_rms)  # no voltage equation
    online.reset()
    assert online.samples == 0
    with pytest.raises(ValueError, match='needs force, position'):
        online.update(voltage=np.zeros(3), current=np.zeros(3), position=np.zeros(3))


def test_online_residual_is_the_voltage_equation_error():
    recording, _ = closed_loop(TABLE1, duration=0.3, dither=0.2)
    online = OnlineIdentifier(recording.sample_period)
    feed(online, recording, [100])
    # 5 mA current noise over beta = (1 - alpha) / R is about 0.1 V of voltage-equation error
    assert 0.05 < online.residual_rms < 0.3


def test_bad_recordings_are_input_errors():
    recording, _ = closed_loop(TABLE1, duration=0.1)
    signals = recording.signals
    short = Recording(1e-4, {k: v[:12] for k, v in signals.items()}, source='short.csv')
    with pytest.raises(InputError, match='short.csv: 12 samples are too few'):
        identify(short)
    still = Recording(1e-4, {k: np.zeros(500) for k in signals}, source='still.csv')
    with pytest.raises(InputError, match='still.csv: the data do not excite'):
        identify(still)
    broken = dict(signals, current=signals['current'].copy())
    broken['current'][40] = np.nan
    with pytest.raises(InputError, match='x.csv: non-finite current at sample 40'):
        identify(Recording(1e-4, broken, source='x.csv'))
    with pytest.raises(InputError, match="unknown model 'thermal'"):
        identify(recording, 'thermal')
    only_position = Recording(1e-4, {'position': signals['position']}, source='p.csv')
    with pytest.raises(InputError, match='p.csv: needs columns voltage, current, position'):
        identify(only_position)
    with pytest.raises(InputError, match='missing voltage'):
        identify(Recording(1e-4, {'force': signals['current'], 'current': signals['current'],
                                  'position': signals['position']}), 'electrical')


def test_reported_std_matches_the_scatter_over_noise_realisations():
    """The noise model behind std (white current noise and position quantisation, coloured by the rows):
    the one-sigma values match the spread of estimates over seeds within a factor of two (measured: 1.0-1.5;
    the white-residual formula sigma2 P overstates B 60 times here)."""
    params = TABLE1.replace(load_force=5.0)
    results = [identify(closed_loop(params, duration=0.3, dither=0.2, seed=seed)[0]) for seed in range(16)]
    for name in results[0].parameters:
        spread = np.std([r.parameters[name] for r in results], ddof=1)
        reported = np.mean([r.std[name] for r in results])
        assert 0.5 < reported / spread < 2.0, (name, reported, spread)
