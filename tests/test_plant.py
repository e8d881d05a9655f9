"""Plant simulation checked against independent truth: solve_ivp of the equations written out here,
closed-form steady states, and the physics each effect must show."""
import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from emla_core.parameters import PARAMETER_NAMES, TABLE1, ActuatorParameters
from emla_core.physics import (
    EFFECTS,
    CoulombFriction,
    Effect,
    ForceConstantVariation,
    InductanceSaturation,
    ResistanceDrift,
    ReturnSpring,
    make_effect,
    register_effect,
)
from emla_sim.effects import ParameterChange
from emla_sim.plant import Plant

TS = 1e-4
R, L, KM, M, B = 4.0, 1.6e-3, 10.8, 0.036, 2.0


def staircase(n, seed=0, level=24.0):
    """Random voltage steps held for 5..30 samples (a rich excitation), within +-level."""
    rng = np.random.default_rng(seed)
    out = np.empty(n)
    k = 0
    while k < n:
        hold = rng.integers(5, 31)
        out[k:k + hold] = rng.uniform(-level, level)
        k += hold
    return out


def reference(params, voltages, dt, *, state=(0.0, 0.0, 0.0), spring=(0.0, 0.0), i_sat=None,
              curvature=(0.0, 0.0), thermal=None, changes=()):
    """End-of-interval (I, x, v, T) from solve_ivp of the model written out independently.

    The electrical state is the flux linkage psi (psi = L I, or L I_sat atan(I / I_sat) when saturating),
    so the saturation check also checks the incremental-inductance formulation. thermal = (alpha, R_th,
    C_th, T_ambient). changes = [(time, params)], applied at their exact time.
    """
    alpha, r_th, c_th, t_amb = thermal if thermal else (0.0, math.inf, math.inf, 20.0)
    stiffness, rest = spring
    c, center = curvature

    def flux(p, i):
        return p.inductance * i_sat * math.atan(i / i_sat) if i_sat else p.inductance * i

    def current(p, psi):
        return i_sat * math.tan(psi / (p.inductance * i_sat)) if i_sat else psi / p.inductance

    def rhs(t, y, p, u):
        psi, x, v, temp = y
        i = current(p, psi)
        r = p.resistance * (1.0 + alpha * (temp - t_amb))
        km = p.emf_constant * (1.0 - c * (x - center) ** 2)
        return [u - r * i - km * v, v,
                (km * i - p.damping * v - p.load_force - stiffness * (x - rest)) / p.mass,
                (r * i * i - (temp - t_amb) / r_th) / c_th]

    p, t = params, 0.0
    pending = sorted(changes, key=lambda change: change[0])
    y = [flux(p, state[0]), state[1], state[2], t_amb]
    out = []
    for u in np.clip(voltages, -params.supply_voltage, params.supply_voltage):
        t_end = t + dt
        while pending and pending[0][0] <= t + 1e-12:
            i = current(p, y[0])
            p = pending.pop(0)[1]
            y[0] = flux(p, i)
        while pending and pending[0][0] < t_end - 1e-12:
            y = solve_ivp(rhs, (t, pending[0][0]), y, args=(p, u), method='DOP853', rtol=1e-11, atol=1e-13).y[:, -1]
            t = pending[0][0]
            i = current(p, y[0])
            p = pending.pop(0)[1]
            y[0] = flux(p, i)  # the current is continuous across a change of L
        y = solve_ivp(rhs, (t, t_end), y, args=(p, u), method='DOP853', rtol=1e-11, atol=1e-13).y[:, -1]
        t = t_end
        out.append((current(p, y[0]), y[1], y[2], y[3]))
    return np.array(out)


def assert_close(result, ref, current_tol, position_tol):
    np.testing.assert_allclose(result['current'], ref[:, 0], rtol=0, atol=current_tol)
    np.testing.assert_allclose(result['position'], ref[:, 1], rtol=0, atol=position_tol)
    np.testing.assert_allclose(result['velocity'], ref[:, 2], rtol=0, atol=position_tol / TS)


# ---- parameters ----

