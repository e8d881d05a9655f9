"""The solenoid plant (emla_sim.solenoid, through emla_core.physics.solenoid and equations.coil_rates) against the
independent generator (tests/solenoid_generator.py: flux-linkage state, scipy DOP853, stops by events)."""
import numpy as np
import pytest
from solenoid_generator import record as independent_record

from emla_core.physics import SolenoidParameters
from emla_sim.solenoid import SolenoidPlant, record


@pytest.mark.parametrize('rate', [1000.0, 5000.0])
def test_the_plant_follows_the_independent_solution_through_the_stops(rate):
    rec, truth = independent_record(duration=1.0, rate=rate, current_noise=0.0, current_step=0.0, resolution=0.0)
    out = SolenoidPlant(SolenoidParameters(**truth)).run(rec.signals['voltage'], 1.0 / rate, sampling='start')
    x = rec.signals['position']
    assert np.mean(x <= 0.0) > 0.1 and np.mean(x >= 1.2e-3) > 0.1 and np.mean((x > 0) & (x < 1.2e-3)) > 0.2
    assert np.max(np.abs(out['current'] - rec.signals['current'])) < 2e-4          # A (of 0-3 A)
    assert np.max(np.abs(out['position'] - x)) < 5e-8                              # m (of a 1.2 mm stroke)


def test_a_smooth_friction_of_the_armature_follows_the_independent_solution():
    """Fc tanh(v / v_s) (friction_speed > 0): a load like the spring's, nothing sticks; the generator's own form."""
    friction = {'friction_force': 0.3, 'friction_speed': 5e-3}
    rec, truth = independent_record(duration=0.5, rate=5000.0, params=friction, current_noise=0.0, current_step=0.0,
                                    resolution=0.0)
    out = SolenoidPlant(SolenoidParameters(**truth)).run(rec.signals['voltage'], 2e-4, sampling='start')
    dry = SolenoidPlant(SolenoidParameters(**dict(truth, friction_speed=0.0))).run(rec.signals['voltage'], 2e-4,
                                                                                    sampling='start')
    x = rec.signals['position']
    assert np.max(np.abs(out['position'] - x)) < 5e-8
    assert np.max(np.abs(dry['position'] - x)) > 1e-6   # the dry, sticking form is another plant


def test_eddy_currents_follow_the_independent_solution():
    """eddy_conductance G: I = psi / L(x) + G dpsi/dt, the current sampled before the voltage steps; the generator's
    own form with tau_e = 0 (its lagging branch is the discrepancy tests')."""
    eddy = {'eddy_conductance': 0.02, 'eddy_time': 0.0}
    rec, truth = independent_record(duration=0.5, rate=5000.0, params=eddy, current_noise=0.0, current_step=0.0,
                                    resolution=0.0)
    params = SolenoidParameters(**{k: v for k, v in truth.items() if k != 'eddy_time'})
    out = SolenoidPlant(params).run(rec.signals['voltage'], 2e-4, sampling='start')
    plain = SolenoidPlant(params.replace(eddy_conductance=0.0)).run(rec.signals['voltage'], 2e-4, sampling='start')
    assert np.max(np.abs(out['current'] - rec.signals['current'])) < 2e-4
    assert np.max(np.abs(out['position'] - rec.signals['position'])) < 5e-8
    assert np.max(np.abs(plain['current'] - rec.signals['current'])) > 0.05   # G dpsi/dt: up to 0.1 A here


def test_the_magnetic_circuit_and_its_force():
    p = SolenoidParameters()
    x, i = 0.6e-3, 2.0
    assert p.inductance(x) == pytest.approx(5e-3 + 2e-6 / 0.9e-3)
    slope = (p.inductance(x + 1e-9) - p.inductance(x - 1e-9)) / 2e-9
    assert p.inductance_slope(x) == pytest.approx(slope, rel=1e-6)
    # the force is the co-energy's slope at constant current, d(L(x) I^2 / 2)/dx
    assert p.coil_force(x, i) == pytest.approx(0.5 * i * i * slope, rel=1e-6)
    assert p.coil_force(x, -i) == p.coil_force(x, i) > 0
    assert p.emf_coefficient(x, i) == pytest.approx(i * slope, rel=1e-6)


@pytest.mark.parametrize('bad', [dict(resistance=0.0), dict(stroke_max=2e-3), dict(mass=float('nan')),
                                 dict(stroke_min=1.3e-3), dict(damping=-1.0), dict(friction_speed=-1e-3)])
def test_impossible_parameters_are_refused(bad):
    with pytest.raises(ValueError, match='SolenoidParameters'):
        SolenoidParameters(**bad)


def test_the_recording_moves_the_armature_across_its_stroke_at_a_bias_current():
    rec, truth = record(duration=1.0, sample_period=2e-4)
    x, i = truth['position'], truth['current']
    assert np.mean(x >= 1.2e-3) > 0.2 and np.mean(x <= 0.0) > 0.05 and np.mean((x > 0) & (x < 1.2e-3)) > 0.2
    assert 0.9 < np.median(i) < 3.0 and i.max() < 3.1
    assert rec.truth(['resistance', 'gap'])['gap'] == 1.5e-3


def test_the_observers_armature_step_follows_scipy_and_its_tangent():
    """physics.solenoid.armature_step (the position observer's mechanics, 10 RK4 steps a sample there): a free
    flight at a current ramp and its Jacobian against scipy's DOP853 on m dv/dt = I^2 L'(x) / 2 - B v - k x - F0
    (the Jacobian by central differences of scipy's solutions); an armature pressed on a stop stays, one that
    reaches a stop lands on it at rest."""
    from scipy.integrate import solve_ivp

    from emla_core.physics.solenoid import armature_step
    p = SolenoidParameters()
    kernel, ts = p.kernel_vector(), 2e-4

    def exact(start):
        def rates(t, y):
            i = 1.8 + (2.0 - 1.8) * t / ts
            return [y[1], (p.coil_force(y[0], i) - p.damping * y[1] - p.load(y[0])) / p.mass]
        return solve_ivp(rates, (0.0, ts), start, method='DOP853', rtol=1e-13, atol=1e-16).y[:, -1]
    start = np.array([0.5e-3, 0.05])
    x, v, jacobian, stop = armature_step(*start, 1.8, 2.0, ts, 10, kernel)
    assert stop == -1
    np.testing.assert_allclose([x, v], exact(start), rtol=1e-9)
    for column, delta in ((0, 1e-8), (1, 1e-5)):
        step = np.eye(2)[column] * delta
        np.testing.assert_allclose(jacobian[:, column], (exact(start + step) - exact(start - step)) / (2 * delta),
                                   rtol=1e-6, atol=1e-9)
    assert armature_step(p.stroke_min, 0.0, 0.2, 0.2, ts, 10, kernel)[3] == 0              # the spring holds it
    assert armature_step(p.stroke_max, 0.0, 3.0, 3.0, ts, 10, kernel)[3] == 1              # the coil holds it
    x, v, jacobian, stop = armature_step(p.stroke_max - 1e-6, 0.5, 3.0, 3.0, ts, 10, kernel)
    assert (x, v, stop) == (p.stroke_max, 0.0, 1) and not jacobian.any()
