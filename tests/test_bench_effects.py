"""The effects of issue 22's library part: friction that closes (smooth_friction, stribeck_friction) and the bench's
own imperfections (sensor_filter, a fractional sensor_delay), each hidden in 1 s at 10 kHz of the independent
plant (tests/independent_plant.py, which shares no code with the suite) and found by the discrepancy workflow
with its parameter within a stated tolerance; a clean record stays adequate. Also: the re-alignments on signals
of known shape, the plant's hooks against closed-form steady states, and the model file's round trip.
"""
import math

import numpy as np
import pytest
from independent_plant import random_parameters, record
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from emla_core.errors import InputError
from emla_core.model_file import Model, ModelEffect, read, write
from emla_core.parameters import TABLE1
from emla_core.physics import CoulombFriction, SmoothFriction, StribeckFriction
from emla_core.recording import Recording
from emla_identification.discrepancy import diagnose
from emla_identification.discrepancy.data import Data
from emla_identification.model import from_fit, model_on_data
from emla_sim.plant import Plant

TS = 1e-4
NEW = ('smooth_friction', 'stribeck_friction', 'sensor_filter', 'sensor_delay')


def diagnosed(effects, seed, params=None):
    recording, truth = record(1.0, params=params, effects=effects, seed=seed)
    diagnosis = diagnose(recording)
    return diagnosis, diagnosis.to_dict(), truth


def settings(diagnosis, name):
    """The settings of the named effect `name` (its variant's, from the stage that named it)."""
    return next(s.assessment.settings for s in diagnosis.stages if s.assessment.name == name)


def within_three_sigma(result, truth, names=('mass', 'damping')):
    final, std = result['reidentified_parameters'], result['reidentified_parameters_std']
    return {n: (final[n] - truth[n]) / std[n] for n in names if abs(final[n] - truth[n]) > 3.0 * std[n]}


@pytest.fixture(scope='module')
def smooth():
    """Smooth friction 1.5 N over 5 mm/s on a random actuator (+-20 %)."""
    return diagnosed([('smooth_friction', {'force': 1.5, 'speed': 5e-3})], 1, random_parameters(seed=1))


# ------------------------------------------------------------------ the workflow on the independent plant
def test_a_clean_record_is_adequate_and_no_bench_effect_is_significant():
    _, result, _ = diagnosed((), 7, random_parameters(seed=7))
    assert result['verdict'] == 'adequate' and result['effects'] == []
    assert not [c for c in result['candidates'] if c['effect'] in NEW and c['significant']], result['candidates']


def test_smooth_friction_is_named_closed_and_its_speed_estimated(smooth):
    diagnosis, result, truth = smooth
    assert [e['effect'] for e in result['effects']] == ['smooth_friction'], result['candidates']
    assert result['verdict'] == 'explained', result['disagreement']
    assert result['added_parameters']['friction_force'] == pytest.approx(1.5, rel=0.01)
    assert settings(diagnosis, 'smooth_friction')['smoothing_speed'] == pytest.approx(5e-3, rel=0.05)   # 5.04 mm/s
    assert within_three_sigma(result, truth) == {}


def test_a_sharper_smooth_friction_is_named_with_its_level():
    """2 mm/s is about seven times the measured velocity's noise (1 um steps): named with its level, the speed
    within 10 % (1.90 mm/s), but the noisy velocity on the steep slope leaves the force balance above its floor."""
    diagnosis, result, _ = diagnosed([('smooth_friction', {'force': 0.8, 'speed': 2e-3})], 0, random_parameters(seed=0))
    assert result['effects'][0]['effect'] == 'smooth_friction', result['candidates']
    assert result['added_parameters']['friction_force'] == pytest.approx(0.8, rel=0.01)
    assert settings(diagnosis, 'smooth_friction')['smoothing_speed'] == pytest.approx(2e-3, rel=0.1)


def test_stribeck_friction_is_named_after_the_coulomb_level():
    """Fc 0.8 N, Fs 1.4 N, v_s 10 mm/s: coulomb_friction first, then the excess. The excess reads low (0.46 N for
    0.6: the rigid sticking rows carry no force, and the independent plant's stuck contact is a damped bristle
    the Coulomb candidate does not model, docs/physics.md 8)."""
    diagnosis, result, _ = diagnosed([('stribeck_friction', {'coulomb': 0.8, 'static': 1.4, 'speed': 0.01})], 0)
    named = [e['effect'] for e in result['effects']]
    assert named[:2] == ['coulomb_friction', 'stribeck_friction'], result['candidates']
    added = result['added_parameters']
    assert added['coulomb_force'] == pytest.approx(0.8, rel=0.03)
    assert added['stribeck_force'] == pytest.approx(0.6, rel=0.3)
    assert settings(diagnosis, 'stribeck_friction')['stribeck_speed'] == pytest.approx(0.01, rel=0.1)


