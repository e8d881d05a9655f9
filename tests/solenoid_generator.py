"""Solenoid test data made independently of emla_sim and emla_core.physics, for the solenoid identification.

The actuator (SI units), written in its flux linkage psi:

    dpsi/dt = u - R psi / L(x),          L(x) = L0 + a / (g0 - x),   I = psi / L(x)
    m dv/dt = a psi^2 / (2 L(x)^2 (g0 - x)^2) - B v - k x - F0,     dx/dt = v

between inelastic end stops x_min, x_max: the armature that reaches a stop stays on it (v = 0, psi alone
integrated) until the net force pulls it off. Each zero-order-hold interval of the voltage is integrated by
scipy's solve_ivp (DOP853, rtol 1e-11) with terminal events at the stops and at the release, so no step crosses a
mode change. The voltage: levels R I_target held 3-15 ms, I_target uniform in one of three bands drawn at random
(the armature floating, pulled shut, released). The samples at t_k = k Ts: the current plus Gaussian noise, then
quantised by the ADC's step; the position quantised; the voltage held over [t_k, t_k+1). A coil that warms
(`resistance_rise`): R rises linearly from its value at t = 0 by that fraction over the record, held over each
interval at its value at the interval's middle (the voltage levels still ask for currents at the cold R).
A friction of the armature (`params` friction_force Fc, friction_speed v_s): Fc tanh(v / v_s) against the motion,
smooth through v = 0 (not the suite's sign, and no sticking: the stops hold the armature).
Iron saturation (`params` iron_current I_1, iron_flux psi_1): the iron in series with the circuit takes
I_1 (sinh(psi / psi_1) - psi / psi_1) more current (not the suite's cubic: every odd power past the third), so
I = psi / L(x) + that; the force stays psi^2 L'(x) / (2 L(x)^2) (the iron's energy does not depend on x).
Residual magnetism (`params` remanence_current I_r, remanence_flux psi_h): the iron's remanence takes
I_r tanh(psi / psi_h) off the current (not the suite's constant I_r: it fades below psi_h, so an unmagnetised
circuit carries no flux), the force again psi^2 L'(x) / (2 L(x)^2).
Eddy currents (`params` eddy_conductance G, eddy_time tau_e): a branch across the magnetic circuit whose current
i_e lags G dpsi/dt by tau_e, tau_e di_e/dt = G dpsi/dt - i_e (a shorted turn with its own leakage, not the suite's
i_e = G dpsi/dt), so I = psi / L(x) + iron + i_e, carried as a state; tau_e = 0 is the suite's form, the current
then sampled just before the voltage steps. The force stays psi^2 L'(x) / (2 L(x)^2).

    rec, truth = record(rate=1000.0, seed=3)     # truth: {name: value} of the parameters
"""
import numpy as np
from scipy.integrate import solve_ivp

from emla_core.recording import Recording

TRUTH = {'resistance': 6.0, 'leakage_inductance': 5e-3, 'gap_coefficient': 2e-6, 'gap': 1.5e-3, 'mass': 0.02,
         'damping': 3.0, 'spring_stiffness': 3000.0, 'spring_preload': 0.5}
STOPS = (0.0, 1.2e-3)                      # m
BANDS = ((1.0, 1.45), (1.45, 3.0), (0.0, 0.5))   # A
HOLD = (3e-3, 15e-3)                       # s
RTOL, ATOL = 1e-11, (1e-14, 1e-13, 1e-11, 1e-11)  # psi in V s, x in m, v in m/s, i_e in A
EDGE = 1e-15                               # m
STUCK = 1e-9                               # s: a mode change sooner than this after the last is a balance
FRICTION_SPEED = 5e-3                      # m/s: v_s of the armature's friction Fc tanh(v / v_s), if any
EDDY_TIME = 2e-5                           # s: tau_e of the eddy currents' branch, if any


def _model(p):
    r, l0, a, g0, m, b, k, f0 = (p[name] for name in TRUTH)
    fc, vs = p.get('friction_force', 0.0), p.get('friction_speed', FRICTION_SPEED)

    def inductance(x):
        return l0 + a / (g0 - x)

    ge, te = p.get('eddy_conductance', 0.0), p.get('eddy_time', EDDY_TIME)

    def current(psi, x):
        return psi / inductance(x) + iron(psi, p)

    def net_force(psi, x, v):
        i = psi / inductance(x)
        return 0.5 * i * i * a / (g0 - x) ** 2 - b * v - k * x - f0 - fc * np.tanh(v / vs)

    def coil(psi, x, ie, u):
        """(dpsi/dt, di_e/dt): the eddy branch lagging (te > 0) or, te = 0, taking G dpsi/dt at once."""
        if ge and te:
            rate = u - r * (current(psi, x) + ie)
            return rate, (ge * rate - ie) / te
        return (u - r * current(psi, x)) / (1.0 + r * ge), 0.0

    def free(t, y, u):
        psi, x, v, ie = y
        rate, eddy = coil(psi, x, ie, u)
        return [rate, v, net_force(psi, x, v) / m, eddy]

    def held(t, y, u, x):
        return list(coil(y[0], x, y[1], u))
    return free, held, net_force