def test_table1_defaults_and_physical():
    assert TABLE1 == ActuatorParameters(4.0, 1.6e-3, 10.8, 0.036, 2.0, 0.0, 24.0)
    assert TABLE1.physical() == {'resistance': 4.0, 'inductance': 1.6e-3, 'emf_constant': 10.8, 'mass': 0.036,
                                 'damping': 2.0, 'load_force': 0.0}
    assert tuple(TABLE1.physical()) == PARAMETER_NAMES
    assert TABLE1.scaled(resistance=1.5, mass=2.0) == TABLE1.replace(resistance=6.0, mass=0.072)


@pytest.mark.parametrize('bad', [dict(resistance=0.0), dict(inductance=-1e-3), dict(emf_constant=0.0),
                                 dict(mass=0.0), dict(damping=-0.1), dict(load_force=math.nan),
                                 dict(supply_voltage=0.0), dict(resistance='4')])
def test_parameters_refuse_unphysical_values(bad):
    with pytest.raises(ValueError, match=next(iter(bad))):
        ActuatorParameters(**bad)


def test_parameters_refuse_unknown_names():
    with pytest.raises(ValueError, match='unknown'):
        TABLE1.scaled(resistence=2.0)


# ---- the linear plant ----

def test_exact_discretisation_matches_solve_ivp():
    params = TABLE1.replace(load_force=3.0)
    voltages = staircase(400)
    result = Plant(params).run(voltages, TS)
    assert_close(result, reference(params, voltages, TS), 1e-9, 1e-12)


def test_step_advance_and_run_agree_and_sampling_conventions():
    voltages = staircase(60, seed=1)
    by_run = Plant().run(voltages, TS)
    stepping = Plant()
    by_step = np.array([stepping.step(u, TS) for u in voltages])
    np.testing.assert_allclose(by_step, np.column_stack([by_run[k] for k in ('current', 'position', 'velocity')]),
                               rtol=1e-12, atol=1e-15)
    assert stepping.time == pytest.approx(60 * TS)
    np.testing.assert_allclose(by_run['time'], TS * np.arange(1, 61))
    start = Plant().run(voltages, TS, sampling='start')
    assert start['current'][0] == 0.0
    np.testing.assert_array_equal(start['current'][1:], by_run['current'][:-1])
    np.testing.assert_allclose(start['time'], TS * np.arange(60))
    block = Plant()
    block.advance(7.0, TS, 5)
    assert block.advance(-3.0, TS, 10)['current'][-1] == pytest.approx(
        Plant().run(np.r_[np.full(5, 7.0), np.full(10, -3.0)], TS)['current'][-1], abs=1e-12)


@pytest.mark.parametrize('load', [0.0, 5.0, -8.0])
def test_dc_steady_state_matches_closed_form(load):
    # u = R I + Km v, Km I = B v + Fl  =>  v = (Km u - R Fl) / (R B + Km^2)
    u = 12.0
    plant = Plant(TABLE1.replace(load_force=load))
    plant.advance(u, TS, 3000)  # 0.3 s, many times the slowest time constant
    v = (KM * u - R * load) / (R * B + KM ** 2)
    assert plant.velocity == pytest.approx(v, rel=1e-9)
    assert plant.current == pytest.approx((u - KM * v) / R, rel=1e-9)
    assert plant.force == pytest.approx(KM * plant.current)


def test_blocked_when_load_balances_the_coil_force():
    u = 6.0
    plant = Plant(TABLE1.replace(load_force=KM * u / R))
    plant.advance(u, TS, 3000)
    assert plant.current == pytest.approx(u / R, rel=1e-9)
    assert plant.velocity == pytest.approx(0.0, abs=1e-9)


def test_voltage_is_clipped_to_the_supply_and_nan_refused():
    high = Plant().run(np.full(50, 100.0), TS)
    np.testing.assert_array_equal(high['voltage'], 24.0)
    np.testing.assert_array_equal(high['current'], Plant().run(np.full(50, 24.0), TS)['current'])
    plant = Plant()
    plant.step(-1e9, TS)
    assert plant.current == pytest.approx(Plant().step(-24.0, TS)[0])
    with pytest.raises(ValueError):
        plant.step(math.nan, TS)
    with pytest.raises(ValueError):
        plant.run([0.0, math.nan], TS)


