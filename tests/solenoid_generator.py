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

A proportional solenoid in closed loop (`closed_loop`): the armature held between its stops, started at rest at
mid-stroke with the flux linkage that balances it, following a position reference within `span` of mid-stroke
(random levels through a critically damped second-order filter, or a multi-sine). A PID position loop computes a
force demand m (s'' + 2 zeta w (s' - v) + w^2 (s - x) + INTEGRAL w^3 int (s - x)) + k x + F0, turned into a
current demand by the force law read backwards, I* = (g0 - x) sqrt(2 F* / a) (plus, as a proportional valve's
driver may add, a dither of `dither` A at DITHER_FREQUENCY), and a voltage by
u = R I* + PI on I* - I (its proportional gain CURRENT_GAIN L(x) / Ts), clipped to +-SUPPLY; every parameter of
the loop is the generator's nominal one (NOMINAL: the truth a few per cent off), v the measured position's
difference low-passed. The loop sees the sensors of the open-loop record (noisy, quantised current; quantised
position) and sets the voltage held over the next interval from them.

    rec, truth = record(rate=1000.0, seed=3)     # truth: {name: value} of the parameters
    rec, truth = closed_loop(rate=5000.0, seed=3, reference='multisine')
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
# The closed loop: the controller's parameters, times the truth (deliberately off); its supply, bandwidths, gains.
NOMINAL = {'resistance': 1.04, 'leakage_inductance': 1.1, 'gap_coefficient': 0.95, 'gap': 1.03, 'mass': 1.08,
           'spring_stiffness': 0.92, 'spring_preload': 1.1}
SUPPLY = 24.0                              # V: the driver's limit, +-
LOOP_BANDWIDTH, LOOP_DAMPING, INTEGRAL = 60.0, 0.8, 0.2   # Hz, zeta, share of w^3 on the position error's integral
REFERENCE_BANDWIDTH = 25.0                 # Hz: the critically damped filter of the reference's levels
VELOCITY_BANDWIDTH = 300.0                 # Hz: the low-pass on the measured position's difference
CURRENT_GAIN, CURRENT_TIME = 0.5, 10.0     # the current loop's gain (of L(x) / Ts) and integral time (samples)
LEVEL_HOLD = (0.02, 0.08)                  # s: the reference's levels
MULTISINE = (1.0, 40.0, 12)                # Hz, Hz, count: the multi-sine's lowest and highest frequency
DITHER_FREQUENCY = 150.0                   # Hz: a proportional valve's driver's dither on the current demand


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


def _sensed(psi, x, eddy, before, p, rng, current_noise, current_step, resolution, rise=1.0):
    """(current, position) as sampled: the coil's current (its eddy branch lagging, or with tau_e = 0 taking
    G dpsi/dt at the voltage `before` of the interval ending there and R times `rise`) plus noise, quantised; the
    position quantised."""
    current = psi / (p['leakage_inductance'] + p['gap_coefficient'] / (p['gap'] - x)) + iron(psi, p)
    ge = p.get('eddy_conductance', 0.0)
    if ge and not p.get('eddy_time', EDDY_TIME):
        r = p['resistance'] * rise
        current = current + ge * (before - r * current) / (1.0 + r * ge)
    else:
        current = current + eddy
    current = current + current_noise * rng.standard_normal(np.shape(psi))
    if current_step:
        current = np.round(current / current_step) * current_step
    position = np.round(x / resolution) * resolution if resolution else x
    return current, position


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
    # (with tau_e = 0, G dpsi/dt at the voltage and R of the interval ending at t_k)
    rise = 1.0 + resistance_rise * np.maximum(np.arange(n) - 0.5, 0.0) / n
    current, position = _sensed(psi, x, eddy, np.r_[0.0, u[:-1]], p, rng, current_noise, current_step, resolution,
                                rise)
    recording = Recording(ts, {'voltage': u, 'current': current, 'position': position},
                          source=f'independent solenoid, {rate:g} Hz')
    return recording, p


def reference_levels(duration, rate, rng, span):
    """(s, s', s'') per sample: levels uniform within `span` of mid-stroke, each held LEVEL_HOLD, through a
    critically damped second-order filter of REFERENCE_BANDWIDTH (so the motion it asks for is smooth)."""
    n, ts = int(round(duration * rate)), 1.0 / rate
    mid = 0.5 * (STOPS[0] + STOPS[1])
    levels = np.empty(n)
    k = 0
    while k < n:
        hold = max(1, int(round(rng.uniform(*LEVEL_HOLD) * rate)))
        levels[k:k + hold] = mid + rng.uniform(-span, span)
        k += hold
    w = 2 * np.pi * REFERENCE_BANDWIDTH
    out = np.empty((n, 3))
    s, rate_s = mid, 0.0
    for k in range(n):
        accel = w * w * (levels[k] - s) - 2.0 * w * rate_s
        out[k] = s, rate_s, accel
        s, rate_s = s + rate_s * ts, rate_s + accel * ts
    return out


def reference_multisine(duration, rate, rng, span):
    """(s, s', s'') per sample: MULTISINE's sines, log-spaced, random phases, amplitudes falling as 1 / f, scaled
    to a peak of `span` about mid-stroke, faded in over the lowest one's period."""
    t = np.arange(int(round(duration * rate))) / rate
    low, high, count = MULTISINE
    w = 2 * np.pi * np.geomspace(low, high, count)
    phase = rng.uniform(0.0, 2 * np.pi, count)
    amplitude = 1.0 / w
    fade = np.minimum(t * low, 1.0)
    waves = [amplitude[:, None] * f(w[:, None] * t + phase[:, None]) * w[:, None] ** j
             for j, f in enumerate((np.sin, np.cos, lambda z: -np.sin(z)))]
    s, rate_s, accel = (fade * wave.sum(axis=0) for wave in waves)   # (the fade's own slope left out: slow)
    scale = span / np.max(np.abs(s))
    return np.column_stack((0.5 * (STOPS[0] + STOPS[1]) + scale * s, scale * rate_s, scale * accel))


def closed_loop(duration=2.0, rate=1000.0, seed=0, params=None, reference='levels', span=0.3e-3, dither=0.0,
                current_noise=5e-3, current_step=10.0 / 2048, resolution=1e-6):
    """(Recording of t, voltage, current, position; the true parameters) of the solenoid of `params` (TRUTH) held
    by the generator's position loop (module docstring) on a reference ('levels' or 'multisine') within `span`
    (m) of mid-stroke, a dither of `dither` A at DITHER_FREQUENCY on the current demand."""
    p = dict(TRUTH, **(params or {}))
    nominal = {name: p[name] * factor for name, factor in NOMINAL.items()}
    rng = np.random.default_rng(seed)
    ts = 1.0 / rate
    plan = {'levels': reference_levels, 'multisine': reference_multisine}[reference](duration, rate, rng, span)
    n = len(plan)
    # at rest at mid-stroke, the flux linkage whose force balances the spring there
    x0 = plan[0, 0]
    held = (p['gap'] - x0) * np.sqrt(2.0 * (p['spring_stiffness'] * x0 + p['spring_preload']) / p['gap_coefficient'])
    state = (held * (p['leakage_inductance'] + p['gap_coefficient'] / (p['gap'] - x0)), x0, 0.0, False, 0.0)
    w = 2 * np.pi * LOOP_BANDWIDTH
    smooth = np.exp(-2 * np.pi * VELOCITY_BANDWIDTH * ts)
    u, current, position = np.empty(n), np.empty(n), np.empty(n)
    velocity, error_integral, current_integral, last, before = 0.0, 0.0, 0.0, None, 0.0
    for k in range(n):
        psi, x, _, _, eddy = state
        current[k], position[k] = _sensed(psi, x, eddy, before, p, rng, current_noise, current_step, resolution)
        measured = position[k]
        velocity = smooth * velocity + (1.0 - smooth) * (0.0 if last is None else (measured - last) / ts)
        last = measured
        s, rate_s, accel = plan[k]
        error = s - measured
        error_integral += error * ts
        force = (nominal['mass'] * (accel + 2 * LOOP_DAMPING * w * (rate_s - velocity) + w * w * error
                                    + INTEGRAL * w ** 3 * error_integral)
                 + nominal['spring_stiffness'] * measured + nominal['spring_preload'])
        gap = max(nominal['gap'] - measured, 1e-6)
        demand = gap * np.sqrt(2.0 * max(force, 0.0) / nominal['gap_coefficient'])   # the force law backwards
        demand += dither * np.sin(2 * np.pi * DITHER_FREQUENCY * k * ts)
        gain = CURRENT_GAIN * (nominal['leakage_inductance'] + nominal['gap_coefficient'] / gap) / ts
        current_integral += (demand - current[k]) * gain / CURRENT_TIME
        u[k] = before = float(np.clip(nominal['resistance'] * demand + gain * (demand - current[k])
                                      + current_integral, -SUPPLY, SUPPLY))
        state = _interval(state, u[k], ts, p)
    recording = Recording(ts, {'voltage': u, 'current': current, 'position': position},
                          source=f'independent solenoid in closed loop, {rate:g} Hz')
    return recording, p


if __name__ == '__main__':
    import time
    for rate in (1000.0, 5000.0):
        started = time.monotonic()
        rec, _ = record(rate=rate)
        x = rec.signals['position']
        print(f'{rate:g} Hz: {time.monotonic() - started:.1f} s; at the stops {np.mean(x <= 0):.2f} / '
              f'{np.mean(x >= STOPS[1]):.2f}; current {np.percentile(rec.signals["current"], [5, 50, 95])}')
