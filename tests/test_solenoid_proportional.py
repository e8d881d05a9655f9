"""A proportional solenoid held between its stops in closed loop (tests/solenoid_generator.py `closed_loop`: a PID
position loop through the generator's own force law and a current loop, its nominal parameters a few per cent off;
5 mA current noise, a 4.9 mA current ADC step, 1 um position steps), identified by emla_identification.solenoid:
R, m, B, k within 2 % of the truth and every parameter within 3 of its reported standard deviations, the fit
check adequate; `emla identify --actuator solenoid` gives its JSON; a record resting on a stop is one clear line."""
import json

import numpy as np
import pytest
from solenoid_generator import STOPS, TRUTH, _interval, closed_loop

from emla_cli.cli import main
from emla_core.errors import InputError
from emla_core.recording import Recording, write_csv
from emla_identification.solenoid import identify_solenoid

WITHIN_TWO_PERCENT = ('resistance', 'mass', 'damping', 'spring_stiffness')
RECORDS = {'1 kHz, levels, dither': dict(duration=2.0, rate=1000.0, seed=1, reference='levels', dither=0.1),
           '5 kHz, multi-sine, dither': dict(duration=1.0, rate=5000.0, seed=2, reference='multisine', dither=0.1),
           '5 kHz, levels': dict(duration=1.0, rate=5000.0, seed=1, reference='levels')}


@pytest.fixture(scope='module', params=list(RECORDS))
def held(request):
    recording, truth = closed_loop(**RECORDS[request.param])
    position = recording.signals['position']
    assert STOPS[0] < position.min() and position.max() < STOPS[1]   # never on a stop
    return recording, truth, identify_solenoid(recording)


def test_r_m_b_k_within_two_percent_and_every_parameter_within_three_sigma(held):
    _, truth, result = held
    for name in WITHIN_TWO_PERCENT:
        assert result.parameters[name] == pytest.approx(truth[name], rel=0.02), name
    for name in TRUTH:
        value, std = result.parameters[name], result.std[name]
        assert np.isfinite(value) and abs(value - truth[name]) < 3 * std, (name, value, std)
    assert all(f.adequate for f in result.fit.values()), {k: f.ratio for k, f in result.fit.items()}


def test_the_cli_gives_exit_0_and_the_json(tmp_path, capsys):
    recording, truth = closed_loop(**RECORDS['5 kHz, multi-sine, dither'])
    path = tmp_path / 'valve.csv'
    write_csv(recording, path, ['voltage', 'current', 'position'])
    assert main(['identify', str(path), '--actuator', 'solenoid', '--json', str(tmp_path / 'fit.json')]) == 0
    data = json.loads((tmp_path / 'fit.json').read_text())
    assert data['model'] == 'solenoid' and data['unresolved'] == []
    assert data['parameters']['mass'] == pytest.approx(truth['mass'], rel=0.02)
    assert all(np.isfinite(value) for value in data['std'].values())


def _shut(noise_steps, samples=1500, rate=1000.0):
    """The generator's solenoid pulled shut by a steady 15 V and held there (the record from 0.2 s on), its
    position read with a sensor that wanders by up to `noise_steps` of its 1 um steps."""
    rng = np.random.default_rng(7)
    state, psi, x = (0.0, STOPS[0], 0.0, True, 0.0), np.empty(samples), np.empty(samples)
    for k in range(samples):
        psi[k], x[k] = state[0], state[1]
        state = _interval(state, 15.0, 1.0 / rate, TRUTH)
    current = psi / (TRUTH['leakage_inductance'] + TRUTH['gap_coefficient'] / (TRUTH['gap'] - x))
    current = current + 5e-3 * rng.standard_normal(samples)
    position = np.round(x / 1e-6) * 1e-6 + 1e-6 * rng.integers(-noise_steps, noise_steps + 1, samples)
    settled = slice(int(0.2 * rate), None)   # after the armature's pull-in
    return Recording(1.0 / rate, {'voltage': np.full(samples, 15.0)[settled], 'current': current[settled],
                                  'position': position[settled]})


@pytest.mark.parametrize('noise_steps, words', [(0, 'position never changes'), (1, 'force-balance rows')])
def test_a_record_resting_on_a_stop_is_one_clear_line(tmp_path, capsys, noise_steps, words):
    recording = _shut(noise_steps)
    with pytest.raises(InputError, match=words):
        identify_solenoid(recording)
    path = tmp_path / 'shut.csv'
    write_csv(recording, path, ['voltage', 'current', 'position'])
    capsys.readouterr()
    assert main(['identify', str(path), '--actuator', 'solenoid']) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0] and 'Traceback' not in err[0], err
