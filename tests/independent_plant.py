"""Closed-loop test data with hidden effects, made independently of emla_sim, for the model-discrepancy workflow.

A test asks for a record in which some effect is at work (a return spring, cogging, ...) and checks that
the discrepancy workflow names it (library effects) or calls the gap unexplained and places it on the right
signal (effects outside the library), without the record telling the workflow anything: the Recording holds
only voltage, current and position, its metadata only the nominal parameters; what was hidden comes back
separately, in the `truth` dict.

The plant (SI units; state coil current I, position x, velocity v):

    L(I, x) dI/dt = u_applied - R(t) I - Km(x) v - I L'(x) v      (electrical)
    m dv/dt    = F_coil(I, x) - B v - Fl - F_extra(x, v, I, t),   dx/dt = v   (mechanical)

with F_coil = Km(x) I; without effects L, R and Km are constants, u_applied = u and F_extra = 0. It is
integrated by fixed-step RK4, `substeps` steps per sample, the commanded voltage u_k held over
[t_k, t_k + Ts) (zero-order hold). The loop: a PID on the sensed position tracking a square-wave stroke
(0 / `stroke`, period 40 ms) plus a Gaussian voltage dither that keeps the identification excited; the
voltage is clipped to +-24 V. The sensor at t_k: current + Gaussian noise, position quantised to
`resolution`, each optionally d samples late. Everything random comes from one numpy Generator: a seed
gives the same record every time.

    rec, truth = record(effects=[ReturnSpring(stiffness=1500.0), 'cogging'], seed=3)
    rec, truth = record(params=random_parameters(seed=5), effects=['coulomb_friction'])

Effects (by name; `make_effect(name, **parameters)`, or the classes below):
  in the library: coulomb_friction, smooth_friction, stribeck_friction, return_spring, magnetic_stiffness,
                  resistance_drift, inductance_saturation, force_constant_variation, position_inductance,
                  sensor_delay (whole or fractional samples), sensor_filter, drive_voltage_error,
                  current_sensor_offset
  not in it:      quadratic_drag, cogging, time_varying_load, force_saturation

Print what each effect does to a record, and the generation time:
    .venv/bin/python tests/independent_plant.py
"""
import dataclasses
import math
import sys
import time
from typing import ClassVar

import numpy as np
from actuators import ACTUATORS

from emla_core.recording import Recording

SAMPLE_PERIOD = 1e-4       # s (10 kHz)
SUPPLY = 24.0              # V, the drive's voltage limit
SUBSTEPS = 4               # RK4 steps per sample (h = 25 us; the stiffest default effect, the drive's
                           # voltage drop reversing over +-20 mA, has |lambda| h ~ 0.4; the nominal plant
                           # |lambda| h ~ 0.04, the stuck friction contact ~ 0.1)

# Near the paper's Table 1 (SI): ohm, H, V s/m = N/A, kg, N s/m, N.
NOMINAL = dict(ACTUATORS['table1'])

# PID on the sensed position (98 % of a 2.5 mm step in about 10 ms at NOMINAL, then a slow integral overshoot
# of a few %; checked stable for random +-20 % parameter sets, alone and with all the effects at their
# defaults combined).
KP = 12000.0   # V/m
KI = 1.5e5     # V/(m s)
KD = 25.0      # V s/m

EFFECTS = {}


def _effect(cls):
    EFFECTS[cls.name] = cls
    return cls


@dataclasses.dataclass(frozen=True)
class Effect:
    """Base of the effects: `name`, whether the discrepancy library knows it (`in_library`), `parameters()`."""

    name: ClassVar[str] = ''
    in_library: ClassVar[bool] = True

    def parameters(self):
        return dataclasses.asdict(self)


# ---------------------------------------------------------------- effects the library should name
@_effect
@dataclasses.dataclass(frozen=True)
class CoulombFriction(Effect):
    """Dry friction Fc sign(v) with a stuck contact at v = 0 (an elasto-plastic, LuGre-like bristle z):

        F_extra = Fc z / delta + sigma1 dz/dt,   dz/dt = v while |z| < delta or z v < 0 (stuck), else 0,
        sigma1 = 2 sqrt(m Fc / delta)   (the stuck contact critically damped)

    While sliding |z| = delta and F_extra = Fc sign(v) exactly; while stuck the contact is a stiff spring
    Fc / delta (the part moves less than `presliding` before it breaks away), so the force is defined and
    continuous at v = 0 and the loop's hunting at rest is real stick-slip.
    force: Fc (N); presliding: delta (m).
    """

    name: ClassVar[str] = 'coulomb_friction'
    force: float = 1.0
    presliding: float = 2e-6


