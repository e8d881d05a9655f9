"""The actuator plant: coil current I, position x, velocity v and coil temperature T, advanced over
zero-order-hold (ZOH) voltage intervals.

The voltage is clipped to +-supply_voltage (the driver saturates) before it is applied; NaN is refused.
Without effects the model is linear and every interval uses its exact ZOH discretisation
    z(k+1) = Phi z(k) + Gamma_u u(k) + Gamma_F Fl,   z = (I, x, v),
from the matrix exponential of the augmented system (cached per parameters and dt); T stays at ambient.
With effects the plant takes classical RK4 sub-steps of at most MAX_SUBSTEP, compiled with numba for the
built-in effects (effects.integrate_interval), through the effect hooks in Python for other effects.
Parameter changes take effect at their exact time, inside an interval if need be.

A dry friction sticks rigidly (equations.friction_force), unless its effect has a pre-sliding band
(`presliding_displacement` delta > 0: the coulomb_friction of a model whose contact is elastic, as the discrepancy
workflow's candidate has it). Its stuck contact is then the elasto-plastic one of that candidate, on the true
position: z = x - y, y the play operator of width delta on x (the contact's anchor, a state of the plant), the
friction Fc z / delta + sigma1 dz/dt (sigma1 its `presliding_damping`; dz/dt = v within the band, 0 while it
slides). The anchor moves after each RK4 sub-step; within one, the force is that of the anchor it started from.
"""
from __future__ import annotations

import collections
import functools
import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np
from scipy.linalg import expm

from emla_core.parameters import TABLE1, ActuatorParameters
from emla_core.physics import AMBIENT_TEMPERATURE, Effect, make_effect
from emla_core.physics.kernel import (
    SLOTS,
    _derivatives,
    _emf,
    coil_state,
    hook_rates,
    integrate_interval,
    integrate_sequence,
    kernel_vector,
)

if TYPE_CHECKING:
    from emla_sim.effects import ParameterChange

# RK4 sub-step bound: 10 sub-steps per 0.1 ms sample keep the integration error many orders of magnitude
# below the sensor noise (5 mA, 1 um) and resolve the electrical time constant L/R = 0.4 ms.
MAX_SUBSTEP = 1e-5
_TIME_TOL = 1e-9  # s; a parameter change this close to an interval's end happens at that end
_COLUMNS = ('current', 'position', 'velocity', 'temperature', 'force')
_LOAD, _FRICTION = SLOTS.index('load_force'), SLOTS.index('coulomb_force')   # kernel slots the contact takes over


@functools.lru_cache(maxsize=64)
def zoh_matrices(resistance, inductance, emf_constant, mass, damping, dt):
    """Exact ZOH discretisation of z = (I, x, v) with inputs (u, Fl): (Phi 3x3, Gamma 3x2), read-only."""
    a = np.zeros((5, 5))  # augmented [[A, B_in], [0, 0]]; x enters neither dI/dt nor dv/dt
    a[0, 0], a[0, 2], a[0, 3] = -resistance / inductance, -emf_constant / inductance, 1.0 / inductance
    a[1, 2] = 1.0
    a[2, 0], a[2, 2], a[2, 4] = emf_constant / mass, -damping / mass, -1.0 / mass
    e = expm(a * dt)
    phi, gamma = e[:3, :3].copy(), e[:3, 3:].copy()
    phi.flags.writeable = gamma.flags.writeable = False
    return phi, gamma


@numba.njit(cache=True)
def _zoh_sequence(phi, gamma_u, offset, state, voltages):
    """Rows (I, x, v) at the end of each interval of the exact discretisation."""
    out = np.empty((voltages.size, 3))
    i, x, v = state[0], state[1], state[2]
    for k in range(voltages.size):
        u = voltages[k]
        i, x, v = (phi[0, 0] * i + phi[0, 1] * x + phi[0, 2] * v + gamma_u[0] * u + offset[0],
                   phi[1, 0] * i + phi[1, 1] * x + phi[1, 2] * v + gamma_u[1] * u + offset[1],
                   phi[2, 0] * i + phi[2, 1] * x + phi[2, 2] * v + gamma_u[2] * u + offset[2])
        out[k, 0], out[k, 1], out[k, 2] = i, x, v
    return out


