"""How the discrepancy workflow sets a re-alignment (a sensor's delay or filter): on the held-out error less the
sensor noise each setting passes into the rows, and again once a later effect is in the model. On records of the
independent plant (tests/independent_plant.py: 5 mA current noise, a 1 um position quantiser), whose noise levels
and hidden settings are the truth.
"""
import dataclasses
import math

import pytest
from independent_plant import random_parameters, record

from emla_identification.discrepancy import diagnose
from emla_identification.discrepancy.adequacy import heldout_noise, noise_gains, sensor_noise
from emla_identification.discrepancy.candidates import library
from emla_identification.discrepancy.data import Data
from emla_identification.discrepancy.fit import fit
from emla_identification.discrepancy.rank import assess
from emla_identification.discrepancy.refine import backfitted, polished

PLANT_NOISE = {'current': 5e-3 ** 2, 'position': 1e-6 ** 2 / 12.0}   # the plant's sensors


def candidate(data, name, **settings):
    prototype = next(c for c in library(data) if c.name == name)
    return dataclasses.replace(prototype, **settings)


@pytest.mark.parametrize('rate, filtered', [(10000.0, False), (3000.0, False), (10000.0, True)])
def test_the_held_out_error_of_the_right_model_is_the_sensor_noise_it_predicts(rate, filtered):
    """A clean record's nominal fit, and a position behind a 2 kHz filter undone at its true time constant (the
    undoing amplifies the position's noise): the held-out error is the plant's noise through the rows, each
    equation's is the noise at the levels fitted to the residuals, and those levels are the plant's."""
    tau = 1.0 / (2.0 * math.pi * 2000.0)
    effects = [('sensor_filter', {'current_cutoff': 0.0, 'position_cutoff': 2000.0})] if filtered else []
    recording, _ = record(1.0, params=random_parameters(seed=3), effects=effects, seed=3, sample_period=1.0 / rate)
    data = Data.from_recording(recording)
    model = fit(data)
    if filtered:
        undone = candidate(data, 'sensor_filter', filtered=('position',), sensed=tuple(data.sensed),
                           time_constant=tau)
        model = fit(undone.realigned(data), (undone,), model)
    gains = noise_gains(model)
    assert sum(heldout_noise(gains, PLANT_NOISE).values()) == pytest.approx(model.heldout.sum(), rel=0.05)
    fitted = sensor_noise(model)
    predicted = heldout_noise(gains, fitted)   # each equation's, at the levels the workflow reads
    for kind, error in zip(data.kinds, model.heldout.sum(axis=0)):
        assert predicted[kind] == pytest.approx(error, rel=0.05), kind
    for name, variance in PLANT_NOISE.items():
        assert fitted[name] == pytest.approx(variance, rel=0.1), name


def test_a_position_filter_is_set_where_its_undoing_costs_no_more_than_its_noise():
    """10 kHz, a 2 kHz position filter (tau = 0.8 sample periods; undoing it multiplies the position's noise in
    the rows by about 1 + 0.26 (tau / Ts)^2): the held-out error alone took tau 1.9 % short here (1-4 % on
    other seeds)."""
    tau = 1.0 / (2.0 * math.pi * 2000.0)
    filtered = [('sensor_filter', {'current_cutoff': 0.0, 'position_cutoff': 2000.0})]
    recording, _ = record(1.0, params=random_parameters(seed=16), effects=filtered, seed=16)
    data = Data.from_recording(recording)
    found = assess(fit(data), candidate(data, 'sensor_filter')).fit.candidates[-1]
    assert found.filtered == ('position',)
    assert found.time_constant == pytest.approx(tau, rel=0.01)


def test_a_delay_named_before_another_effect_is_searched_again_with_it():
    """A position 1.5 samples late beside a position-dependent inductance (10 kHz). A delay named at 1.2 samples
    (as a delay named first may be, taking up some of the other effect's misfit) moves to the truth once the
    inductance's candidate is added to the model: backfitted."""
    late = 1.5
    recording, _ = record(1.0, params=random_parameters(seed=5), seed=5, delays={'current': 0, 'position': late},
                          effects=[('position_inductance', {'growth': -30.0, 'center': 1.25e-3})])
    data = Data.from_recording(recording)
    early = candidate(data, 'sensor_delay', late=('position',), sensed=tuple(data.sensed), delay=1.2)
    first = fit(early.realigned(data), (early,), fit(data))
    both = assess(first, candidate(data, 'position_inductance'))
    assert both.fit.candidates[0].delay == 1.2
    again = backfitted(data, first, both)
    assert again.fit.candidates[0].delay == pytest.approx(late, abs=0.05)
    assert again.fit.heldout.sum() < both.fit.heldout.sum()


