"""The inverse-system law of the EMLA, its state feedback, and the state estimates it runs on.

Inverse system (docs/physics.md §5). The coil current the mechanics needs for a motion s(t) and the voltage that
drives it follow from the two model equations read backwards:

    I* = (m s'' + B s' + Fl) / Km,    u = R I* + L dI*/dt + Km s'
       = (m L/Km) s''' + ((m R + B L)/Km) s'' + (B R/Km + Km) s' + R Fl/Km

This is the paper's full form. Its mixed form u = (m L/Km) s''' + (B L/Km) s'' + Km s' + R I, with the
measured current I, is the same law here: the controller takes s'' from the force balance
s'' = (Km I - B s' - Fl)/m, and substituting that in either form gives the other. So there is nothing
to decide by measurement between them; this module computes it once, as above.

In series with the plant (exact parameters) the law leaves a triple integrator s''' = w. The virtual input
w = r''' + k2 (r'' - s'') + k1 (r' - s') + k0 (r - s) with (s + wb)(s^2 + 2 zeta wb s + wb^2) as the
closed-loop polynomial makes the tracking error decay with bandwidth wb = 2 pi f and damping ratio zeta.

Sampling. The voltage is held over each control interval, so it acts on average half an interval late. The
law is therefore evaluated for the interval midpoint: the reference there, and the estimated state
predicted there by the triple integrator itself (with the w being computed, which makes w the solution of
a scalar linear equation). With exact parameters this leaves a position error of about Ts^2/24 r''(t)
instead of the Ts/2 r'(t) of a law evaluated at the sample instant.

State estimates. s' comes from a two-state observer on the measured position, driven by the acceleration
from the force balance with the measured current; s'' from the force balance. Both use the controller's
model parameters, never the plant's state.

Effects. A model with Coulomb friction Fc and a spring k (x - xc) (of either sign) has the extra force
F_e = Fc tanh(s'/v_eps) + k (s - xc) opposing +x: it enters the force balance and the inverse like the load
force does (I* = (m s'' + B s' + Fl + F_e)/Km, dI*/dt gains k s'/Km), so the law compensates it instead of
leaving it to the feedback. The friction's direction is smoothed over v_eps (FRICTION_SPEED): at rest the
feedback, not a switching feedforward, holds the part.
"""
import math

import numba
import numpy as np

from emla_core.physics import coil_rates

# Layout of the compiled law's coefficient vector.
(R, L, KM, M, B, FL, K0, K1, K2, L1, L2, TS, SUPPLY, FC, KS, XC) = range(16)
N_COEFFICIENTS = 16
FRICTION_SPEED = 1e-3  # m/s: v_eps of the friction's smoothed direction
# Layout of its state vector: the observer's prior estimates of position and velocity for the next sample.
(X_HAT, V_HAT) = range(2)


@numba.njit(cache=True)
def inverse_voltage(resistance, inductance, emf_constant, mass, damping, load_force,
                    velocity, acceleration, jerk):
    """u = R I* + L dI*/dt + Km s' for the motion (s', s'', s'''); scalars or arrays."""
    current = (mass * acceleration + damping * velocity + load_force) / emf_constant
    current_rate = (mass * jerk + damping * acceleration) / emf_constant
    return resistance * current + inductance * current_rate + emf_constant * velocity


def feedback_gains(bandwidth: float, damping: float) -> tuple[float, float, float]:
    """(k0, k1, k2) placing the closed-loop poles at (s + wb)(s^2 + 2 zeta wb s + wb^2), wb = 2 pi bandwidth."""
    if not (math.isfinite(bandwidth) and bandwidth > 0.0):
        raise ValueError(f'bandwidth must be positive (Hz), got {bandwidth!r}')
    if not (math.isfinite(damping) and damping > 0.0):
        raise ValueError(f'damping ratio must be positive, got {damping!r}')
    wb = 2.0 * math.pi * bandwidth
    return wb ** 3, (1.0 + 2.0 * damping) * wb ** 2, (1.0 + 2.0 * damping) * wb


def observer_gains(bandwidth: float, sample_period: float) -> tuple[float, float]:
    """(l1, l2) of the position/velocity observer with both error poles at z = exp(-2 pi bandwidth Ts).

    Predictor x+ = x + Ts v + ..., v+ = v + Ts a + ..., corrector x += l1 e, v += l2 e (e = measured - x):
    the error matrix (I - l c) A has trace 2 - l1 - l2 Ts and determinant 1 - l1, hence the gains.
    """
    if not (math.isfinite(bandwidth) and bandwidth > 0.0):
        raise ValueError(f'observer bandwidth must be positive (Hz), got {bandwidth!r}')
    pole = math.exp(-2.0 * math.pi * bandwidth * sample_period)
    return 1.0 - pole ** 2, (1.0 - pole) ** 2 / sample_period


@numba.njit(cache=True)
def effect_force(c, position, velocity):
    """F_e of the model's effects (opposing +x) at a position and velocity."""
    return c[FC] * math.tanh(velocity / FRICTION_SPEED) + c[KS] * (position - c[XC])


