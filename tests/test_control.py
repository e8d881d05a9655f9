"""Adaptive inverse-system control: reference, inverse law, feedback, controller guard, closed loop, metrics.

Independent truth: the plant's exact ZOH simulation, the closed-form sampling error of the inverse derived
from the plant's transfer function, the triple-integrator error response of the pole placement, and signals
with known metrics.
"""
import collections
import math
from types import SimpleNamespace

import numpy as np
import pytest

from emla_bench.loop import run_closed_loop
from emla_bench.scenarios import tracking_metrics
from emla_control import inverse
from emla_control.controller import InverseSystemController
from emla_control.reference import StrokeReference
from emla_core.parameters import TABLE1
from emla_core.recording import Recording
from emla_identification.online import OnlineIdentifier
from emla_sim.plant import Plant
from emla_sim.sensor import Sensor, SensorConfig

P = TABLE1
REF = StrokeReference()
NOISELESS = SensorConfig(current_noise_std=0.0, position_resolution=0.0)


# ---- reference ----

def test_reference_derivatives_are_continuous_and_consistent():
    t = np.arange(0.0, 2 * REF.period, 1e-6)
    s, *derivatives = REF(t)
    for low, high in zip((s, *derivatives[:-1]), derivatives):
        # each derivative is the slope of the one below (central differences, error ~ dt^2)
        slope = np.gradient(low, t)
        assert np.max(np.abs(slope[1:-1] - high[1:-1])) < 1e-3 * np.max(np.abs(high))
    # no jumps where the pieces meet: the ends of the moves
    joints = np.array([0.0, REF.transition, REF.period / 2, REF.period / 2 + REF.transition, REF.period])
    for before, after, whole in zip(REF(joints - 1e-9), REF(joints + 1e-9), (s, *derivatives)):
        assert np.max(np.abs(after - before)) < 1e-5 * np.max(np.abs(whole))
    assert (s.min(), s.max()) == pytest.approx((0.0, REF.stroke), abs=1e-15)
    np.testing.assert_allclose(REF(t + REF.period)[0], s, atol=1e-12)


def test_reference_moves():
    moves = REF.moves(REF.period)
    assert [(m.start, m.end, m.hold_end, m.origin, m.target) for m in moves] == [
        (0.0, 0.008, 0.02, 0.0, 0.004), (0.02, 0.028, 0.04, 0.004, 0.0)]
    with pytest.raises(ValueError):
        StrokeReference(transition=0.03)


# ---- the inverse law ----