def test_a_coulomb_friction_is_not_called_stribeck_or_smooth():
    _, result, _ = diagnosed([('coulomb_friction', {'force': 1.0})], 0)
    assert [e['effect'] for e in result['effects']] == ['coulomb_friction'], result['candidates']


@pytest.mark.parametrize('cutoff, seed, tolerance', [
    (3000.0, 2, 0.05),
    (1000.0, 0, 0.03)])
def test_a_current_sensors_filter_is_named_at_the_sensor_and_closed(cutoff, seed, tolerance):
    diagnosis, result, _ = diagnosed([('sensor_filter', {'current_cutoff': cutoff})], seed,
                                     random_parameters(seed=seed))
    assert [e['effect'] for e in result['effects']] == ['sensor_filter'], result['candidates']
    assert result['verdict'] == 'explained', result['disagreement']
    assert result['added_parameters']['current_filter_cutoff'] == pytest.approx(cutoff, rel=tolerance)
    assert settings(diagnosis, 'sensor_filter')['current_filter_time_constant'] == pytest.approx(
        1.0 / (2.0 * math.pi * cutoff), rel=tolerance)
    assert 'current_filter_cutoff' in result['candidates'][0]['evidence']    # the evidence names the sensor


def test_one_filter_on_every_sensor_is_named_once_and_closed():
    cutoff = 3000.0
    diagnosis, result, truth = diagnosed([('sensor_filter', {'current_cutoff': cutoff, 'position_cutoff': cutoff})],
                                         4, random_parameters(seed=4))
    assert [e['effect'] for e in result['effects']] == ['sensor_filter'], result['candidates']
    assert result['verdict'] == 'explained', result['disagreement']
    for name in ('current', 'position'):
        assert result['added_parameters'][f'{name}_filter_cutoff'] == pytest.approx(cutoff, rel=0.05), name
    assert within_three_sigma(result, truth, ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')) == {}


def test_a_position_late_by_a_fraction_of_a_sample_is_named_and_closed():
    _, result, _ = diagnosed([('sensor_delay', {'current': 0.0, 'position': 1.5})], 0)
    assert [e['effect'] for e in result['effects']] == ['sensor_delay'], result['candidates']
    assert result['verdict'] == 'explained', result['disagreement']
    assert result['added_parameters']['position_delay'] == pytest.approx(1.5 * TS, abs=0.05 * TS)
    assert 'current_delay' not in result['added_parameters']


def test_a_current_late_by_half_a_sample_is_named_and_explained():
    """The position moves half a sample the other way (the drive by whole samples only: Data.realigned). It was
    named a first-order current filter (a group delay of half a sample) while the all-pass that moves the position
    started settled at a later sample than the record's first (data._advanced): the first rows' transient cost
    the delay more than the filter. Now the delay alone, within 3 sigma and 0.01 samples, and explained."""
    _, result, _ = diagnosed([('sensor_delay', {'current': 0.5, 'position': 0.0})], 0)
    assert [e['effect'] for e in result['effects']] == ['sensor_delay'], result['candidates']
    assert result['verdict'] == 'explained', result['disagreement']
    delay, std = result['added_parameters']['current_delay'], result['added_parameters_std']['current_delay']
    assert abs(delay - 0.5 * TS) < min(3.0 * std, 0.01 * TS)


def _within_three_sigma(result, truth):
    names = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')
    found, std = result['reidentified_parameters'], result['reidentified_parameters_std']
    return {k: round((found[k] - truth[k]) / std[k], 2) for k in names if abs(found[k] - truth[k]) > 3 * std[k]}


def test_a_record_three_samples_late_is_realigned_and_refitted_about_its_own_estimate():
    """Current and position 3 samples late at 5 kHz: the nominal model identified on the misaligned data is far
    off (R half, L four times the truth), and one step from it landed on a negative inductance. The delay is
    named alone, within 0.01 samples, and the model re-identified about the re-aligned data's own estimate is
    within 3 sigma."""
    params = random_parameters(seed=79)
    ts = 2e-4
    recording, truth = record(1.5, params=params, seed=79, sample_period=ts, delays={'current': 3.0, 'position': 3.0})
    result = diagnose(recording).to_dict()
    assert [e['effect'] for e in result['effects']] == ['sensor_delay'], result['candidates']
    assert result['verdict'] == 'explained', result['disagreement']
    assert result['added_parameters']['current_delay'] == pytest.approx(3 * ts, abs=0.01 * ts)
    assert 0 < result['added_parameters_std']['current_delay'] < 0.01 * ts   # the profiled delay's own sigma
    assert result['reidentified_parameters']['inductance'] > 0
    assert not _within_three_sigma(result, truth)


def test_a_late_current_the_data_cannot_place_is_a_rival_and_the_model_within_its_sigma():
    """The current alone 0.784 samples late at 3 kHz: a first-order filter and the delay each close one equation
    better than the other. Whichever is named, the other is reported as its rival, and the re-identified parameters
    carry the difference between the two (it was R 11.6 % low at 16 sigma)."""
    params = random_parameters(seed=160)
    recording, truth = record(1.5, params=params, seed=160, sample_period=1.0 / 3000.0,
                              delays={'current': 0.784, 'position': 0.0})
    result = diagnose(recording).to_dict()
    names = [e['effect'] for e in result['effects']]
    assert names and names[0] in ('sensor_delay', 'sensor_filter'), result['candidates']
    assert any('do not tell' in w and 'sensor_' in w for w in result['warnings']) or names[0] == 'sensor_delay'
    assert not _within_three_sigma(result, truth)


# ------------------------------------------------------------------ the re-alignments on signals of known shape
def _data(n=3000, **signals):
    t = np.arange(n) * TS
    base = {'voltage': np.sin(2 * np.pi * 30 * t), 'current': np.cos(2 * np.pi * 40 * t),
            'position': 1e-3 * np.sin(2 * np.pi * 20 * t)}
    base.update({k: v(t) if callable(v) else v for k, v in signals.items()})
    return Data.from_recording(Recording(TS, base)), t


def test_a_dead_time_drop_stiff_about_zero_current_leaves_the_model_within_its_sigma():
    """A 0.745 V dead-time drop fading over 25 mA at 10 kHz (sweep seed 50): about zero current it acts as a 30 ohm
    resistance beside R = 6.6 ohm, so the current settles within the band some 20 us into an interval. Its terms
    taken along a current path without the drop, L came out 1.5 % low (5.5 sigma), Km and m 0.7 % low; along the
    path the fitted drop bends, the fade current is found within 3 % and every nominal parameter within 3 sigma."""
    params = {'resistance': 6.598, 'inductance': 8.098e-4, 'emf_constant': 4.513, 'mass': 0.02469, 'damping': 1.433,
              'load_force': 0.0}
    drive = {'dead_time_drop': 0.745, 'offset': -0.085, 'current_band': 0.0247}
    recording, truth = record(1.5, params=params, effects=[('drive_voltage_error', drive)], seed=50,
                              sample_period=1e-4, substeps=16)
    diagnosis = diagnose(recording)
    result = diagnosis.to_dict()
    assert [e['effect'] for e in result['effects']] == ['drive_voltage_error'], result['candidates']
    assert settings(diagnosis, 'drive_voltage_error')['current_scale'] == pytest.approx(0.0247, rel=0.03)
    assert not _within_three_sigma(result, truth)


def test_a_fractional_delay_moves_the_position_and_keeps_its_noise_white():
    def signal(t):
        return 1e-3 * np.sin(2 * np.pi * 60 * t)
    data, t = _data(position=signal)
    moved = data.realigned({'position': 1.3}).signals['position']
    t = t[:len(moved)]
    assert np.max(np.abs(moved - signal(t + 1.3 * TS))[20:]) < 1e-6 * 1e-3
    noise = np.random.default_rng(0).standard_normal(len(t) + data.max_delay)
    data, _ = _data(n=len(noise), position=noise)
    out = data.realigned({'position': 0.5}).signals['position'][50:]
    assert np.var(out) == pytest.approx(np.var(noise), rel=0.03)   # a 4-point interpolation would lose 30 %
    assert abs(np.corrcoef(out[1:], out[:-1])[0, 1]) < 0.03
    assert 'position' not in data.realigned({'position': 0.5}).shaping


def test_a_current_late_by_a_fraction_moves_by_whole_samples_and_the_voltage_by_its_interval_mean():
    data, _ = _data()
    moved = data.realigned({'current': 2.25})
    full = np.concatenate((data.signals['current'], data.spare['current']))
    assert np.array_equal(moved.signals['current'], full[2:2 + len(data)])
    u = data.signals['voltage']
    assert np.allclose(moved.signals['voltage'][1:], 0.25 * u[:-1] + 0.75 * u[1:], rtol=0, atol=1e-15)
    # the position moves the other way by the fraction, exactly for its smooth signal
    t = np.arange(len(data)) * TS
    assert np.max(np.abs(moved.signals['position'] - 1e-3 * np.sin(2 * np.pi * 20 * (t - 0.25 * TS)))[20:]) < 1e-9


def test_a_fractionally_late_current_shifts_the_held_voltage_exactly_by_parts():
    rng = np.random.default_rng(2)
    steps = rng.normal(size=3000)
    data, _ = _data(voltage=steps)
    moved = data.realigned({'current': 1.3})
    parts = moved.voltage_parts
    # the staircase u_i over [i, i+1) (samples) read 0.3 samples earlier, by quadrature over each part
    fine = np.linspace(0.0, 1.0, 4001)
    for j in (5, 6, 777):
        for m in range(parts.shape[1]):
            s = j + (m + fine) / parts.shape[1] - 0.3
            assert parts[j, m] == pytest.approx(np.trapezoid(steps[np.floor(s).astype(int)], fine), abs=2e-3)
    assert np.allclose(parts.mean(axis=1)[:len(data)], moved.signals['voltage'], rtol=0, atol=1e-12)


@pytest.mark.parametrize('late', [0.784, 0.5])
def test_a_record_late_by_a_fraction_fits_the_exact_rows_at_its_delay(late):
    """Noise-free, current and position both `late` samples late at 3 kHz: re-aligned by that delay, the nominal
    model fits, its parameters within 0.2 % (m, B: 1 %). With the voltage's fraction as its interval mean instead
    of through each part's gain, B came out 46 % low."""
    from emla_identification.discrepancy.fit import nominal_fit
    params = random_parameters(seed=3)
    ts = 1.0 / 3000.0
    recording, _ = record(1.0, params=params, seed=3, current_noise=0.0, resolution=1e-12, sample_period=ts,
                          delays={'current': late, 'position': late})
    data = Data.from_recording(recording).realigned({'current': late, 'position': late})
    names = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')
    fitted = nominal_fit(data, {**{k: params[k] for k in names}, 'load_force': params['load_force']}).parameters
    for name, tolerance in zip(names, (2e-3, 2e-3, 2e-3, 1e-2, 1e-2)):
        assert fitted[name] == pytest.approx(params[name], rel=tolerance), name


def test_a_position_filter_is_undone_to_the_fourth_order_of_the_sample_period():
    tau, w = 0.7 * TS, 2.0 * np.pi * 300.0    # a loop's 300 Hz: the three-point difference errs by 7.7e-4, this 3.4e-5
    data, t = _data(position=lambda t: 1e-3 * np.sin(w * t - np.arctan(w * tau)) / np.hypot(1.0, w * tau))
    out = data.unfiltered('position', tau).signals['position']
    error = np.max(np.abs(out - 1e-3 * np.sin(w * t[:len(out)]))[2:-2])   # against the filter's own input
    assert error < 1e-4 * 1e-3
    noise = np.random.default_rng(2).standard_normal(20000)   # its white noise: amplified by 1 + 0.26 (tau / Ts)^2
    data, _ = _data(n=len(noise), position=noise)              # (the three-point difference: 1 + 0.5 (tau / Ts)^2)
    assert np.var(data.unfiltered('position', 2.0 * TS).signals['position']) < 1.0 + 0.3 * 2.0 ** 2
    both = data.unfiltered(('current', 'position'), tau).signals   # every sensor filtered: only the voltage moves
    assert np.array_equal(both['position'], data.signals['position'])
    assert np.array_equal(both['current'], data.signals['current'])


def test_a_drive_filter_passes_to_the_voltage_and_the_position_exactly():
    tau = 0.7 * TS
    rng = np.random.default_rng(1)
    steps = rng.normal(size=3000)
    data, t = _data(voltage=steps, position=lambda t: 1e-3 * (t / 0.3) ** 3)
    out = data.unfiltered('current', tau)
    # the continuous filter of the staircase and of the cubic, integrated independently, started settled
    k = np.arange(200)
    y_u, means = steps[0], []
    for j in k:    # exact first-order response over each held interval, its mean by quadrature
        s = np.linspace(0.0, TS, 4001)
        path = steps[j] + (y_u - steps[j]) * np.exp(-s / tau)
        means.append(np.trapezoid(path, s) / TS)
        y_u = path[-1]
    assert np.allclose(out.signals['voltage'][:200], means, rtol=0, atol=1e-6)
    def x(s):
        return 1e-3 * (s / 0.3) ** 3
    solved = solve_ivp(lambda s, y: (x(s) - y) / tau, (0.0, t[199]), [0.0], t_eval=t[:200], rtol=1e-12, atol=1e-18)
    # exact for the cubic once the first interval's held x_-1 = x_0 (an error of 1e-15 m) has decayed
    assert np.allclose(out.signals['position'][2:200], solved.y[0][2:], rtol=1e-9, atol=1e-15)
    assert np.array_equal(out.signals['current'], data.signals['current'])     # the drive's samples untouched
    assert len(out.shaping['position']) > 4


# ------------------------------------------------------------------ the plant through the effects' hooks
def _steady_speed(plant, voltage, seconds=0.3):
    rows = plant.advance(voltage, TS, int(seconds / TS))
    return rows['velocity'][-1], rows['position'][-1]


def test_the_plant_slides_at_the_speed_smooth_friction_leaves():
    p = TABLE1
    effect = SmoothFriction(friction_force=1.0, smoothing_speed=0.01)
    v, _ = _steady_speed(Plant(p, effects=[effect]), 2.0)
    # steady: Km (u - Km v) / R = B v + Fl + Fc tanh(v / v_s)
    expected = brentq(lambda w: p.emf_constant * (2.0 - p.emf_constant * w) / p.resistance - p.damping * w
                      - p.load_force - 1.0 * np.tanh(w / 0.01), 0.0, 1.0)
    assert v == pytest.approx(expected, rel=1e-4)


def test_the_plant_holds_below_breakaway_and_slides_on_the_stribeck_curve():
    p = TABLE1
    effects = [CoulombFriction(coulomb_force=0.5), StribeckFriction(stribeck_force=0.5, stribeck_speed=0.01)]
    # the voltage whose coil force at rest is 0.8 N beyond the load: above Fc, below Fc + dF
    hold = (0.8 + p.load_force) * p.resistance / p.emf_constant
    v, x = _steady_speed(Plant(p, effects=effects), hold, 0.05)
    assert v == 0.0 and x == 0.0
    v, _ = _steady_speed(Plant(p, effects=effects), 2.0)
    expected = brentq(lambda w: p.emf_constant * (2.0 - p.emf_constant * w) / p.resistance - p.damping * w
                      - p.load_force - 0.5 - 0.5 * np.exp(-(w / 0.01) ** 2), 1e-6, 1.0)
    assert v == pytest.approx(expected, rel=1e-4)


# ------------------------------------------------------------------ the model file
def test_the_model_file_keeps_the_smoothing_speed_and_the_plant_reads_it(smooth, tmp_path):
    diagnosis, _, _ = smooth
    names = [stage.assessment.name for stage in diagnosis.stages]
    write(from_fit(diagnosis.final, names, 'record', 'test', diagnosis.final_std), tmp_path / 'm.yaml')
    model = read(tmp_path / 'm.yaml')
    speed = model.effects[0].settings['smoothing_speed']
    assert speed == pytest.approx(settings(diagnosis, 'smooth_friction')['smoothing_speed'], rel=1e-12)
    recording, _ = record(0.1, effects=[('smooth_friction', {'force': 1.5, 'speed': 5e-3})], seed=1)
    on_data = model_on_data(model, recording)
    assert on_data.candidates[0].smoothing_speed == pytest.approx(speed, rel=1e-6)   # not the grid's nearest
    (plant_effect,) = model.plant_effects()
    assert isinstance(plant_effect, SmoothFriction) and plant_effect.smoothing_speed == speed


def test_a_sensor_filter_in_a_model_file_is_predicted_but_not_simulated(tmp_path):
    tau = 4.3e-5
    model = Model(TS, {k: (v, None) for k, v in TABLE1.physical().items()},
                  [ModelEffect('sensor_filter', 'sensor_filter', {}, {'current_filter_time_constant': tau})])
    write(model, tmp_path / 'f.yaml')
    model = read(tmp_path / 'f.yaml')
    recording, _ = record(0.1, seed=0)
    assert model_on_data(model, recording).candidates[0].time_constant == pytest.approx(tau, rel=1e-6)
    with pytest.raises(InputError, match='sensor\'s filter'):
        model.plant_effects()
    bad = Model(TS, model.parameters, [ModelEffect('sensor_filter', 'sensor_filter', {},
                                                   {'current_filter_time_constant': -1.0})])
    write(bad, tmp_path / 'bad.yaml')
    with pytest.raises(InputError, match='current_filter_time_constant'):
        read(tmp_path / 'bad.yaml')
