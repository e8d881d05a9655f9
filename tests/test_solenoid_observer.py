"""The sensorless position of a solenoid (emla_identification.solenoid_observer) on the independent generator
(tests/solenoid_generator.py: 5 mA current noise, a 4.9 mA ADC step): L(x) and the mechanics identified on a bench
record with position, the position then estimated on other records from their voltage and current alone while
the coil's R rises 20 %, against the generator's position; bad input is one clear line."""
import json

import numpy as np
import pytest
from solenoid_generator import STOPS, record

from emla_cli.cli import main
from emla_core.errors import InputError
from emla_core.recording import write_csv
from emla_identification.solenoid import identify_solenoid
from emla_identification.solenoid_observer import PositionObserver, observe_position, observer_model

RATE, SECONDS, RISE = 5000.0, 2.0, 0.2
STROKE = STOPS[1] - STOPS[0]


@pytest.fixture(scope='module')
def bench():
    recording, _ = record(duration=SECONDS, rate=RATE, seed=31)
    return identify_solenoid(recording)


@pytest.fixture(scope='module')
def rising():
    """A record (seed 32) whose R rises 20 %, and its R at the end."""
    recording, truth = record(duration=SECONDS, rate=RATE, seed=32, resistance_rise=RISE)
    return recording, truth['resistance'] * (1 + RISE * (1 - 0.5 / len(recording)))


def observed(bench, recording, smooth=True):
    """(the estimate from the record's voltage and current alone, its RMS position error over the stroke)."""
    params, noise = observer_model(bench)
    estimate = observe_position(params, recording.sample_period, recording.signals['voltage'],
                                recording.signals['current'], current_noise=noise, smooth=smooth)
    error = estimate.position - recording.signals['position']
    return estimate, np.sqrt(np.mean(error ** 2)) / STROKE


@pytest.mark.parametrize('smooth', [True, False])
def test_the_position_within_two_percent_of_the_stroke_while_r_rises(bench, rising, smooth):
    """Issue 24's 2 % of the stroke, offline (0.53 % measured) and causal (0.83 %); R followed to its rise."""
    recording, final = rising
    estimate, share = observed(bench, recording, smooth)
    assert share < 0.02
    assert estimate.resistance[-1] == pytest.approx(final, rel=1e-3)
    assert abs(estimate.resistance[-1] - final) < 3 * estimate.resistance_std[-1]
    assert estimate.held.mean() < 0.02


def test_the_position_std_covers_the_error(bench, rising):
    """The reported one-sigma: resting, 3 sigma covers all but a few samples (the landings); in flight 95 % (the
    mechanics identified within 2 % and the landings make it optimistic by 1.4-2.5x there)."""
    recording, _ = rising
    estimate, _ = observed(bench, recording)
    x = recording.signals['position']
    outside = np.abs(estimate.position - x) > 3 * estimate.position_std
    flight = (x > STOPS[0]) & (x < STOPS[1])
    assert outside[~flight].mean() < 0.005 and outside[flight].mean() < 0.07
    assert np.all(np.isfinite(estimate.position_std)) and np.all(estimate.position_std > 0)


@pytest.mark.parametrize('seed', [34, 35, 36, 37])
def test_other_records_and_a_constant_r_within_two_percent(bench, seed):
    """Other records, R rising and constant (0.47-0.72 % measured, causal 0.58-0.92 %)."""
    for rise in (0.0, RISE):
        recording, _ = record(duration=SECONDS, rate=RATE, seed=seed, resistance_rise=rise)
        assert observed(bench, recording)[1] < 0.02
        assert observed(bench, recording, smooth=False)[1] < 0.02


def test_a_valve_with_eddy_currents_is_observed_through_them():
    """Eddy currents (0.01 S, the generator's own form): the bench fit with them (identify_solenoid eddy=True, its
    JSON through observer_model) gives the observer I = (M_c + G u) / (1 + R G) and the mechanics M_c: within 1 %
    of the stroke with R followed (0.50 % measured), where the same model without them is 1.71 %."""
    eddy = {'eddy_conductance': 0.01, 'eddy_time': 0.0}
    bench_record, _ = record(duration=SECONDS, rate=RATE, seed=31, params=eddy)
    params, noise = observer_model(identify_solenoid(bench_record, eddy=True).to_dict())
    recording, truth = record(duration=1.0, rate=RATE, seed=32, resistance_rise=RISE / 2, params=eddy)
    errors = []
    for model in (params, params.replace(eddy_conductance=0.0)):
        estimate = observe_position(model, recording.sample_period, recording.signals['voltage'],
                                    recording.signals['current'], current_noise=noise)
        errors.append(np.sqrt(np.mean((estimate.position - recording.signals['position']) ** 2)) / STROKE)
        if not errors[1:]:
            assert estimate.resistance[-1] == pytest.approx(truth['resistance'] * (1 + RISE / 2), rel=1e-3)
    assert params.eddy_conductance == pytest.approx(0.01, rel=0.02)
    assert errors[0] < 0.01 and errors[1] > 2 * errors[0]