@_effect
@dataclasses.dataclass(frozen=True)
class SmoothFriction(Effect):
    """Friction without sticking, smooth through zero speed: F_extra = Fc tanh(v / v_s) (a lubricated contact,
    or a friction model as many simulators write it). force: Fc (N); speed: v_s (m/s)."""

    name: ClassVar[str] = 'smooth_friction'
    force: float = 0.8
    speed: float = 2e-3


@_effect
@dataclasses.dataclass(frozen=True)
class StribeckFriction(Effect):
    """Dry friction whose level falls from the breakaway force Fs at rest to the Coulomb level Fc at speed:
    g(v) = Fc + (Fs - Fc) exp(-(v / v_s)^2), with the stuck contact of CoulombFriction at that level:

        F_extra = g(v) z / delta + sigma1 dz/dt,   dz/dt = v while |z| < delta or z v < 0, else 0,
        sigma1 = 2 sqrt(m Fs / delta)

    While sliding F_extra = g(v) sign(v); the part breaks away at Fs. coulomb: Fc (N); static: Fs (N);
    speed: v_s (m/s); presliding: delta (m)."""

    name: ClassVar[str] = 'stribeck_friction'
    coulomb: float = 0.8
    static: float = 1.4
    speed: float = 0.01
    presliding: float = 2e-6


@_effect
@dataclasses.dataclass(frozen=True)
class ReturnSpring(Effect):
    """A spring pulling back to its rest position: F_extra = k (x - x0), k > 0.
    stiffness: k (N/m); rest_position: x0 (m)."""

    name: ClassVar[str] = 'return_spring'
    stiffness: float = 1500.0
    rest_position: float = 0.0


@_effect
@dataclasses.dataclass(frozen=True)
class MagneticStiffness(Effect):
    """Reluctance force pulling toward a pole on the +x side, linearised: F_extra = -k (x - xc), k > 0
    (a spring of negative stiffness; the force on the part is +k (x - xc)).
    stiffness: k (N/m); center: xc (m), where the linearised force is zero."""

    name: ClassVar[str] = 'magnetic_stiffness'
    stiffness: float = 2000.0
    center: float = 0.0


@_effect
@dataclasses.dataclass(frozen=True)
class ResistanceDrift(Effect):
    """The coil heats: R(t) = R0 (1 + alpha T), T the temperature rise over ambient (0 at the start),

        dT/dt = (R(t) I^2 - T / R_th) / C_th

    The defaults are time-compressed (tau = R_th C_th = 3.6 s; a real coil takes minutes) so that R rises by
    about 17 % within a 3 s record of the default loop (about 3 W of copper loss).
    thermal_resistance: R_th (K/W); thermal_capacitance: C_th (J/K); coefficient: alpha (1/K, copper 0.0039)."""

    name: ClassVar[str] = 'resistance_drift'
    thermal_resistance: float = 30.0
    thermal_capacitance: float = 0.12
    coefficient: float = 0.0039


@_effect
@dataclasses.dataclass(frozen=True)
class InductanceSaturation(Effect):
    """The iron saturates: flux psi(I) = L0 I_sat atan(I / I_sat), so the incremental inductance is
    L(I) = dpsi/dI = L0 / (1 + (I / I_sat)^2) and the electrical equation dpsi/dt = L(I) dI/dt =
    u - R I - Km v. saturation_current: I_sat (A); at the default L halves at the default loop's peak
    currents (~4 A) and falls by ~8 % at 1.2 A (its 90th percentile of |I|)."""

    name: ClassVar[str] = 'inductance_saturation'
    saturation_current: float = 4.0


@_effect
@dataclasses.dataclass(frozen=True)
class PositionInductance(Effect):
    """The coil moves into the iron: flux psi = L(x) I with L(x) = L0 exp(a (x - xc)), so
    L(x) dI/dt = u - R I - Km v - I L'(x) v and the co-energy adds the force I^2 L'(x) / 2 along +x,
    L'(x) = a L(x). growth: a (1/m); center: xc (m). At the default L rises 10 % over the default stroke and
    the force reaches about 0.5 N at 4 A."""

    name: ClassVar[str] = 'position_inductance'
    growth: float = 40.0
    center: float = 1.25e-3