def test_initial_state_and_temperature_without_effects():
    plant = Plant(initial_state=(1.0, 2e-3, 0.1))
    assert (plant.current, plant.position, plant.velocity, plant.temperature) == (1.0, 2e-3, 0.1, 20.0)
    assert plant.integration == 'exact'
    assert plant.true_parameters() == TABLE1


# ---- effects ----

def zero_strength_effects():
    return [CoulombFriction(coulomb_force=0.0), ReturnSpring(spring_stiffness=0.0),
            ResistanceDrift(temperature_coefficient=0.0),
            InductanceSaturation(inductance_quadratic=0.0), ForceConstantVariation(emf_constant_curvature=0.0)]


def test_rk4_with_zero_strength_effects_equals_the_exact_path():
    voltages = staircase(500, seed=2)
    plant = Plant(TABLE1.replace(load_force=2.0), zero_strength_effects())
    assert plant.integration == 'rk4'
    exact = Plant(TABLE1.replace(load_force=2.0)).run(voltages, TS)
    result = plant.run(voltages, TS)
    assert_close(result, np.column_stack([exact[k] for k in ('current', 'position', 'velocity')]), 1e-7, 1e-10)


def test_smooth_effects_match_solve_ivp_of_the_written_out_model():
    params = TABLE1.replace(load_force=1.0)
    effects = [ReturnSpring(spring_stiffness=1500.0, spring_center=1e-3),
               InductanceSaturation.curve(TABLE1.inductance, 5.0),
               ForceConstantVariation(emf_constant_curvature=-8000.0 * TABLE1.emf_constant, center=2e-3),
               ResistanceDrift.fast(time_constant=0.01)]
    drift = effects[3]
    voltages = staircase(300, seed=3)
    result = Plant(params, effects).run(voltages, TS)
    ref = reference(params, voltages, TS, spring=(1500.0, 1e-3), i_sat=5.0, curvature=(8000.0, 2e-3),
                    thermal=(drift.temperature_coefficient, drift.thermal_resistance,
                             drift.thermal_capacitance, drift.ambient_temperature))
    assert_close(result, ref, 1e-6, 1e-9)  # far below the sensor's 5 mA and 1 um
    np.testing.assert_allclose(result['temperature'], ref[:, 3], rtol=0, atol=1e-6)


class HookOnly:
    """Mixin: the same effect without kernel values, so the plant integrates it through the hooks."""

    def kernel_values(self):
        return None


def test_hook_integration_equals_the_compiled_one():
    effects = [CoulombFriction(coulomb_force=2.0), ReturnSpring(), ResistanceDrift.fast(time_constant=0.005),
               InductanceSaturation(), ForceConstantVariation()]
    hook_only = [dataclasses.make_dataclass('Hook' + type(e).__name__, [], bases=(HookOnly, type(e)),
                                            frozen=True)(**dataclasses.asdict(e)) for e in effects]
    voltages = staircase(120, seed=4, level=10.0)
    compiled, python = Plant(effects=effects), Plant(effects=hook_only)
    assert (compiled.integration, python.integration) == ('rk4', 'rk4-python')
    a, b = compiled.run(voltages, TS), python.run(voltages, TS)
    for key in ('current', 'position', 'velocity', 'temperature', 'force'):
        np.testing.assert_allclose(a[key], b[key], rtol=1e-9, atol=1e-12)


def test_coulomb_friction_below_breakaway_gives_no_motion():
    friction = CoulombFriction(coulomb_force=1.0)
    plant = Plant(effects=[friction])
    below = 0.9 * R * friction.coulomb_force / KM  # steady coil force 0.9 Fc
    result = plant.advance(below, TS, 2000)
    assert np.all(result['position'] == 0.0) and np.all(result['velocity'] == 0.0)
    assert plant.current == pytest.approx(below / R, rel=1e-6)