@pytest.mark.parametrize('late, seed', [(0.64, 5), (0.45, 7)])
def test_a_fractional_position_delay_is_set_at_the_truth(late, seed):
    """A position a fraction of a sample late (10 kHz; the record starts in motion). The all-pass that moves it
    once started at a later sample than the record's first and put a transient in the first rows, different
    either side of half a sample (where its whole-sample part steps): 0.64 was set at 0.5, and 0.45 at 0.47."""
    recording, _ = record(1.0, params=random_parameters(seed=seed), seed=seed, delays={'current': 0, 'position': late})
    data = Data.from_recording(recording)
    found = assess(fit(data), candidate(data, 'sensor_delay')).fit.candidates[-1]
    assert found.late == ('position',)
    assert found.delay == pytest.approx(late, abs=0.005)


def test_a_whole_sample_position_delay_is_set_by_the_force_balance():
    """A position 2 samples late at 5 kHz. The rows are weighted by the misaligned nominal model's residual, which
    leaves the force balance's weight tiny; summed in those weights the electrical equation's noise set the delay
    at 2.007 samples after the polish (the force balance left at about 10 times its floor). Each equation's error
    in its noise's units: within 0.002 samples."""
    recording, _ = record(1.0, params=random_parameters(seed=1), seed=1, sample_period=2e-4,
                          delays={'current': 0, 'position': 2.0})
    data = Data.from_recording(recording)
    base = fit(data)
    found = polished(base, assess(base, candidate(data, 'sensor_delay'))).fit.candidates[-1]
    assert found.late == ('position',)
    assert found.delay == pytest.approx(2.0, abs=0.002)


def test_a_position_filter_is_named_over_the_delay_that_scores_as_well():
    """10 kHz, a 2 kHz position filter (1 s, seed 3): a delay of about tau removes as much of the held-out
    one-step error (score 1.014 against the filter's 1.013) but leaves the force balance at 38 times its floor;
    the filter, named for leaving the least disagreement, leaves it at its floor."""
    filtered = [('sensor_filter', {'current_cutoff': 0.0, 'position_cutoff': 2000.0})]
    recording, _ = record(1.0, params=random_parameters(seed=3), effects=filtered, seed=3)
    result = diagnose(recording).to_dict()
    assert [e['effect'] for e in result['effects']] == ['sensor_filter'], result['candidates']
    assert result['verdict'] == 'explained', result['disagreement']
    assert result['added_parameters']['position_filter_cutoff'] == pytest.approx(2000.0, rel=0.01)


def test_the_finer_interpolators_come_closer_to_the_truth():
    """The interpolation's share of the sigmas (profile.finer) is the estimates' change when the position is
    re-aligned with finer interpolators (Data.finer), so they must be finer: a sine at an eighth of the sample rate
    (the fast motion a slow logger sees) moved back 0.37 samples by the all-pass, and undone from behind a
    first-order filter of 0.9 sample periods, comes out closer to the sine with them. Errors against the exact
    sine, away from the ends."""
    import numpy as np

    from emla_core.recording import Recording
    n, omega, tau = 4000, 2.0 * math.pi / 8.0, 0.9   # per sample
    k = np.arange(n)
    truth = np.sin(omega * k)
    phase = math.atan(omega * tau)
    recorded = {'late': np.sin(omega * (k - 0.37)),
                'filtered': np.sin(omega * k - phase) / math.hypot(1.0, omega * tau)}

    def error(name, finer):
        data = dataclasses.replace(Data.from_recording(Recording(1.0, {
            'voltage': np.cos(k), 'current': np.sin(0.3 * k), 'position': recorded[name]})), finer=finer)
        moved = (data.realigned({'position': 0.37}) if name == 'late' else
                 data.unfiltered(('position',), tau)).signals['position']
        return float(np.max(np.abs(moved - truth[:len(moved)])[100:-100]))
    for name in recorded:
        assert error(name, True) < 0.5 * error(name, False), name