@_effect
@dataclasses.dataclass(frozen=True)
class ForceConstantVariation(Effect):
    """Field fringing: Km(x) = Km0 (1 + a (x - xc) + b (x - xc)^2) in the coil force Km(x) I and in the
    back-EMF Km(x) v alike. slope: a (1/m); curvature: b (1/m^2); center: xc (m; the default stroke's
    middle). Defaults: Km about +-3.75 % and -4.7 % at the ends of the 2.5 mm stroke."""

    name: ClassVar[str] = 'force_constant_variation'
    slope: float = 30.0
    curvature: float = -3.0e4
    center: float = 1.25e-3


@_effect
@dataclasses.dataclass(frozen=True)
class SensorDelay(Effect):
    """The sensed current is current(t_k - d_I Ts), the sensed position position(t_k - d_x Ts); the loop
    and the record both get the late samples (the voltage is not delayed). current, position: d_I, d_x
    (samples, >= 0; fractional ones read between samples by cubic Hermite interpolation of the state and its
    derivative, dI/dt under the voltage held over that interval and v)."""

    name: ClassVar[str] = 'sensor_delay'
    current: float = 0
    position: float = 2


@_effect
@dataclasses.dataclass(frozen=True)
class SensorFilter(Effect):
    """An analogue first-order low-pass (an anti-alias filter) in front of the sampler: the sensed current is
    y_I + noise with tau_I dy_I/dt = I - y_I, tau_I = 1 / (2 pi f_I), and likewise the position (its filter
    before the quantiser). Each filter is integrated exactly for the current or position linear over each
    RK4 sub-step. The loop and the record both get the filtered signals. current_cutoff, position_cutoff:
    f_I, f_x (Hz; 0: no filter)."""

    name: ClassVar[str] = 'sensor_filter'
    current_cutoff: float = 3000.0
    position_cutoff: float = 0.0


@_effect
@dataclasses.dataclass(frozen=True)
class DriveVoltageError(Effect):
    """The drive applies u_applied = u - Vd s(I) - V0 while the record holds the commanded u: Vd the
    H-bridge dead-time drop against the current direction, s(I) = tanh(I / I_band) (the drop reverses
    over a small band of current, as a real bridge's does), V0 a constant offset.
    dead_time_drop: Vd (V); offset: V0 (V); current_band: I_band (A)."""

    name: ClassVar[str] = 'drive_voltage_error'
    dead_time_drop: float = 0.5
    offset: float = 0.2
    current_band: float = 0.02


@_effect
@dataclasses.dataclass(frozen=True)
class CurrentSensorOffset(Effect):
    """The sensed current carries a constant bias: I_measured = I + I0 + noise (the loop does not use the
    current, so only the record sees it). offset: I0 (A)."""

    name: ClassVar[str] = 'current_sensor_offset'
    offset: float = 0.05


# ---------------------------------------------------------------- effects outside the library
@_effect
@dataclasses.dataclass(frozen=True)
class QuadraticDrag(Effect):
    """Fluid drag: F_extra = c v |v| (depends on velocity). coefficient: c (N s^2/m^2); the default gives
    3.6 N at the default loop's peak speed (~0.95 m/s), where the viscous B v is 1.9 N."""

    name: ClassVar[str] = 'quadratic_drag'
    in_library: ClassVar[bool] = False
    coefficient: float = 4.0


@_effect
@dataclasses.dataclass(frozen=True)
class Cogging(Effect):
    """Detent force: F_extra = A sin(2 pi (x - x_phase) / pitch) (depends on position).
    amplitude: A (N); pitch (m); phase: x_phase (m)."""

    name: ClassVar[str] = 'cogging'
    in_library: ClassVar[bool] = False
    amplitude: float = 1.5
    pitch: float = 1.3e-3
    phase: float = 0.0


@_effect
@dataclasses.dataclass(frozen=True)
class TimeVaryingLoad(Effect):
    """A slowly varying external load: F_extra = A sin(2 pi t / P + phi) (depends on time).
    amplitude: A (N); period: P (s); phase: phi (rad)."""

    name: ClassVar[str] = 'time_varying_load'
    in_library: ClassVar[bool] = False
    amplitude: float = 2.0
    period: float = 0.7
    phase: float = 0.0