def test_inverse_is_the_papers_full_and_mixed_form():
    rng = np.random.default_rng(0)
    v, a, j = rng.normal(0, 1, 50), rng.normal(0, 400, 50), rng.normal(0, 4e5, 50)
    R, L, Km, m, B, Fl = 4.0, 1.6e-3, 10.8, 0.036, 2.0, 3.0
    u = inverse.inverse_voltage(R, L, Km, m, B, Fl, v, a, j)
    full = m * L / Km * j + (m * R + B * L) / Km * a + (B * R / Km + Km) * v + R * Fl / Km
    current = (m * a + B * v + Fl) / Km  # the current whose force balance gives acceleration a
    mixed = m * L / Km * j + B * L / Km * a + Km * v + R * current
    np.testing.assert_allclose(u, full, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(u, mixed, rtol=1e-12, atol=1e-9)


def _open_loop_error(ts, duration=REF.period / 2):
    t = np.arange(0.0, duration, ts)
    u = inverse.open_loop_voltage(P, REF, t, ts)
    x = Plant(P).run(u, ts, sampling='start')['position']
    return t, x - REF(t)[0]


def test_inverse_in_series_with_the_plant_reproduces_the_reference_to_sampling_error():
    """With exact parameters and no feedback, the plant follows the reference up to the ZOH's error.

    The voltage is the continuous inverse u(t) at each interval's midpoint. Expanding the ZOH error per
    interval (mean -u'' Ts^2/24, first moment -u' Ts^3/12) and passing it through the plant, whose response
    to u is exactly r, gives the position error Ts^2/24 r''(t) at the samples, plus, for each kink of u (the
    smooth step's 4th derivative jumps at both ends of a move, so u' jumps by (m L/Km) 840 stroke/T^4), a
    step Ts^2/24 Kv |du'| with Kv = Km/(R B + Km^2) the velocity per volt.
    """
    kink = P.mass * P.inductance / P.emf_constant * 840.0 * REF.stroke / REF.transition ** 4
    kv = P.emf_constant / (P.resistance * P.damping + P.emf_constant ** 2)
    errors = {}
    for ts in (1e-4, 5e-5):
        t, error = _open_loop_error(ts)
        max_acceleration = np.max(np.abs(REF(t)[2]))
        bound = ts ** 2 / 24 * (max_acceleration + 2 * kv * kink)
        assert np.max(np.abs(error)) < bound
        hold = t > REF.transition + 4e-3  # plant transients (ms) over: only the two kinks' steps remain
        np.testing.assert_allclose(error[hold], ts ** 2 / 24 * 2 * kv * kink, rtol=0.03)
        errors[ts] = np.max(np.abs(error))
    assert errors[1e-4] < 0.5e-6  # 0.35 um on a 4 mm stroke at 10 kHz
    assert 3.6 < errors[1e-4] / errors[5e-5] < 4.4  # second order in Ts


# ---- feedback and observer design ----

def test_feedback_gains_place_the_poles():
    k0, k1, k2 = inverse.feedback_gains(100.0, 0.7)
    wb = 2 * math.pi * 100.0
    expected = np.sort_complex(np.array([-wb, complex(-0.7 * wb, wb * math.sqrt(1 - 0.49)),
                                         complex(-0.7 * wb, -wb * math.sqrt(1 - 0.49))]))
    np.testing.assert_allclose(np.sort_complex(np.roots([1.0, k2, k1, k0])), expected, rtol=1e-9)
    with pytest.raises(ValueError):
        inverse.feedback_gains(-1.0, 0.7)


def test_observer_gains_place_both_error_poles():
    ts = 1e-4
    l1, l2 = inverse.observer_gains(1000.0, ts)
    a = np.array([[1.0, ts], [0.0, 1.0]])
    error_matrix = (np.eye(2) - np.outer([l1, l2], [1.0, 0.0])) @ a
    np.testing.assert_allclose(np.linalg.eigvals(error_matrix), [math.exp(-2 * math.pi * 1000.0 * ts)] * 2,
                               atol=1e-6)


def test_closed_loop_error_decays_as_the_placed_poles():
    """Initial offset e0, reference at rest: with exact parameters the loop is the triple integrator under
    the feedback, so e(t) = e0 (1 + wb t + (wb t)^2 / 2) exp(-wb t) for zeta = 1."""
    e0, bandwidth = 100e-6, 150.0
    still = lambda t: tuple(np.zeros_like(np.asarray(t, dtype=float)) for _ in range(4))  # noqa: E731
    controller = InverseSystemController(P, bandwidth=bandwidth, damping=1.0)
    result = run_closed_loop(Plant(P, initial_state=(0.0, e0, 0.0)), controller, still, 0.01,
                             sensor=Sensor(NOISELESS))
    wt = 2 * math.pi * bandwidth * result.recording.time
    expected = e0 * (1 + wt + wt ** 2 / 2) * np.exp(-wt)
    assert np.max(np.abs(result.truth['position'] - expected)) < 2e-3 * e0  # observer and sampling: 5e-5


# ---- the controller ----

def _controller(**kw):
    return InverseSystemController(P, control_period=1e-4, **kw)


def test_guard_rejects_implausible_estimates_and_keeps_the_previous():
    controller = _controller(min_samples=1000, max_jump=2.0)
    good = P.scaled(resistance=1.3, mass=1.2).physical()
    cases = [
        (good, 500, 'start-up'),
        ({**good, 'resistance': math.nan}, 5000, 'non-finite'),
        ({**good, 'inductance': math.inf}, 5000, 'non-finite'),
        ({**good, 'emf_constant': -10.8}, 5000, 'non-physical'),
        ({**good, 'mass': 0.0}, 5000, 'non-physical'),
        ({**good, 'damping': -1.0}, 5000, 'non-physical'),
        ({**good, 'resistance': 3 * P.resistance}, 5000, 'jump'),
        ({**good, 'mass': P.mass / 2.5}, 5000, 'jump'),
        ({**good, 'load_force': 100.0}, 5000, 'load beyond stall force'),  # stall force 10.8 * 24 / 5.2 N
        ({}, 5000, 'no parameters'),
    ]
    for estimate, samples, _reason in cases:
        assert not controller.update_parameters(estimate, samples)
        assert controller.parameters == P
    assert controller.rejected == len(cases)
    assert controller.rejections == collections.Counter(reason for _, _, reason in cases)
    assert controller.update_parameters(good, 5000)
    assert controller.parameters.physical() == pytest.approx(good)
    assert controller.update_parameters({'resistance': 6.0})  # a partial estimate updates only its keys
    assert controller.parameters.resistance == 6.0 and controller.parameters.mass == pytest.approx(good['mass'])
    assert controller.accepted == 2


def test_voltage_stays_within_the_supply_without_wind_up():
    """A move twice as fast as the actuator can follow at 24 V: the law saturates for milliseconds, and the
    loop still settles onto the reference during each hold (nothing winds up)."""
    fast = StrokeReference(stroke=4e-3, transition=2e-3)
    for supply in (24.0, 12.0):
        controller = InverseSystemController(P, supply_voltage=supply)
        result = run_closed_loop(Plant(P), controller, fast, 2 * fast.period)
        voltage = result.recording.signals['voltage']
        assert np.max(np.abs(voltage)) <= supply
        assert np.sum(np.abs(voltage) == supply) > 20  # it did saturate
        error = result.truth['position'] - result.recording.signals['reference']
        for move in fast.moves(2 * fast.period):
            late = (result.recording.time > move.hold_end - 5e-3) & (result.recording.time < move.hold_end)
            assert np.max(np.abs(error[late])) < 3e-6


# ---- the closed loop ----

def test_closed_loop_tracks_with_exact_parameters_and_repeats_exactly():
    runs = [run_closed_loop(Plant(P), _controller(), REF, REF.period) for _ in range(2)]
    for name in ('voltage', 'current', 'position'):
        np.testing.assert_array_equal(runs[0].recording.signals[name], runs[1].recording.signals[name])
    error = runs[0].truth['position'] - runs[0].recording.signals['reference']
    assert np.sqrt(np.mean(error ** 2)) < 1e-6  # with 5 mA and 1 um sensor noise
    np.testing.assert_allclose(runs[0].true_parameters['resistance'], P.resistance)


def test_an_identified_load_force_is_compensated():
    """A 5 N load the model lacks: the identifier finds it, and once the controller takes it the tracking is
    that of the exact model; without the update the load drags the position ~0.5 mm behind."""
    rms = {}
    for adapt in (False, True):
        result = run_closed_loop(Plant(P.replace(load_force=5.0)), _controller(), REF, 0.4, adapt=adapt,
                                 identifier=OnlineIdentifier(1e-4, memory_time=0.03))
        assert result.estimates['load_force'][-1] == pytest.approx(5.0, rel=0.01)
        error = (result.truth['position'] - result.recording.signals['reference'])[result.recording.time >= 0.2]
        rms[adapt] = np.sqrt(np.mean(error ** 2))
    assert result.model['load_force'][-1] == pytest.approx(5.0, rel=0.01)
    assert rms[True] < 1e-6 < 1e-4 < rms[False]


def test_control_period_can_be_a_multiple_of_the_sample_period():
    controller = InverseSystemController(P, control_period=2e-4, bandwidth=100.0)
    result = run_closed_loop(Plant(P), controller, REF, REF.period)
    voltage = result.recording.signals['voltage']
    np.testing.assert_array_equal(voltage[0::2], voltage[1::2])
    error = result.truth['position'] - result.recording.signals['reference']
    assert np.sqrt(np.mean(error ** 2)) < 3e-6
    with pytest.raises(ValueError):
        run_closed_loop(Plant(P), InverseSystemController(P, control_period=1.5e-4), REF, 0.01)



def _tracking_at_1ms(policy, periods=200):
    """RMS tracking error (true position) at 10 kHz under a 1 ms control period (the graph's), 150 Hz:
    'now' computes each period's voltage from the sample at its start (no computational delay), 'ahead' one
    period earlier with step_ahead (the controller node), 'late' the same delay without the model's prediction
    (the law told the sample at t is the state at t + Tc)."""
    n, ts = 10, 1e-4
    plant, sensor = Plant(P), Sensor()
    controller = InverseSystemController(P, control_period=n * ts, bandwidth=150.0)
    controller.reset(plant.position)

    def midpoint(k):
        return tuple(float(r[0]) for r in REF(np.array([(k + 0.5) * n * ts])))
    held, error = None, []
    for k in range(periods):
        current, position = sensor.measure(plant.current, plant.position)
        if policy == 'now':
            voltage = controller.step(current, position, midpoint(k))
        elif policy == 'ahead':
            held = controller.start_ahead(current, position, midpoint(0)) if held is None else held
            voltage, held = held, controller.step_ahead(current, position, midpoint(k + 1))
        else:
            held = controller.step(current, position, midpoint(0)) if held is None else held
            voltage, held = held, controller.step(current, position, midpoint(k + 1))
        for j in range(n):
            error.append(plant.position - REF(np.array([(k * n + j) * ts]))[0][0])
            plant.step(voltage, ts)
    return math.sqrt(np.mean(np.square(error)))


def test_one_period_of_computational_delay_costs_little_with_the_models_prediction():
    """The controller node computes the next period's voltage while the plant runs this one; predicting the
    state over that period from the model keeps the tracking within 10 % of a controller without delay (12 um
    here), where ignoring the delay loses it (hundreds of um)."""
    rms = {policy: _tracking_at_1ms(policy) for policy in ('now', 'ahead', 'late')}
    assert rms['now'] < 15e-6
    assert rms['ahead'] < 1.1 * rms['now']
    assert rms['late'] > 10 * rms['ahead']


# ---- metrics ----

def test_tracking_metrics_on_signals_with_known_values():
    ts, bump = 1e-4, 100e-6  # 100 um: outside the 2 % band (80 um) of a 4 mm stroke
    t = np.arange(0.0, 2 * REF.period, ts)
    r = REF(t)[0]
    x = r.copy()
    current = np.sin(2 * math.pi * t / REF.period)
    for move in REF.moves(2 * REF.period):
        late = (t >= move.end) & (t < move.end + 3e-3)
        x[late] += bump if move.target > move.origin else -bump
    result = SimpleNamespace(recording=Recording(ts, {'reference': r}), truth={'position': x, 'current': current})
    metrics = tracking_metrics(result, REF, start=REF.period)  # the second cycle only
    assert metrics['rms_tracking_error'] == pytest.approx(bump * math.sqrt(6e-3 / REF.period), rel=1e-3)
    assert metrics['max_overshoot'] == pytest.approx(bump, rel=1e-6)
    assert metrics['settling_time'] == pytest.approx(REF.transition + 3e-3, abs=1.5 * ts)
    assert metrics['peak_current'] == pytest.approx(1.0, abs=1e-6)