class Plant:
    """The actuator, from rest (or `initial_state` = (I, x, v[, T])) at time 0.

    effects: Effect instances or registered effect names; changes: ParameterChange instances.
    substeps: RK4 sub-steps per interval when effects are present (default: ceil(dt / MAX_SUBSTEP)).
    Coil temperature T is in deg C; it starts at the thermal effect's ambient (else AMBIENT_TEMPERATURE).
    """

    def __init__(self, params: ActuatorParameters = TABLE1, effects: Iterable[Effect | str] = (),
                 changes: Iterable[ParameterChange] = (), *, initial_state: Sequence[float] | None = None,
                 substeps: int | None = None) -> None:
        self._effects = tuple(make_effect(e) if isinstance(e, str) else e for e in effects)
        for effect in self._effects:
            if not isinstance(effect, Effect):
                raise TypeError(f'effects must be Effect instances or effect names, got {effect!r}')
            if effect.simulation_refusal:
                raise ValueError(f'the plant does not simulate {effect.name}: {effect.simulation_refusal}')
        names = [effect.name for effect in self._effects]
        if len(set(names)) != len(names):
            raise ValueError(f'each effect may be given once, got {names}')
        if substeps is not None and not (isinstance(substeps, int) and substeps >= 1):
            raise ValueError(f'substeps must be a positive integer or None, got {substeps!r}')
        self._substeps = substeps
        # the parameters after each change, worked out now so that an impossible change fails here
        self._schedule: collections.deque[tuple[float, ActuatorParameters]] = collections.deque()
        scheduled = params
        for change in sorted(changes, key=lambda c: c.time):
            scheduled = change.apply(scheduled)
            self._schedule.append((change.time, scheduled))
        ambient = next((e.ambient_temperature for e in self._effects if e.ambient_temperature is not None),
                       AMBIENT_TEMPERATURE)
        state = tuple(initial_state) if initial_state is not None else (0.0, 0.0, 0.0)
        if len(state) not in (3, 4):
            raise ValueError(f'initial_state is (current, position, velocity[, temperature]), got {state!r}')
        self._i, self._x, self._v, self._temp = (float(s) for s in state + (ambient,) * (4 - len(state)))
        self._time = 0.0
        # (Fc, delta, sigma1) of an elastic stuck contact, or None; its anchor y, relaxed at the start
        contact, self._contact = _elastic_contact(self._effects)
        self._anchor = self._x
        self._hooked = tuple(e for e in self._effects if e is not contact)   # its effect acts through it alone
        self._set_parameters(params)
        self._apply_due_changes()

    # ---- state ----
    time = property(lambda self: self._time, doc='Simulated time (s).')
    current = property(lambda self: self._i, doc='Coil current I (A).')
    position = property(lambda self: self._x, doc='Position x (m).')
    velocity = property(lambda self: self._v, doc='Velocity v (m/s).')
    temperature = property(lambda self: self._temp, doc='Coil temperature T (deg C).')
    effects = property(lambda self: self._effects, doc='The active effects.')

    @property
    def force(self) -> float:
        """Coil force d W'/dx (N): Km I for a moving coil, with the effects' terms."""
        return coil_state(self._params, self._effects, self._i, self._x)[2]

    @property
    def integration(self) -> str:
        """'exact' (linear ZOH), 'rk4' (compiled) or 'rk4-python' (through effect hooks)."""
        if not self._effects:
            return 'exact'
        return 'rk4' if self._kernel is not None else 'rk4-python'

    def true_parameters(self) -> ActuatorParameters:
        """The ActuatorParameters now: after the parameter changes so far, R at the coil temperature.

        State-dependent effects (L(I), Km(x), friction, spring) are functions, not parameters: their
        nominal L and Km are reported.
        """
        return self._params.scaled(resistance=math.prod(e.resistance_factor(self._temp) for e in self._effects))

    # ---- advancing ----
    def step(self, voltage: float, dt: float) -> tuple[float, float, float]:
        """Advance one ZOH interval of dt seconds at `voltage`; return (I, x, v) at its end."""
        supply = self._params.supply_voltage
        u = supply if voltage > supply else -supply if voltage < -supply else float(voltage)
        if u != u or not dt > 0.0:
            raise ValueError(f'step needs a voltage that is not NaN and dt > 0, got {voltage!r}, {dt!r}')
        t_end = self._time + dt
        if t_end + _TIME_TOL < self._next_change_time:
            self._integrate(u, dt)
            self._time = t_end
        else:
            self._step_through_changes(u, dt)
        return self._i, self._x, self._v

    def run(self, voltages: Sequence[float] | np.ndarray, dt: float, *, sampling: str = 'end') -> dict[str, np.ndarray]:
        """Apply a voltage sequence, one ZOH interval of dt per value.

        Returns a dict of arrays: time, voltage (as applied, clipped), current, position, velocity,
        temperature, force. sampling='end': state at the END of each interval (time = t0 + (k+1) dt);
        sampling='start': state at the START of each interval, aligned with the voltage applied over it
        (time = t0 + k dt; the recording convention). Either way the plant ends after the last interval.
        """
        if sampling not in ('end', 'start'):
            raise ValueError(f"sampling must be 'end' or 'start', got {sampling!r}")
        u = np.asarray(voltages, dtype=float)
        if u.ndim != 1 or np.isnan(u).any() or not dt > 0.0:
            raise ValueError('run needs a 1-D voltage sequence without NaN and dt > 0')
        supply = self._params.supply_voltage
        u = np.clip(u, -supply, supply)
        t0, first = self._time, self._row()
        rows = np.empty((u.size, len(_COLUMNS)))
        k = 0
        while k < u.size:
            n = self._intervals_before_change(dt, u.size - k)
            if n:
                rows[k:k + n] = self._run_block(u[k:k + n], dt)
                self._time += n * dt
                self._apply_due_changes()
            else:
                n = 1
                self._step_through_changes(u[k], dt)
                rows[k] = self._row()
            k += n
        if sampling == 'start':
            rows = np.vstack((first, rows[:-1]))[:u.size]
            times = t0 + dt * np.arange(u.size)
        else:
            times = t0 + dt * np.arange(1, u.size + 1)
        return dict(time=times, voltage=u, **{name: rows[:, c].copy() for c, name in enumerate(_COLUMNS)})

    def advance(self, voltage: float, dt: float, n: int) -> dict[str, np.ndarray]:
        """n intervals of dt at one voltage (a control period of n samples): run()'s dict, end sampling."""
        return self.run(np.full(int(n), float(voltage)), dt)

    # ---- internals ----
    def _set_parameters(self, params):
        self._params = params
        self._kernel = kernel_vector(params, self._effects) if self._effects else None
        self._linear_dt = None  # the linear coefficients below are for these parameters and this dt

    def _apply_due_changes(self):
        while self._schedule and self._schedule[0][0] <= self._time + _TIME_TOL:
            self._set_parameters(self._schedule.popleft()[1])
        self._next_change_time = self._schedule[0][0] if self._schedule else math.inf

    def _step_through_changes(self, u, dt):
        """step() for an interval with parameter changes inside or at its end."""
        t_end, remaining = self._time + dt, dt
        while self._next_change_time < t_end - _TIME_TOL:
            self._integrate(u, self._next_change_time - self._time)
            remaining = t_end - self._next_change_time
            self._time = self._next_change_time
            self._apply_due_changes()
        self._integrate(u, remaining)
        self._time = t_end
        self._apply_due_changes()

    def _intervals_before_change(self, dt, limit):
        """How many of the next intervals end before (or at) the next parameter change, at most limit."""
        if self._next_change_time == math.inf:
            return limit
        return min(limit, max(0, math.floor((self._next_change_time - self._time + _TIME_TOL) / dt)))

    def _substeps_for(self, dt):
        return self._substeps or max(1, math.ceil(dt / MAX_SUBSTEP - 1e-9))

    def _integrate(self, u, dt):
        """Advance the state by dt at voltage u with the current parameters (time is the caller's)."""
        if not self._effects:
            if dt != self._linear_dt:
                self._linear = self._linear_coefficients(dt)
                self._linear_dt = dt
            ii, iv, iu, i0, xi, xv, xu, x0, vi, vv, vu, v0 = self._linear
            i, v = self._i, self._v
            self._i = ii * i + iv * v + iu * u + i0
            self._x += xi * i + xv * v + xu * u + x0
            self._v = vi * i + vv * v + vu * u + v0
        elif self._contact is not None and self._kernel is not None:
            self._i, self._x, self._v, self._temp, self._anchor = _contact_interval(
                self._i, self._x, self._v, self._temp, self._anchor, u, dt, self._substeps_for(dt), self._kernel,
                self._contact)
        elif self._kernel is not None:
            self._i, self._x, self._v, self._temp = integrate_interval(
                self._i, self._x, self._v, self._temp, u, dt, self._substeps_for(dt), self._kernel)
        else:
            self._i, self._x, self._v, self._temp = self._integrate_hooks(u, dt)

    def _linear_coefficients(self, dt):
        """Rows of (Phi[:, I], Phi[:, v], Gamma_u, Gamma_F Fl) as Python floats (Phi[:, x] = e_x)."""
        p = self._params
        phi, gamma = zoh_matrices(p.resistance, p.inductance, p.emf_constant, p.mass, p.damping, dt)
        return tuple(float(c) for r in range(3)
                     for c in (phi[r, 0], phi[r, 2], gamma[r, 0], gamma[r, 1] * p.load_force))

    def _run_block(self, u, dt):
        """Rows (I, x, v, T, force) at the end of each interval, no parameter change inside."""
        p = self._params
        if not self._effects:
            phi, gamma = zoh_matrices(p.resistance, p.inductance, p.emf_constant, p.mass, p.damping, dt)
            zs = _zoh_sequence(phi, gamma[:, 0].copy(), gamma[:, 1] * p.load_force,
                               np.array([self._i, self._x, self._v]), u)
            rows = np.column_stack((zs, np.full(u.size, self._temp), p.emf_constant * zs[:, 0]))
        elif self._contact is not None and self._kernel is not None:
            rows = _contact_sequence(np.array([self._i, self._x, self._v, self._temp, self._anchor]), u, dt,
                                     self._substeps_for(dt), self._kernel, self._contact)
            self._anchor, rows = float(rows[-1, 5]), rows[:, :5]
        elif self._kernel is not None:
            rows = integrate_sequence(np.array([self._i, self._x, self._v, self._temp]), u, dt,
                                      self._substeps_for(dt), self._kernel)
        else:
            rows = np.empty((u.size, len(_COLUMNS)))
            for k, uk in enumerate(u):
                self._integrate(uk, dt)
                rows[k] = self._row()
        self._i, self._x, self._v, self._temp = (float(c) for c in rows[-1, :4])
        return rows

    def _row(self):
        return self._i, self._x, self._v, self._temp, self.force

    def _integrate_hooks(self, u, dt):
        """Classical RK4 through the effect hooks: same scheme as kernel.integrate_interval (and _contact_interval,
        the elastic contact's anchor moved after each sub-step)."""
        n = self._substeps_for(dt)
        h = dt / n
        y = np.array([self._i, self._x, self._v, self._temp])
        for _ in range(n):
            k1 = self._hook_rates(y, u, h)
            k2 = self._hook_rates(y + 0.5 * h * k1, u, h)
            k3 = self._hook_rates(y + 0.5 * h * k2, u, h)
            k4 = self._hook_rates(y + h * k3, u, h)
            y = y + h / 6.0 * (k1 + 2.0 * (k2 + k3) + k4)
            if self._contact is not None:
                band = self._contact[1]
                self._anchor = min(max(self._anchor, float(y[1]) - band), float(y[1]) + band)
        return tuple(float(c) for c in y)

    def _hook_rates(self, y, u, h):
        """kernel.hook_rates at the state y, with the elastic contact's force (if any) in the load."""
        if self._contact is None:
            return hook_rates(self._params, self._effects, y, u, h)
        contact = _contact_force(float(y[1]), float(y[2]), self._anchor, self._contact)
        return hook_rates(self._params.replace(load_force=self._params.load_force + contact), self._hooked, y, u, h)