def test_coulomb_friction_sliding_speed_and_clean_stop():
    fc, u = 1.0, 3.0
    plant = Plant(effects=[CoulombFriction(coulomb_force=fc)])
    plant.advance(u, TS, 3000)
    # sliding: Km I = B v + Fc with u = R I + Km v
    assert plant.velocity == pytest.approx((KM * u / R - fc) / (B + KM ** 2 / R), rel=1e-9)
    stop = plant.advance(0.0, TS, 1000)  # back-EMF braking then friction: it stops and stays
    stopped = np.abs(stop['velocity']) < 1e-9
    k = np.argmax(stopped)
    assert 0 < k < 500 and np.all(stopped[k:])
    assert np.ptp(stop['position'][k:]) < 1e-12
    assert np.all(np.diff(stop['position'][:k]) > 0.0)  # no chatter while stopping


def test_coulomb_friction_reversals_do_not_chatter():
    square = np.tile(np.r_[np.full(200, 2.0), np.full(200, -2.0)], 3)
    velocity = Plant(effects=[CoulombFriction(coulomb_force=1.0)]).run(square, TS)['velocity']
    signs = np.sign(velocity[np.abs(velocity) > 1e-9])
    assert np.count_nonzero(np.diff(signs)) == 5  # one reversal per voltage flip after the first


def test_return_spring_static_equilibrium():
    spring = ReturnSpring(spring_stiffness=2000.0, spring_center=-1e-3)
    plant = Plant(effects=[spring])
    u = 2.0
    plant.advance(u, TS, 5000)  # the slow overdamped pole is at -70 1/s
    assert plant.current == pytest.approx(u / R, rel=1e-9)
    assert plant.position == pytest.approx(spring.spring_center + KM * (u / R) / spring.spring_stiffness, rel=1e-9)


def test_inductance_saturation_speeds_up_the_current_rise():
    nominal = Plant().advance(24.0, TS, 3)['current']
    saturating = Plant(effects=[InductanceSaturation.curve(TABLE1.inductance, 3.0)]).advance(24.0, TS, 3)['current']
    assert np.all(saturating > nominal * 1.05)
    # the steady state does not depend on the inductance
    plant = Plant(effects=[InductanceSaturation.curve(TABLE1.inductance, 3.0)])
    plant.advance(12.0, TS, 3000)
    assert plant.velocity == pytest.approx(KM * 12.0 / (R * B + KM ** 2), rel=1e-9)


def test_resistance_drift_steady_temperature_and_resistance():
    drift = ResistanceDrift.fast(time_constant=0.02)
    spring = ReturnSpring()  # holds the actuator still so the current settles at u / R(T)
    plant = Plant(effects=[drift, spring])
    assert plant.temperature == drift.ambient_temperature
    u = 8.0
    plant.advance(u, TS, 3000)  # 15 thermal time constants
    # steady: dT = R(T) I^2 R_th with I = u / R(T), R(T) = R (1 + alpha dT)
    alpha, r_th = drift.temperature_coefficient, drift.thermal_resistance
    rise = (-1.0 + math.sqrt(1.0 + 4.0 * alpha * u ** 2 * r_th / R)) / (2.0 * alpha)
    assert plant.temperature - drift.ambient_temperature == pytest.approx(rise, rel=1e-5)
    hot = R * (1.0 + 0.0039 * rise)
    assert plant.true_parameters().resistance == pytest.approx(hot, rel=1e-5)
    assert plant.current == pytest.approx(u / hot, rel=1e-5)


def test_resistance_drift_defaults_are_a_slow_copper_coil():
    drift = ResistanceDrift()
    assert drift.temperature_coefficient == 0.0039
    assert 10.0 < drift.thermal_resistance * drift.thermal_capacitance < 300.0
    assert ResistanceDrift.fast(0.1).thermal_resistance * ResistanceDrift.fast(0.1).thermal_capacitance == \
        pytest.approx(0.1)


def test_force_constant_lower_at_the_stroke_ends():
    variation = ForceConstantVariation(emf_constant_curvature=-(4000.0) * TABLE1.emf_constant, center=0.0)
    forces = [Plant(effects=[variation], initial_state=(2.0, x, 0.0)).force for x in (-5e-3, 0.0, 5e-3)]
    assert forces == pytest.approx([0.9 * KM * 2.0, KM * 2.0, 0.9 * KM * 2.0])
    # and in the back-EMF: moving at the stroke end induces less voltage, so the current rises faster
    at_end = Plant(effects=[variation], initial_state=(0.0, 5e-3, 1.0)).step(0.0, TS)[0]
    at_center = Plant(effects=[variation], initial_state=(0.0, 0.0, 1.0)).step(0.0, TS)[0]
    assert 0.85 < at_end / at_center < 0.95