def test_online_frame_by_frame_and_after_lost_samples(bench, rising):
    """The causal filter frame by frame (the identifier node's PositionObserver) is observe_position's without the
    smoother, exactly; after 10 ms of lost samples (gap()) it is back within 2 % of the stroke 0.1 s later (it
    starts anywhere on the stroke, its flux from the current, until the current and the mechanics place it)."""
    recording, final = rising
    u, i, x = (recording.signals[name] for name in ('voltage', 'current', 'position'))
    params, noise = observer_model(bench)
    causal = observe_position(params, recording.sample_period, u, i, current_noise=noise, smooth=False)
    observer = PositionObserver(params, recording.sample_period, current_noise=noise)
    frames = [observer.update(u[k:k + 37], i[k:k + 37])[0] for k in range(0, len(u), 37)]
    np.testing.assert_array_equal(np.concatenate(frames), causal.position)
    assert observer.resistance == causal.resistance[-1]
    observer = PositionObserver(params, recording.sample_period, current_noise=noise)
    half, lost, settle = len(u) // 2, 50, round(0.1 * RATE)
    observer.update(u[:half], i[:half])
    observer.gap()
    after, _ = observer.update(u[half + lost:], i[half + lost:])
    assert np.sqrt(np.mean((after[settle:] - x[half + lost + settle:]) ** 2)) < 0.02 * STROKE
    assert observer.resistance == pytest.approx(final, rel=1e-3)
    with pytest.raises(InputError, match='finite voltage and current of one length'):
        observer.update(u[:3], np.r_[i[:2], np.nan])


def test_bad_input_is_one_clear_error(bench):
    params, noise = observer_model(bench)
    with pytest.raises(InputError, match='one length'):
        observe_position(params, 2e-4, np.ones(10), np.ones(9), current_noise=noise)
    with pytest.raises(InputError, match='non-finite current at sample 3'):
        observe_position(params, 2e-4, np.ones(10), np.r_[np.ones(3), np.nan, np.ones(6)], current_noise=noise)
    fit = bench.to_dict()
    del fit['stroke']
    with pytest.raises(InputError, match='not a solenoid identification'):
        observer_model(fit)


def one_line_error(capsys, argv, words):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0] and 'Traceback' not in err[0], err


def test_the_cli_writes_the_position_and_refuses_bad_input_in_one_line(bench, tmp_path, capsys):
    recording, _ = record(duration=0.5, rate=RATE, seed=33, resistance_rise=RISE / 4)   # 10 %/s, as the 2 s records
    data, fit, out = tmp_path / 'valve.csv', tmp_path / 'fit.json', tmp_path / 'position.csv'
    write_csv(recording, data, ['voltage', 'current'])
    fit.write_text(json.dumps(bench.to_dict()))
    assert main(['identify', str(data), '--actuator', 'solenoid', '--observer-from', str(fit),
                 '--position-out', str(out), '--plot', str(tmp_path / 'position.png')]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary['samples'] == len(recording) and 'position_rms_error' not in summary
    assert (tmp_path / 'position.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    lines = out.read_text().splitlines()
    assert lines[0] == 't,position_estimate,position_std,resistance_estimate,held' and len(lines) == len(recording) + 1
    position = np.array([float(line.split(',')[1]) for line in lines[1:]])
    assert np.all((position >= STOPS[0]) & (position <= STOPS[1]))
    checked = tmp_path / 'checked.csv'   # a bench record with its position: the estimate judged against it
    write_csv(recording, checked, ['voltage', 'current', 'position'])
    assert main(['identify', str(checked), '--actuator', 'solenoid', '--observer-from', str(fit),
                 '--position-out', str(tmp_path / 'checked-x.csv')]) == 0
    assert 0 < json.loads(capsys.readouterr().out)['position_rms_error'] < 0.02 * STROKE
    one_line_error(capsys, ['identify', str(data), '--actuator', 'solenoid', '--observer-from', str(data),
                            '--position-out', str(tmp_path / 'x.csv')], 'cannot read it as JSON')
    one_line_error(capsys, ['identify', str(data), '--observer-from', str(fit), '--position-out',
                            str(tmp_path / 'x.csv')], '--actuator solenoid')
    one_line_error(capsys, ['identify', str(data), '--actuator', 'solenoid', '--position-out',
                            str(tmp_path / 'x.csv')], 'go together')
    write_csv(recording, data, ['voltage'])
    one_line_error(capsys, ['identify', str(data), '--actuator', 'solenoid', '--observer-from', str(fit),
                            '--position-out', str(tmp_path / 'x.csv')], 'current')