def _elastic_contact(effects):
    """(the effect, its (Fc, delta, sigma1) as an array) of the friction among `effects` whose stuck contact is
    elastic (a pre-sliding band `presliding_displacement` delta > 0; an effect without one sticks rigidly), or
    (None, None)."""
    contacts = [(effect, np.array([effect.friction_level(), effect.presliding_displacement,
                                   getattr(effect, 'presliding_damping', 0.0)]))
                for effect in effects if getattr(effect, 'presliding_displacement', 0.0) > 0.0]
    if len(contacts) > 1:
        raise ValueError(f'the plant follows one elastic friction contact, not {len(contacts)}')
    return contacts[0] if contacts else (None, None)


@numba.njit(cache=True)
def _contact_force(x, v, anchor, contact):
    """The elastic contact's force on the moving part (N, opposing +x) at (x, v) and its anchor: Fc z / delta +
    sigma1 dz/dt, z = x - anchor held within the band; dz/dt = v within it or back into it, 0 while it slides."""
    coulomb, band, damping = contact[0], contact[1], contact[2]
    z = min(max(x - anchor, -band), band)
    if abs(z) >= band * (1.0 - 1e-9) and z * v > 0.0:   # sliding: the anchor follows the part
        return coulomb * z / band
    return coulomb * z / band + damping * v