@numba.njit(cache=True)
def _corrected(state, c, position):
    """The observer's position and velocity corrected with a measured position."""
    e = position - state[X_HAT]
    return state[X_HAT] + c[L1] * e, state[V_HAT] + c[L2] * e


@numba.njit(cache=True)
def _law(c, r0, r1, r2, r3, current, x, v):
    """(limited voltage, acceleration, jerk) of the interval starting at the state (current, x, v): the voltage,
    the acceleration at the start and the jerk the limited voltage gives. r0..r3 = reference s, s', s'', s'''
    at the interval midpoint."""
    a = _derivatives(c, current, x, v, 0.0)[2]   # the force balance (the voltage does not enter it)
    h = 0.5 * c[TS]
    w = (r3 + c[K2] * (r2 - a) + c[K1] * (r1 - v - h * a) + c[K0] * (r0 - x - h * v - 0.5 * h * h * a)) \
        / (1.0 + c[K2] * h + 0.5 * c[K1] * h * h + c[K0] * h * h * h / 6.0)
    v_mid = v + h * a + 0.5 * h * h * w
    x_mid = x + h * v + 0.5 * h * h * a
    u = inverse_voltage(c[R], c[L], c[KM], c[M], c[B], c[FL] + effect_force(c, x_mid, v_mid), v_mid, a + h * w, w) \
        + c[L] * c[KS] * v_mid / c[KM]
    limited = min(max(u, -c[SUPPLY]), c[SUPPLY])
    # The jerk the limited voltage really gives (u is affine in w), so saturation cannot wind the observer up.
    du_dw = (c[M] * c[L] + h * (c[M] * c[R] + c[B] * c[L]) + 0.5 * h * h * (c[B] * c[R] + c[KM] ** 2)) / c[KM]
    return limited, a, w + (limited - u) / du_dw


@numba.njit(cache=True)
def control_step(state, c, r0, r1, r2, r3, current, position):
    """One control interval: correct the observer with the measurement, return the (limited) voltage, and
    predict the state for the next sample. r0..r3 = reference s, s', s'', s''' at the interval midpoint."""
    x, v = _corrected(state, c, position)
    limited, a, w = _law(c, r0, r1, r2, r3, current, x, v)
    ts = c[TS]
    state[X_HAT] = x + ts * v + 0.5 * ts * ts * a + ts * ts * ts * w / 6.0
    state[V_HAT] = v + ts * a + 0.5 * ts * ts * w
    return limited


@numba.njit(cache=True)
def law_voltage(state, c, r0, r1, r2, r3, current, position):
    """The (limited) voltage of control_step, the observer left as it is."""
    x, v = _corrected(state, c, position)
    return _law(c, r0, r1, r2, r3, current, x, v)[0]


@numba.njit(cache=True)
def _derivatives(c, current, x, v, voltage):
    """(I', x', v') of the model: L I' = u - R I - Km v, x' = v, m v' = Km I - B v - Fl - F_e(x, v)."""
    di, dv = coil_rates(current, v, voltage, c[R], c[L], c[KM], c[KM] * current, c[M], c[B],
                        c[FL] + effect_force(c, x, v), 0.0, 1.0)
    return di, v, dv


@numba.njit(cache=True)
def predict(c, current, x, v, voltage, duration, steps):
    """The model's (current, position, velocity) `duration` s on under a constant `voltage` (RK4, `steps` steps)."""
    h = duration / steps
    for _ in range(steps):
        k1 = _derivatives(c, current, x, v, voltage)
        k2 = _derivatives(c, current + 0.5 * h * k1[0], x + 0.5 * h * k1[1], v + 0.5 * h * k1[2], voltage)
        k3 = _derivatives(c, current + 0.5 * h * k2[0], x + 0.5 * h * k2[1], v + 0.5 * h * k2[2], voltage)
        k4 = _derivatives(c, current + h * k3[0], x + h * k3[1], v + h * k3[2], voltage)
        current += h * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]) / 6.0
        x += h * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]) / 6.0
        v += h * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]) / 6.0
    return current, x, v


@numba.njit(cache=True)
def delayed_control_step(state, c, r0, r1, r2, r3, current, position, held, steps):
    """One control interval ahead: correct the observer with the measurement at t, predict the state at t + Ts
    from the model under `held` (the voltage over [t, t + Ts), decided an interval earlier; RK4 in `steps`
    steps), and return the (limited) voltage for [t + Ts, t + 2 Ts) from that state; r0..r3 = the reference at
    that interval's midpoint. The prediction is the observer's prior for the next measurement."""
    x, v = _corrected(state, c, position)
    current, state[X_HAT], state[V_HAT] = predict(c, current, x, v, held, c[TS], steps)
    return _law(c, r0, r1, r2, r3, current, state[X_HAT], state[V_HAT])[0]


def open_loop_voltage(params, reference, times, sample_period):
    """The inverse alone (no feedback) as ZOH voltages over [t, t + Ts) for each t in `times`."""
    _, velocity, acceleration, jerk = reference(np.asarray(times) + 0.5 * sample_period)
    p = params
    return inverse_voltage(p.resistance, p.inductance, p.emf_constant, p.mass, p.damping, p.load_force,
                           velocity, acceleration, jerk)