@_effect
@dataclasses.dataclass(frozen=True)
class ForceSaturation(Effect):
    """The coil force saturates: Km I becomes Km I_s tanh(I / I_s) (depends on current); the back-EMF
    stays Km v. saturation_current: I_s (A); at the default the force falls 24 % short at the default loop's
    peak currents (~4 A) and 3 % at 1.2 A (its 90th percentile of |I|)."""

    name: ClassVar[str] = 'force_saturation'
    in_library: ClassVar[bool] = False
    saturation_current: float = 4.0


def make_effect(name, **parameters):
    """The effect called `name` with `parameters` (the rest at their defaults)."""
    if name not in EFFECTS:
        raise ValueError(f'unknown effect {name!r}; known: {", ".join(EFFECTS)}')
    return EFFECTS[name](**parameters)


def _as_effects(effects, delays):
    """Effect instances from instances, names, (name, {parameters}) pairs or a {name: {parameters}} dict."""
    if isinstance(effects, dict):
        effects = list(effects.items())
    out = []
    for e in effects:
        if isinstance(e, Effect):
            out.append(e)
        elif isinstance(e, str):
            out.append(make_effect(e))
        else:
            name, parameters = e
            out.append(make_effect(name, **(parameters or {})))
    if delays:
        out.append(SensorDelay(**delays))
    names = [e.name for e in out]
    if len(set(names)) != len(names):
        raise ValueError(f'an effect appears twice: {names}')
    return {e.name: e for e in out}


def random_parameters(seed=0, spread=0.2, base=None):
    """Nominal parameters with R, L, Km, m and B each drawn uniformly within +-`spread` (relative) of `base`
    (default NOMINAL); the load force is kept. `seed`: an int or a numpy Generator."""
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    base = dict(NOMINAL if base is None else base)
    for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping'):
        base[name] = float(base[name] * (1.0 + spread * rng.uniform(-1.0, 1.0)))
    return base


