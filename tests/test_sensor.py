"""Sensor sampling: noise and quantisation statistics, delay line, reproducibility."""
import math

import numpy as np
import pytest

from emla_sim.sensor import Sensor, SensorConfig

N = 200_000


def test_defaults_are_the_dsp_of_the_paper():
    assert SensorConfig() == SensorConfig(sample_period=1e-4, current_noise_std=5e-3, position_resolution=1e-6,
                                          position_noise_std=0.0, delay_samples=0, seed=0)


def test_current_noise_is_unbiased_with_the_configured_std():
    current, _ = Sensor().measure(np.full(N, 1.5), np.zeros(N))
    error = current - 1.5
    sigma_of_mean = 5e-3 / math.sqrt(N)
    assert abs(error.mean()) < 5 * sigma_of_mean
    assert error.std() == pytest.approx(5e-3, rel=0.02)  # std of a std estimate: 1/sqrt(2N) = 0.16 %


def test_position_quantisation_rounds_to_the_nearest_lsb():
    lsb = 1e-6
    true = np.random.default_rng(1).uniform(-5e-3, 5e-3, N)
    _, position = Sensor().measure(np.zeros(N), true)
    codes = position / lsb
    np.testing.assert_allclose(codes, np.round(codes), atol=1e-6)
    error = position - true
    assert np.abs(error).max() <= lsb / 2 * (1 + 1e-6)
    assert abs(error.mean()) < 0.01 * lsb
    assert error.std() == pytest.approx(lsb / math.sqrt(12), rel=0.02)  # uniform on one LSB


def test_position_noise_adds_to_the_quantisation_error():
    lsb, sigma = 1e-6, 2e-6
    true = np.random.default_rng(2).uniform(0.0, 1e-3, N)
    current, position = Sensor(SensorConfig(position_noise_std=sigma, current_noise_std=0.0)).measure(
        np.full(N, 0.25), true)
    np.testing.assert_array_equal(current, 0.25)
    assert (position - true).std() == pytest.approx(math.hypot(sigma, lsb / math.sqrt(12)), rel=0.02)


def test_no_noise_no_quantisation_passes_through():
    sensor = Sensor(SensorConfig(current_noise_std=0.0, position_resolution=0.0))
    assert sensor.measure(0.123, 4.56e-4) == (0.123, 4.56e-4)


@pytest.mark.parametrize('delay', [1, 3])
def test_delay_shifts_by_whole_samples_across_calls(delay):
    config = SensorConfig(current_noise_std=0.0, position_resolution=0.0, delay_samples=delay)
    current = np.arange(1.0, 41.0)
    position = -1e-4 * current
    sensor = Sensor(config)
    measured = [sensor.measure(current[:7], position[:7]), sensor.measure(current[7:8], position[7:8]),
                sensor.measure(current[8:], position[8:])]
    measured_current = np.concatenate([m[0] for m in measured])
    measured_position = np.concatenate([m[1] for m in measured])
    np.testing.assert_array_equal(measured_current[delay:], current[:-delay])
    np.testing.assert_array_equal(measured_position[delay:], position[:-delay])
    np.testing.assert_array_equal(measured_current[:delay], current[0])  # the line starts full of sample 0
    one_by_one = Sensor(config)
    assert [one_by_one.measure(float(c), float(p)) for c, p in zip(current, position)] == \
        list(zip(measured_current, measured_position))


def test_seed_reproducibility_and_chunk_independence():
    config = SensorConfig(position_noise_std=1e-6, seed=7)
    current = np.linspace(-2.0, 2.0, 5000)
    position = np.linspace(0.0, 5e-3, 5000)
    whole = Sensor(config).measure(current, position)
    again = Sensor(config).measure(current, position)
    np.testing.assert_array_equal(whole[0], again[0])
    np.testing.assert_array_equal(whole[1], again[1])
    chunked = Sensor(config)
    pieces = [chunked.measure(current[k:k + 997], position[k:k + 997]) for k in range(0, 5000, 997)]
    np.testing.assert_array_equal(np.concatenate([p[0] for p in pieces]), whole[0])
    np.testing.assert_array_equal(np.concatenate([p[1] for p in pieces]), whole[1])
    other = Sensor(SensorConfig(position_noise_std=1e-6, seed=8)).measure(current, position)
    assert not np.array_equal(other[0], whole[0])


def test_scalar_calls_draw_the_same_noise_as_arrays():
    config = SensorConfig(position_noise_std=3e-6, seed=3, delay_samples=2)
    current, position = np.linspace(0, 1, 9000), np.linspace(0, 1e-3, 9000)  # over two noise blocks
    array = Sensor(config).measure(current, position)
    sensor = Sensor(config)
    scalar = np.array([sensor.measure(float(c), float(p)) for c, p in zip(current, position)])
    np.testing.assert_array_equal(scalar[:, 0], array[0])
    np.testing.assert_array_equal(scalar[:, 1], array[1])


@pytest.mark.parametrize('bad', [dict(sample_period=0.0), dict(current_noise_std=-1.0),
                                 dict(position_resolution=math.nan), dict(delay_samples=-1),
                                 dict(delay_samples=1.5)])
def test_config_refuses_bad_values(bad):
    with pytest.raises(ValueError, match=next(iter(bad))):
        SensorConfig(**bad)