def iron(psi, p):
    """The iron's share of the current (A) at flux linkage psi: its saturation less its remanence."""
    share = 0.0 * psi
    if p.get('iron_current'):
        z = psi / p['iron_flux']
        share = share + p['iron_current'] * (np.sinh(z) - z)
    if p.get('remanence_current'):
        share = share - p['remanence_current'] * np.tanh(psi / p['remanence_flux'])
    return share


def _interval(state, u, ts, p):
    """(psi, x, v, on_stop, i_e) after one interval at voltage u, from state (psi, x, v, on_stop, i_e)."""
    free, held, net_force = _model(p)
    low, high = STOPS
    t, (psi, x, v, on_stop, ie) = 0.0, state
    while t < ts * (1 - 1e-12):
        if on_stop:
            def release(t, y, u, x=x):
                return net_force(y[0], x, 0.0)
            release.terminal, release.direction = True, (1 if x <= low else -1)
            sol = solve_ivp(held, (t, ts), [psi, ie], 'DOP853', args=(u, x), events=release, rtol=RTOL,
                            atol=(ATOL[0], ATOL[3]))
            if sol.status == 1 and sol.t[-1] - t < STUCK:   # the force balanced on the stop: held a moment longer
                sol = solve_ivp(held, (t, min(t + STUCK, ts)), [psi, ie], 'DOP853', args=(u, x), rtol=RTOL,
                                atol=(ATOL[0], ATOL[3]))
                t, (psi, ie) = sol.t[-1], sol.y[:, -1]
                continue
            t, (psi, ie), v, on_stop = sol.t[-1], sol.y[:, -1], 0.0, sol.status != 1
            continue

        def hit_low(t, y, u):   # (just beyond the stops: an armature leaving one does not hit it at once)
            return y[1] - low + EDGE

        def hit_high(t, y, u):
            return y[1] - high - EDGE
        hit_low.terminal, hit_low.direction = True, -1
        hit_high.terminal, hit_high.direction = True, 1
        sol = solve_ivp(free, (t, ts), [psi, x, v, ie], 'DOP853', args=(u,), events=(hit_low, hit_high), rtol=RTOL,
                        atol=ATOL)
        t, (psi, x, v, ie) = sol.t[-1], sol.y[:, -1]
        if sol.status == 1:   # a stop reached: put on it, at rest, held there while the force presses it on
            x, v = (low if x < 0.5 * (low + high) else high), 0.0
            on_stop = (net_force(psi, x, 0.0) <= 0.0) if x == low else (net_force(psi, x, 0.0) >= 0.0)
    return psi, x, v, on_stop, ie


def voltage(duration, rate, rng, resistance):
    """The held voltage levels, one per sample."""
    n = int(round(duration * rate))
    u = np.empty(n)
    k = 0
    while k < n:
        hold = max(1, int(round(rng.uniform(*HOLD) * rate)))
        u[k:k + hold] = resistance * rng.uniform(*BANDS[rng.integers(len(BANDS))])
        k += hold
    return u


def record(duration=2.0, rate=1000.0, seed=0, params=None, current_noise=5e-3, current_step=10.0 / 2048,
           resolution=1e-6, resistance_rise=0.0):
    """(Recording of t, voltage, current, position; the true parameters) of the solenoid of `params` (TRUTH),
    its R rising by the fraction `resistance_rise` over the record (the parameters hold R at t = 0)."""
    p = dict(TRUTH, **(params or {}))
    rng = np.random.default_rng(seed)
    ts = 1.0 / rate
    u = voltage(duration, rate, rng, p['resistance'])
    n = len(u)
    psi, x, eddy, state = np.empty(n), np.empty(n), np.empty(n), (0.0, STOPS[0], 0.0, True, 0.0)
    for k in range(n):
        psi[k], x[k], eddy[k] = state[0], state[1], state[4]
        rise = 1.0 + resistance_rise * (k + 0.5) / n
        state = _interval(state, u[k], ts, dict(p, resistance=p['resistance'] * rise) if resistance_rise else p)
    current = psi / (p['leakage_inductance'] + p['gap_coefficient'] / (p['gap'] - x)) + iron(psi, p)
    ge = p.get('eddy_conductance', 0.0)
    if ge and not p.get('eddy_time', EDDY_TIME):   # G dpsi/dt with the voltage and R of the interval ending at t_k
        before = np.r_[0.0, u[:-1]]
        r = p['resistance'] * (1.0 + resistance_rise * np.maximum(np.arange(n) - 0.5, 0.0) / n)
        current = current + ge * (before - r * current) / (1.0 + r * ge)
    else:
        current = current + eddy
    current = current + current_noise * rng.standard_normal(n)
    if current_step:
        current = np.round(current / current_step) * current_step
    position = np.round(x / resolution) * resolution if resolution else x
    recording = Recording(ts, {'voltage': u, 'current': current, 'position': position},
                          source=f'independent solenoid, {rate:g} Hz')
    return recording, p


if __name__ == '__main__':
    import time
    for rate in (1000.0, 5000.0):
        started = time.monotonic()
        rec, _ = record(rate=rate)
        x = rec.signals['position']
        print(f'{rate:g} Hz: {time.monotonic() - started:.1f} s; at the stops {np.mean(x <= 0):.2f} / '
              f'{np.mean(x >= STOPS[1]):.2f}; current {np.percentile(rec.signals["current"], [5, 50, 95])}')