def _simulate(p, fx, n, ts, substeps, stroke, period, dither, current_noise, resolution, rng):
    """The closed loop for n samples; (voltage, current, position, true resistance at the samples)."""
    r0, l0, km0, m, b, fl = (float(p[k]) for k in ('resistance', 'inductance', 'emf_constant', 'mass',
                                                    'damping', 'load_force'))
    inv_m = 1.0 / m
    inv_l0 = 1.0 / l0

    e = fx.get('force_constant_variation')
    kmvar = e is not None
    ka, kb, kc = (e.slope, e.curvature, e.center) if kmvar else (0.0, 0.0, 0.0)
    e = fx.get('resistance_drift')
    drift = e is not None
    alpha, inv_rth, inv_cth = (e.coefficient, 1.0 / e.thermal_resistance, 1.0 / e.thermal_capacitance) \
        if drift else (0.0, 0.0, 0.0)
    e = fx.get('drive_voltage_error')
    drive = e is not None
    vd, v0, inv_iband = (e.dead_time_drop, e.offset, 1.0 / e.current_band) if drive else (0.0, 0.0, 0.0)
    e = fx.get('position_inductance')
    pind = e is not None
    ga, gc = (e.growth, e.center) if pind else (0.0, 0.0)
    e = fx.get('inductance_saturation')
    lsat = e is not None
    if lsat and pind:
        raise ValueError('position_inductance and inductance_saturation together are not modelled')
    inv_isat = 1.0 / e.saturation_current if lsat else 0.0
    e = fx.get('force_saturation')
    fsat = e is not None
    fs = e.saturation_current if fsat else 0.0
    inv_fs = 1.0 / fs if fsat else 0.0
    e = fx.get('coulomb_friction')
    fric = e is not None
    fc, delta = (e.force, e.presliding) if fric else (0.0, 1.0)
    fc_delta = fc / delta
    sigma1 = 2.0 * math.sqrt(m * fc_delta)
    e = fx.get('stribeck_friction')
    stribeck = e is not None
    if stribeck and fric:
        raise ValueError('coulomb_friction and stribeck_friction together are not modelled')
    if stribeck:   # the bristle contact of coulomb_friction, its level g(v) falling from Fs to Fc
        fric = True
        fc, excess, inv_vs, delta = e.coulomb, e.static - e.coulomb, 1.0 / e.speed, e.presliding
        sigma1 = 2.0 * math.sqrt(m * e.static / delta)
    e = fx.get('smooth_friction')
    smooth = e is not None
    sf_force, sf_inv_speed = (e.force, 1.0 / e.speed) if smooth else (0.0, 0.0)
    # the stiffnesses and the other forces on position, velocity and time
    k_lin, x_lin = 0.0, 0.0   # F_extra += k_lin * x - x_lin: springs (return and magnetic) combined
    e = fx.get('return_spring')
    if e is not None:
        k_lin += e.stiffness
        x_lin += e.stiffness * e.rest_position
    e = fx.get('magnetic_stiffness')
    if e is not None:
        k_lin -= e.stiffness
        x_lin -= e.stiffness * e.center
    spring = k_lin != 0.0 or x_lin != 0.0
    e = fx.get('quadratic_drag')
    drag = e is not None
    cq = e.coefficient if drag else 0.0
    e = fx.get('cogging')
    cog = e is not None
    ca, cw, cph = (e.amplitude, 2.0 * math.pi / e.pitch, e.phase) if cog else (0.0, 0.0, 0.0)
    e = fx.get('time_varying_load')
    load = e is not None
    la, lw, lph = (e.amplitude, 2.0 * math.pi / e.period, e.phase) if load else (0.0, 0.0, 0.0)
    e = fx.get('sensor_delay')
    d_i, d_x = (float(e.current), float(e.position)) if e is not None else (0.0, 0.0)
    if d_i < 0 or d_x < 0:
        raise ValueError('sensor delays are >= 0 samples')
    fractional = d_i != int(d_i) or d_x != int(d_x)   # read between samples: keep each interval's derivatives
    d_i, d_x = (d_i, d_x) if fractional else (int(d_i), int(d_x))
    e = fx.get('sensor_filter')
    tau_i = 1.0 / (2.0 * math.pi * e.current_cutoff) if e is not None and e.current_cutoff > 0 else 0.0
    tau_x = 1.0 / (2.0 * math.pi * e.position_cutoff) if e is not None and e.position_cutoff > 0 else 0.0
    e = fx.get('current_sensor_offset')
    i_offset = e.offset if e is not None else 0.0
    tanh, sin = math.tanh, math.sin

    def f(i, x, v, temp, z, t, u):
        """d/dt of (I, x, v, T, z) under the held command u."""
        km = km0
        if kmvar:
            d = x - kc
            km = km0 * (1.0 + ka * d + kb * d * d)
        r = r0 * (1.0 + alpha * temp) if drift else r0
        ua = u - vd * tanh(i * inv_iband) - v0 if drive else u
        reluctance = 0.0
        if pind:   # psi = L(x) I: the back-EMF gains I L'(x) v, the force I^2 L'(x) / 2
            lx = l0 * math.exp(ga * (x - gc))
            ua -= i * ga * lx * v
            reluctance = 0.5 * i * i * ga * lx
            di = (ua - r * i - km * v) / lx
        elif lsat:
            q = i * inv_isat
            di = (ua - r * i - km * v) * inv_l0 * (1.0 + q * q)
        else:
            di = (ua - r * i - km * v) * inv_l0
        force = km * fs * tanh(i * inv_fs) if fsat else km * i
        force += reluctance - b * v - fl
        dz = 0.0
        if fric:
            stiffness = (fc + excess * math.exp(-(v * inv_vs) ** 2)) / delta if stribeck else fc_delta
            if -delta < z < delta or z * v < 0.0:
                dz = v
                force -= stiffness * z + sigma1 * v
            else:
                force -= stiffness * z
        if smooth:
            force -= sf_force * tanh(v * sf_inv_speed)
        if spring:
            force -= k_lin * x - x_lin
        if drag:
            force -= cq * v * abs(v)
        if cog:
            force -= ca * sin(cw * (x - cph))
        if load:
            force -= la * sin(lw * t + lph)
        dtemp = (r * i * i - temp * inv_rth) * inv_cth if drift else 0.0
        return di, v, force * inv_m, dtemp, dz

    noise = (current_noise * rng.standard_normal(n)).tolist()
    kick = (dither * rng.standard_normal(n)).tolist()
    voltage, current, position, resistance = (np.empty(n) for _ in range(4))
    true_i, true_x = [0.0] * n, [0.0] * n
    # per interval [t_k, t_k+1] (fractional delays): dI/dt at both ends under u_k, v at both ends
    rate_i0, rate_i1, speed0, speed1 = ([0.0] * n for _ in range(4))
    i = x = v = temp = z = 0.0
    y_i = y_x = 0.0   # the sensor filters' outputs
    h = ts / substeps
    half = 0.5 * h
    sixth = h / 6.0
    integral = previous = 0.0
    for k in range(n):
        t = k * ts
        true_i[k], true_x[k] = (y_i if tau_i else i), (y_x if tau_x else x)
        resistance[k] = r0 * (1.0 + alpha * temp)
        if fractional:
            late_i = _hermite(true_i, rate_i0, rate_i1, k - d_i, ts)
            late_x = _hermite(true_x, speed0, speed1, k - d_x, ts)
        else:
            late_i = true_i[k - d_i] if k >= d_i else 0.0
            late_x = true_x[k - d_x] if k >= d_x else 0.0
        sensed_i = late_i + i_offset + noise[k]
        sensed_x = resolution * math.floor(late_x / resolution + 0.5)
        current[k], position[k] = sensed_i, sensed_x
        error = (stroke if t % period < 0.5 * period else 0.0) - sensed_x
        speed = (sensed_x - previous) / ts if k else 0.0
        previous = sensed_x
        u = KP * error + KI * (integral + error * ts) - KD * speed + kick[k]
        if -SUPPLY < u < SUPPLY or u * error < 0.0:   # integrate unless it winds further into the limit
            integral += error * ts
        u = min(max(u, -SUPPLY), SUPPLY)
        voltage[k] = u
        for s in range(substeps):
            ts0 = t + s * h
            a1, b1, c1, d1, e1 = f(i, x, v, temp, z, ts0, u)
            if fractional and s == 0:
                rate_i0[k], speed0[k] = a1, b1
            i_start, x_start = i, x
            a2, b2, c2, d2, e2 = f(i + half * a1, x + half * b1, v + half * c1, temp + half * d1,
                                   z + half * e1, ts0 + half, u)
            a3, b3, c3, d3, e3 = f(i + half * a2, x + half * b2, v + half * c2, temp + half * d2,
                                   z + half * e2, ts0 + half, u)
            a4, b4, c4, d4, e4 = f(i + h * a3, x + h * b3, v + h * c3, temp + h * d3, z + h * e3, ts0 + h, u)
            i += sixth * (a1 + 2.0 * (a2 + a3) + a4)
            x += sixth * (b1 + 2.0 * (b2 + b3) + b4)
            v += sixth * (c1 + 2.0 * (c2 + c3) + c4)
            temp += sixth * (d1 + 2.0 * (d2 + d3) + d4)
            if fric:
                z += sixth * (e1 + 2.0 * (e2 + e3) + e4)
                z = min(max(z, -delta), delta)
            if tau_i:
                y_i = _first_order(y_i, i_start, i, h, tau_i)
            if tau_x:
                y_x = _first_order(y_x, x_start, x, h, tau_x)
        if fractional:
            rate_i1[k], speed1[k] = f(i, x, v, temp, z, t + ts, u)[:2]
            if tau_i or tau_x:
                raise ValueError('a fractional sensor_delay together with sensor_filter is not modelled')
        if not (abs(i) < 1e3 and abs(x) < 1.0):
            raise RuntimeError(f'the loop went unstable at t = {t:.4f} s (I = {i:.3g} A, x = {x:.3g} m)')
    return voltage, current, position, resistance