@numba.njit(cache=True)
def _contact_interval(i, x, v, temp, anchor, u, dt, substeps, p, contact):
    """(I, x, v, T, anchor) after dt at constant voltage u: kernel.integrate_interval's RK4 sub-steps with the
    kernel's rigid friction off and the elastic contact's force in the load of every stage, its anchor moved after
    each sub-step (the play operator)."""
    h = dt / substeps
    q = p.copy()
    q[_FRICTION] = 0.0
    load, band = p[_LOAD], contact[1]
    for _ in range(substeps):
        q[_LOAD] = load + _contact_force(x, v, anchor, contact)
        a0, a1, a2, a3 = _derivatives(i, x, v, temp, u, q, h)
        x1, v1 = x + 0.5 * h * a1, v + 0.5 * h * a2
        q[_LOAD] = load + _contact_force(x1, v1, anchor, contact)
        b0, b1, b2, b3 = _derivatives(i + 0.5 * h * a0, x1, v1, temp + 0.5 * h * a3, u, q, h)
        x2, v2 = x + 0.5 * h * b1, v + 0.5 * h * b2
        q[_LOAD] = load + _contact_force(x2, v2, anchor, contact)
        c0, c1, c2, c3 = _derivatives(i + 0.5 * h * b0, x2, v2, temp + 0.5 * h * b3, u, q, h)
        x3, v3 = x + h * c1, v + h * c2
        q[_LOAD] = load + _contact_force(x3, v3, anchor, contact)
        d0, d1, d2, d3 = _derivatives(i + h * c0, x3, v3, temp + h * c3, u, q, h)
        i += h / 6.0 * (a0 + 2.0 * (b0 + c0) + d0)
        x += h / 6.0 * (a1 + 2.0 * (b1 + c1) + d1)
        v += h / 6.0 * (a2 + 2.0 * (b2 + c2) + d2)
        temp += h / 6.0 * (a3 + 2.0 * (b3 + c3) + d3)
        anchor = min(max(anchor, x - band), x + band)
    return i, x, v, temp, anchor


@numba.njit(cache=True)
def _contact_sequence(state, voltages, dt, substeps, p, contact):
    """Rows (I, x, v, T, coil force, anchor) at the end of each ZOH interval, from state (I, x, v, T, anchor)."""
    out = np.empty((voltages.size, 6))
    i, x, v, temp, anchor = state[0], state[1], state[2], state[3], state[4]
    for k in range(voltages.size):
        i, x, v, temp, anchor = _contact_interval(i, x, v, temp, anchor, voltages[k], dt, substeps, p, contact)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3], out[k, 5] = i, x, v, temp, anchor
        out[k, 4] = _emf(x, p) * i
    return out