# ---- parameter changes ----

@pytest.mark.parametrize('when', [0.01, 0.01 + 0.37 * TS])
def test_parameter_change_takes_effect_at_its_time(when):
    changes = [ParameterChange(when, 'resistance', 1.5), ParameterChange(when + 0.005, 'mass', 1.5),
               ParameterChange(when + 0.005, 'load_force', value=10.0)]
    voltages = staircase(300, seed=5)
    after_r = TABLE1.scaled(resistance=1.5)
    after_all = after_r.scaled(mass=1.5).replace(load_force=10.0)
    ref = reference(TABLE1, voltages, TS, changes=[(when, after_r), (when + 0.005, after_all)])
    assert_close(Plant(changes=changes).run(voltages, TS), ref, 1e-9, 1e-12)
    stepping = Plant(changes=changes)
    for k, u in enumerate(voltages[:140]):
        stepping.step(u, TS)
        assert stepping.true_parameters() == (TABLE1 if (k + 1) * TS < when - 1e-12 else after_r)
    assert stepping.current == pytest.approx(ref[139, 0], abs=1e-9)


def test_parameter_change_with_effects_and_drift_reported():
    drift = ResistanceDrift.fast(time_constant=0.01)
    plant = Plant(effects=[drift, ReturnSpring()], changes=[ParameterChange(0.02, 'resistance', 1.5)])
    plant.advance(10.0, TS, 300)
    expected = 4.0 * 1.5 * (1.0 + 0.0039 * (plant.temperature - drift.ambient_temperature))
    assert plant.true_parameters().resistance == pytest.approx(expected)
    assert plant.temperature > drift.ambient_temperature + 1.0


def test_bad_parameter_changes_fail_early():
    with pytest.raises(ValueError, match='one of'):
        ParameterChange(0.1, 'stiffness', 2.0)
    with pytest.raises(ValueError, match='exactly one'):
        ParameterChange(0.1, 'mass', 2.0, value=1.0)
    with pytest.raises(ValueError, match='resistance'):
        Plant(changes=[ParameterChange(0.1, 'resistance', -1.0)])


# ---- the effect registry ----

def test_registry_makes_effects_by_name():
    assert set(EFFECTS) >= {'coulomb_friction', 'return_spring', 'resistance_drift', 'inductance_saturation',
                            'force_constant_variation'}
    assert make_effect('return_spring', spring_stiffness=500.0) == ReturnSpring(spring_stiffness=500.0)
    assert Plant(effects=['coulomb_friction']).effects == (CoulombFriction(),)
    with pytest.raises(ValueError, match='unknown effect'):
        make_effect('magic')
    with pytest.raises(ValueError, match='bad parameters'):
        make_effect('return_spring', spring_stifness=1.0)
    with pytest.raises(ValueError, match='force'):
        CoulombFriction(coulomb_force=-1.0)
    with pytest.raises(ValueError, match='once'):
        Plant(effects=['return_spring', ReturnSpring()])


def test_a_registered_user_effect_is_simulated_through_its_hooks():
    @dataclasses.dataclass(frozen=True)
    class ConstantPush(Effect):
        name = 'test_constant_push'
        push: float = 4.0

        def extra_force(self, position, velocity):
            return -self.push  # pushes towards +x

    try:
        register_effect(ConstantPush)
        with pytest.raises(ValueError, match='already registered'):
            register_effect(dataclasses.make_dataclass('Other', [], bases=(ConstantPush,), frozen=True))
        plant = Plant(effects=[make_effect('test_constant_push')])
        assert plant.integration == 'rk4-python'
        plant.advance(0.0, TS, 200)
        assert plant.velocity == pytest.approx(4.0 / (B + KM ** 2 / R), rel=1e-6)  # like Fl = -4 N
    finally:
        EFFECTS.pop('test_constant_push', None)
