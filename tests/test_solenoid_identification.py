"""Offline identification of a solenoid (emla_identification.solenoid) on the independent generator's records
(tests/solenoid_generator.py: scipy DOP853, end stops by events, 5 mA current noise, a 4.9 mA current ADC step,
1 um position steps) at the rates the users log at: every parameter within 2 % of the truth and within 3 of its
reported standard deviations; the fit check calls the solenoid adequate; bad input is one clear error."""
import numpy as np
import pytest
from solenoid_generator import record

from emla_core.errors import InputError
from emla_identification.solenoid import identify_solenoid
from emla_identification.solenoid_online import WindowedSolenoid

CHECKED = ('resistance', 'leakage_inductance', 'gap_coefficient', 'gap', 'mass', 'damping', 'spring_stiffness')


@pytest.mark.parametrize('rate, duration, seed', [(1000.0, 8.0, 11), (5000.0, 2.0, 12)])
def test_every_parameter_within_two_percent_and_three_sigma(rate, duration, seed):
    recording, truth = record(duration=duration, rate=rate, seed=seed)
    result = identify_solenoid(recording)
    for name in CHECKED:
        value, std = result.parameters[name], result.std[name]
        assert value == pytest.approx(truth[name], rel=0.02), name
        assert abs(value - truth[name]) < 3 * std, (name, value, std)
    preload = result.parameters['spring_preload']
    assert abs(preload - truth['spring_preload']) < 3 * result.std['spring_preload']
    assert all(f.adequate for f in result.fit.values()), {k: f.ratio for k, f in result.fit.items()}
    assert result.warnings() == []


def test_the_errors_over_noise_realisations_are_about_one_reported_sigma():
    values = {name: [] for name in CHECKED}
    for seed in range(4):
        recording, truth = record(duration=1.0, rate=5000.0, seed=100 + seed)
        result = identify_solenoid(recording)
        for name in CHECKED:
            values[name].append((result.parameters[name] - truth[name]) / result.std[name])
    for name in CHECKED:
        assert np.sqrt(np.mean(np.square(values[name]))) < 3.0, name


def test_a_coil_that_does_not_move_is_refused_in_one_line():
    t = np.arange(2000)
    with pytest.raises(InputError, match='position never changes'):
        identify_solenoid(sample_period=1e-3, voltage=np.full(2000, 6.0), current=1.0 - np.exp(-t / 2.0),
                          position=np.zeros(2000))
    with pytest.raises(InputError, match='non-finite current'):
        identify_solenoid(sample_period=1e-3, voltage=np.ones(2000), current=np.r_[np.nan, np.ones(1999)],
                          position=np.linspace(0, 1e-3, 2000))


def test_the_windowed_model_online_is_the_offline_fit_of_its_latest_window():
    """WindowedSolenoid (the identifier node's online_model) fed frames of the independent generator's record: each
    fit is identify_solenoid's on the latest window, within 2 % and 3 sigma of the truth. A window with too little
    motion gives its fit with the warnings that say so; one without any keeps the last estimate and says why."""
    recording, truth = record(duration=1.6, rate=5000.0, seed=14)
    s, ts = recording.signals, recording.sample_period
    model = WindowedSolenoid(ts, window=1.2, refit_period=0.8)
    assert np.isnan(model.full_estimate()[0]['gap']) and model.samples == 0
    for first in range(0, len(recording), 250):
        model.update(*(s[name][first:first + 250] for name in ('voltage', 'current', 'position')))
    window = {name: s[name][-6000:] for name in ('voltage', 'current', 'position')}
    offline = identify_solenoid(sample_period=ts, **window)
    values, std, (names, covariance) = model.full_estimate()
    assert values == offline.parameters and model.samples == 6000 and model.problems() == []
    for name in CHECKED:
        assert abs(values[name] - truth[name]) < min(3 * std[name], 0.02 * truth[name]), name
    rest = np.full(4000, 0.0)   # the armature comes to rest: a window with little motion, then one with none
    model.update(rest, rest, rest + s['position'][-1])
    assert model.problems() and not any('failed' in line for line in model.problems())   # a fit, with its warnings
    values = model.full_estimate()[0]
    model.update(rest, rest, rest + s['position'][-1])
    assert model.full_estimate()[0] == values and 'the position never changes' in model.problems()[0]