def _first_order(y, start, end, h, tau):
    """y after h of tau dy/dt = w - y, w going linearly from `start` to `end` (exact)."""
    slope = (end - start) / h
    return end - tau * slope + (y - start + tau * slope) * math.exp(-h / tau)


def _hermite(values, rate0, rate1, position, ts):
    """The signal at fractional sample `position` (0 before the start): cubic Hermite on the interval
    [floor, floor + 1] from the values at its ends and the derivatives there (per second)."""
    if position <= 0.0:
        return values[0] if position == 0.0 else 0.0
    j = int(math.floor(position))
    f = position - j
    if f == 0.0:
        return values[j]
    y0, y1, m0, m1 = values[j], values[j + 1], rate0[j] * ts, rate1[j] * ts
    f2, f3 = f * f, f * f * f
    return (2 * f3 - 3 * f2 + 1) * y0 + (f3 - 2 * f2 + f) * m0 + (-2 * f3 + 3 * f2) * y1 + (f3 - f2) * m1


def record(duration=3.0, params=None, effects=(), seed=0, current_noise=5e-3, resolution=1e-6, delays=None, *,
           stroke=2.5e-3, period=0.04, dither=0.5, substeps=SUBSTEPS, sample_period=SAMPLE_PERIOD):
    """A closed-loop record of the actuator with `effects` hidden in it.

    Parameters
    ----------
    duration : float
        Length in s (at 10 kHz: 3 s is 30000 samples).
    params : dict, optional
        Nominal parameters {resistance, inductance, emf_constant, mass, damping, load_force} in SI; missing
        ones from NOMINAL. random_parameters() draws a set.
    effects : iterable or dict
        Effect instances (CoulombFriction(force=1.0), ...), names ('cogging': its defaults),
        (name, {parameter: value}) pairs, or a {name: {parameter: value}} dict; any combination, each
        effect at most once.
    seed : int
        Seeds the current noise and the voltage dither (one numpy Generator): same seed, same record.
    current_noise : float
        Standard deviation of the current sensor's Gaussian noise (A).
    resolution : float
        Position quantisation step (m).
    delays : dict, optional
        Shorthand for a SensorDelay: {'current': d_I, 'position': d_x} in samples.
    stroke, period, dither
        The square-wave reference 0 / stroke (m) with `period` (s), the dither's standard deviation (V).
    substeps : int
        RK4 steps per sample.

    Returns
    -------
    (Recording, dict)
        The Recording has signals voltage (commanded, V), current (sensed, A) and position (sensed, m) at
        `sample_period`, a source that names no effect, and metadata {'true_<name>': repr(value)} of the
        nominal parameters only. The truth dict holds the nominal parameters, 'effects': {name: {its
        parameters}}, 'in_library' / 'not_in_library': the names of the hidden effects by kind, and
        'resistance_final' (the true R at the last sample; differs from R0 with resistance_drift).
    """
    p = dict(NOMINAL)
    p.update(params or {})
    unknown = set(p) - set(NOMINAL)
    if unknown:
        raise ValueError(f'unknown parameters {sorted(unknown)}; known: {", ".join(NOMINAL)}')
    p = {k: float(v) for k, v in p.items()}
    fx = _as_effects(effects, delays)
    rng = np.random.default_rng(seed)
    n = int(round(duration / sample_period))
    voltage, current, position, resistance = _simulate(p, fx, n, sample_period, int(substeps), stroke, period,
                                                       dither, current_noise, resolution, rng)
    recording = Recording(sample_period, {'voltage': voltage, 'current': current, 'position': position},
                          source='independent closed-loop simulation',
                          metadata={f'true_{k}': repr(v) for k, v in p.items()})
    truth = dict(p)
    truth['effects'] = {name: e.parameters() for name, e in fx.items()}
    truth['in_library'] = [name for name, e in fx.items() if e.in_library]
    truth['not_in_library'] = [name for name, e in fx.items() if not e.in_library]
    truth['resistance_final'] = float(resistance[-1])
    return recording, truth


def _summary(duration=1.0):
    """Per effect: how far it moves the record from the effect-free one (same seed), and the time taken."""
    t0 = time.perf_counter()
    base, _ = record(duration)
    current = base.signals['current']
    print(f'no effect: {time.perf_counter() - t0:.2f} s for {duration:g} s; peak |I| {np.max(np.abs(current)):.2f} A, '
          f'rms I {np.sqrt(np.mean(current ** 2)):.2f} A')
    for name in EFFECTS:
        t0 = time.perf_counter()
        rec, truth = record(duration, effects=[name])
        took = time.perf_counter() - t0
        di = np.sqrt(np.mean((rec.signals['current'] - base.signals['current']) ** 2))
        dx = np.sqrt(np.mean((rec.signals['position'] - base.signals['position']) ** 2))
        du = np.sqrt(np.mean((rec.signals['voltage'] - base.signals['voltage']) ** 2))
        print(f'{name:26s} {took:5.2f} s  rms change: current {di * 1e3:7.1f} mA  position {dx * 1e6:6.1f} um'
              f'  voltage {du:5.2f} V  R_final {truth["resistance_final"]:.3f}')


if __name__ == '__main__':
    _summary(float(sys.argv[1]) if len(sys.argv) > 1 else 1.0)
