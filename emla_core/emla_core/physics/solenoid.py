"""The solenoid (reluctance actuator) family: its parameters, its magnetic circuit and its compiled plant step
(docs/physics.md §9).

The coil's flux linkage is psi(x, I) = L(x) I with a leakage path in parallel with an air-gap path whose
reluctance grows with the gap g0 - x (x > 0 closes the gap):

    L(x)  = L0 + a / (g0 - x),          L'(x) = a / (g0 - x)^2
    l     = d psi/dI = L(x)             (incremental inductance)
    e     = d psi/dx = I L'(x)          (back-EMF coefficient)
    F     = d W'/dx  = I^2 L'(x) / 2    (co-energy force, always towards +x: it closes the gap)
    load  = F0 + k x                    (return spring with preload F0, pushing the armature open)

Iron saturation (`saturation_coefficient` c > 0): the iron in series with the circuit takes a magnetomotive force
that grows faster than the flux, the first odd term of its curve, so the current is I = psi / L(x) + c psi^3.
With M = psi / L(x) (the current the circuit alone would take), the energy W = psi^2 / (2 L(x)) + c psi^4 / 4
gives F = -dW/dx at constant psi = M^2 L'(x) / 2, and l = 1 / (1 / L(x) + 3 c psi^2), e = M L'(x) l / L(x);
psi from I by Newton's method (`flux`).

Eddy currents (`eddy_conductance` G > 0): the iron's eddy currents as a conductance across the magnetic circuit,
a branch in parallel with it taking G dpsi/dt, so the coil's current is I = M_c + G dpsi/dt with M_c = psi / L(x)
+ c psi^3 - I_r the circuit's own (the flux lags the current; the force is still M^2 L'(x) / 2). From
dpsi/dt = u - R I: dpsi/dt = (u - R M_c) / (1 + R G), and the plant integrates M_c with the coil's equation at
u / (1 + R G) and R / (1 + R G); the current it gives is I = (M_c + G u) / (1 + R G), which jumps with the voltage
(sampled just before the voltage steps: with the voltage of the interval that ends there).

Residual magnetism (`remanence_current` I_r > 0): the iron's remanent magnetisation as an equivalent current in the
circuit, I = psi / L(x) + c psi^3 - I_r, so at I = 0 the circuit keeps psi = L(x) I_r and its force (a valve that
sticks after release). The energy gains -I_r psi, which does not depend on x: F = M^2 L'(x) / 2, l and e as above;
psi from I + I_r.

These are handed to equations.coil_rates, the suite's one right-hand side. The armature moves between end stops
x_min and x_max; a stop is inelastic: the armature that reaches it stays there, at rest, while the net force
presses it on, and leaves when that force turns.
"""
from __future__ import annotations

import dataclasses
import math
import numbers

import numba
import numpy as np

from .equations import coil_rates

# The identified parameters of the family, in the order used by its identification and reports.
SOLENOID_PARAMETER_NAMES = ('resistance', 'leakage_inductance', 'gap_coefficient', 'gap', 'mass', 'damping',
                            'spring_stiffness', 'spring_preload')
SOLENOID_UNITS = {'resistance': 'ohm', 'leakage_inductance': 'H', 'gap_coefficient': 'H m', 'gap': 'm',
                  'mass': 'kg', 'damping': 'N s/m', 'spring_stiffness': 'N/m',
                  'spring_preload': 'N (opens the gap, opposes +x)', 'stroke_min': 'm', 'stroke_max': 'm',
                  'supply_voltage': 'V'}

# The solenoid's effects as the discrepancy names them and a model file lists them: {effect: ({its parameter, as
# identified: the SolenoidParameters field}, the settings it carries, fields too)}.
SOLENOID_EFFECTS = {'friction': ({'coulomb_force': 'friction_force'}, ('friction_speed',)),
                    'iron_saturation': ({'saturation_coefficient': 'saturation_coefficient'}, ()),
                    'residual_magnetism': ({'remanence_current': 'remanence_current'}, ()),
                    'eddy_currents': ({'eddy_conductance': 'eddy_conductance'}, ())}


@dataclasses.dataclass(frozen=True)
class SolenoidParameters:
    """A solenoid's physical parameters, SI units.

    Parameters
    ----------
    resistance : float
        Coil resistance R (ohm), > 0.
    leakage_inductance : float
        L0 (H), the leakage path's inductance, >= 0.
    gap_coefficient : float
        a (H m), the air-gap path's inductance times its length: a / (g0 - x) is its inductance, > 0.
    gap : float
        g0 (m), the air gap at x = 0, > 0 and above `stroke_max` (the gap never closes fully).
    mass : float
        Moving mass m (kg), > 0.
    damping : float
        Viscous damping B (N s/m), >= 0.
    spring_stiffness : float
        Return spring stiffness k (N/m), >= 0.
    spring_preload : float
        F0 (N): the spring's force at x = 0, pushing the armature open (towards -x) when positive.
    stroke_min, stroke_max : float
        The end stops x_min < x_max (m).
    supply_voltage : float
        The driver's limit U (V), > 0: the voltage is clipped to +-U.
    friction_force : float
        A friction Fc (N, >= 0) of the armature; 0: none.
    friction_speed : float
        v_s (m/s, >= 0) of that friction: Fc tanh(v / v_s), smooth through v = 0; 0: the dry Fc sign(v), sticking
        below breakaway (equations.friction_force).
    saturation_coefficient : float
        c (A / Wb^3, >= 0) of the iron's saturation: I = psi / L(x) + c psi^3; 0: none.
    remanence_current : float
        I_r (A, >= 0), the iron's residual magnetism as an equivalent current: I = psi / L(x) + c psi^3 - I_r; 0: none.
    eddy_conductance : float
        G (S = 1/ohm, >= 0) of the iron's eddy currents: I = psi / L(x) + c psi^3 - I_r + G dpsi/dt; 0: none.

    Examples
    --------
    >>> p = SolenoidParameters()
    >>> round(p.inductance(0.0) * 1e3, 3), round(p.coil_force(0.0, 2.0), 3)   # mH, N
    (6.333, 1.778)
    """

    resistance: float = 6.0
    leakage_inductance: float = 5e-3
    gap_coefficient: float = 2e-6
    gap: float = 1.5e-3
    mass: float = 0.02
    damping: float = 3.0
    spring_stiffness: float = 3000.0
    spring_preload: float = 0.5
    stroke_min: float = 0.0
    stroke_max: float = 1.2e-3
    supply_voltage: float = 24.0
    friction_force: float = 0.0
    friction_speed: float = 0.0
    saturation_coefficient: float = 0.0
    remanence_current: float = 0.0
    eddy_conductance: float = 0.0

    def __post_init__(self):
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
                raise ValueError(f'SolenoidParameters.{field.name} must be a finite number, got {value!r}')
            object.__setattr__(self, field.name, float(value))
        for name in ('resistance', 'gap_coefficient', 'gap', 'mass', 'supply_voltage'):
            if getattr(self, name) <= 0.0:
                raise ValueError(f'SolenoidParameters.{name} must be positive, got {getattr(self, name)!r}')
        for name in ('leakage_inductance', 'damping', 'spring_stiffness', 'friction_force', 'friction_speed',
                     'saturation_coefficient', 'remanence_current', 'eddy_conductance'):
            if getattr(self, name) < 0.0:
                raise ValueError(f'SolenoidParameters.{name} must be >= 0, got {getattr(self, name)!r}')
        if not self.stroke_min < self.stroke_max < self.gap:
            raise ValueError(f'SolenoidParameters needs stroke_min < stroke_max < gap, got {self.stroke_min!r}, '
                             f'{self.stroke_max!r}, {self.gap!r}')

    def identified(self) -> dict[str, float]:
        """The parameters the identification estimates, {name: value} in SOLENOID_PARAMETER_NAMES order."""
        return {name: getattr(self, name) for name in SOLENOID_PARAMETER_NAMES}

    def replace(self, **values: float) -> SolenoidParameters:
        """A copy with some fields set to new values."""
        return dataclasses.replace(self, **values)

    def inductance(self, position):
        """L(x) = L0 + a / (g0 - x) (H): the flux linkage per ampere and the incremental inductance."""
        return inductance(position, self.leakage_inductance, self.gap_coefficient, self.gap)

    def inductance_slope(self, position):
        """L'(x) = a / (g0 - x)^2 (H/m)."""
        return inductance_slope(position, self.gap_coefficient, self.gap)

    def flux_linkage(self, position, current):
        """psi (V s = Wb): L(x) (I + I_r), or with saturation the root of psi / L(x) + c psi^3 = I + I_r."""
        return _flux(np.asarray(current, dtype=float) + self.remanence_current, self.inductance(position),
                     self.saturation_coefficient)

    def magnetizing_current(self, position, current):
        """M = psi / L(x) (A): the current itself without saturation and remanence."""
        return self.flux_linkage(position, current) / self.inductance(position)

    def emf_coefficient(self, position, current):
        """d psi/dx = M L'(x) l / L(x) (V s/m; I L'(x) without saturation): the back-EMF is this times the
        velocity."""
        inductance_x, psi = self.inductance(position), self.flux_linkage(position, current)
        incremental = 1.0 / (1.0 / inductance_x + 3.0 * self.saturation_coefficient * psi * psi)
        return psi / inductance_x * self.inductance_slope(position) * incremental / inductance_x

    def coil_force(self, position, current):
        """The co-energy force M^2 L'(x) / 2 (N, towards +x)."""
        magnetizing = self.magnetizing_current(position, current)
        return 0.5 * magnetizing * magnetizing * self.inductance_slope(position)

    def load(self, position):
        """The spring's force F0 + k x (N, opposing +x)."""
        return self.spring_preload + self.spring_stiffness * position

    def kernel_vector(self) -> np.ndarray:
        """The compiled plant's parameter vector (KERNEL_SLOTS order)."""
        return np.array([getattr(self, name) for name in KERNEL_SLOTS])


KERNEL_SLOTS = ('resistance', 'leakage_inductance', 'gap_coefficient', 'gap', 'mass', 'damping', 'spring_stiffness',
                'spring_preload', 'stroke_min', 'stroke_max', 'friction_force', 'friction_speed',
                'saturation_coefficient', 'remanence_current', 'eddy_conductance')
_R, _L0, _A, _G0, _M, _B, _K, _F0, _XMIN, _XMAX, _FC, _VS, _C, _IR, _GE = range(len(KERNEL_SLOTS))
NEWTON_STEPS = 8   # of `flux`: from psi = L I, each at least doubles the correct digits once near the root


@numba.njit(cache=True)
def flux(current, inductance, saturation):
    """psi with psi / L + c psi^3 = I (V s), by Newton's method from L I (for c > 0 the function is increasing and
    convex on the side of the start, so the steps close in from there without overshooting)."""
    psi = inductance * current
    if saturation > 0.0:
        for _ in range(NEWTON_STEPS):
            residual = psi / inductance + saturation * psi ** 3 - current
            psi -= residual / (1.0 / inductance + 3.0 * saturation * psi ** 2)
    return psi


_flux = numba.vectorize(['float64(float64, float64, float64)'], cache=True)(flux.py_func)


@numba.njit(cache=True)
def coil_terms(i, x, p):
    """(l, e, F) of the coil at current i and position x, parameters p (KERNEL_SLOTS): its incremental inductance,
    back-EMF coefficient and co-energy force, with the iron's saturation."""
    inductance_x = inductance(x, p[_L0], p[_A], p[_G0])
    slope = inductance_slope(x, p[_A], p[_G0])
    psi = flux(i + p[_IR], inductance_x, p[_C])
    magnetizing = psi / inductance_x
    incremental = 1.0 / (1.0 / inductance_x + 3.0 * p[_C] * psi * psi)
    return incremental, magnetizing * slope * incremental / inductance_x, 0.5 * magnetizing * magnetizing * slope


@numba.njit(cache=True)
def inductance(x, leakage, coefficient, gap):
    """L(x) = L0 + a / (g0 - x) (H)."""
    return leakage + coefficient / (gap - x)


@numba.njit(cache=True)
def inductance_slope(x, coefficient, gap):
    """L'(x) = a / (g0 - x)^2 (H/m)."""
    return coefficient / ((gap - x) * (gap - x))


@numba.njit(cache=True)
def _rates(i, x, v, u, p, h):
    """(dM_c/dt, dx/dt, dv/dt) at the circuit's current M_c = i (the coil's current without eddy currents): the
    coil's l, e, F and the spring's load through coil_rates, the voltage and R over 1 + R G; at an end stop at rest
    the armature stays while the net force presses it on."""
    load, dry = p[_F0] + p[_K] * x, p[_FC]
    if p[_VS] > 0.0:   # the smooth friction: a load like the spring's, nothing to stick
        load, dry = load + p[_FC] * np.tanh(v / p[_VS]), 0.0
    incremental, emf, force = coil_terms(i, x, p)
    scale = 1.0 / (1.0 + p[_R] * p[_GE])   # the share of u - R M_c that drives the flux past the eddy branch
    di, dv = coil_rates(i, v, u * scale, p[_R] * scale, incremental, emf, force, p[_M], p[_B], load, dry, h)
    if v == 0.0 and ((x >= p[_XMAX] and dv > 0.0) or (x <= p[_XMIN] and dv < 0.0)):
        return di, 0.0, 0.0
    return di, v, dv


@numba.njit(cache=True)
def armature_step(x, v, i0, i1, dt, steps, p):
    """(x, v, J, stop) after dt of the armature's mechanics alone, the coil's current going linearly from i0 to
    i1 (A), in `steps` RK4 steps of _rates' acceleration (the friction and the stops' hold included); J the 2x2
    d(x, v)/d(x0, v0), by central differences of the whole step. An armature that reaches a stop or rests on one
    ends there at rest, J zero, `stop` 0 (x_min) or 1 (x_max); -1 in flight."""
    x1, v1, stop = _flight(x, v, i0, i1, dt, steps, p)
    jacobian = np.zeros((2, 2))
    if stop < 0:
        for column in range(2):
            dx, dv = (1e-9 * (p[_XMAX] - p[_XMIN]), 0.0) if column == 0 else (0.0, 1e-6)
            up = _flight(x + dx, v + dv, i0, i1, dt, steps, p)
            down = _flight(x - dx, v - dv, i0, i1, dt, steps, p)
            span = 2.0 * (dx + dv)
            if up[2] >= 0:     # a perturbed run that lands: the difference on the side still in flight
                up, span = (x1, v1, stop), dx + dv
            elif down[2] >= 0:
                down, span = (x1, v1, stop), dx + dv
            if up[2] < 0 and down[2] < 0:
                jacobian[0, column], jacobian[1, column] = (up[0] - down[0]) / span, (up[1] - down[1]) / span
    return x1, v1, jacobian, stop


@numba.njit(cache=True)
def _flight(x, v, i0, i1, dt, steps, p):
    """(x, v, stop) of armature_step, without the Jacobian: RK4 on (x, v), a stop reached or held ending it."""
    h = dt / steps
    for k in range(steps):
        slope = (i1 - i0) / steps
        i_start, i_middle, i_end = i0 + slope * k, i0 + slope * (k + 0.5), i0 + slope * (k + 1.0)
        a0 = _rates(i_start, x, v, 0.0, p, h)[2]
        a1 = _rates(i_middle, x + 0.5 * h * v, v + 0.5 * h * a0, 0.0, p, h)[2]
        a2 = _rates(i_middle, x + 0.5 * h * (v + 0.5 * h * a0), v + 0.5 * h * a1, 0.0, p, h)[2]
        a3 = _rates(i_end, x + h * (v + 0.5 * h * a1), v + h * a2, 0.0, p, h)[2]
        x += h * (v + h / 6.0 * (a0 + a1 + a2))
        v += h / 6.0 * (a0 + 2.0 * (a1 + a2) + a3)
        if x <= p[_XMIN] or x >= p[_XMAX]:
            return min(max(x, p[_XMIN]), p[_XMAX]), 0.0, 0 if x <= p[_XMIN] else 1
    return x, v, -1


@numba.njit(cache=True)
def _rk4(i, x, v, u, p, h):
    """One classical RK4 step of h."""
    a0, a1, a2 = _rates(i, x, v, u, p, h)
    b0, b1, b2 = _rates(i + 0.5 * h * a0, x + 0.5 * h * a1, v + 0.5 * h * a2, u, p, h)
    c0, c1, c2 = _rates(i + 0.5 * h * b0, x + 0.5 * h * b1, v + 0.5 * h * b2, u, p, h)
    d0, d1, d2 = _rates(i + h * c0, x + h * c1, v + h * c2, u, p, h)
    return (i + h / 6.0 * (a0 + 2.0 * (b0 + c0) + d0), x + h / 6.0 * (a1 + 2.0 * (b1 + c1) + d1),
            v + h / 6.0 * (a2 + 2.0 * (b2 + c2) + d2))


@numba.njit(cache=True)
def solenoid_step(i, x, v, u, p, h):
    """(M_c, x, v) after one sub-step of h at voltage u, parameters p (KERNEL_SLOTS), M_c the circuit's current (I
    without eddy currents), with the inelastic stops: a step that crosses a stop is split where it reaches it (the
    crossing found linearly within the step), the armature put on the stop at rest, and the rest of the step taken
    from there."""
    i1, x1, v1 = _rk4(i, x, v, u, p, h)
    stop = p[_XMAX] if x1 > p[_XMAX] else p[_XMIN] if x1 < p[_XMIN] else x1
    if stop == x1:
        return i1, x1, v1
    # (an armature that starts beyond the stop and does not move is put on it at once)
    fraction = min(max((stop - x) / (x1 - x), 0.0), 1.0) if x1 != x else 0.0
    i1 = _rk4(i, x, v, u, p, fraction * h)[0]
    if fraction < 1.0:
        i1, x1, v1 = _rk4(i1, stop, 0.0, u, p, (1.0 - fraction) * h)
    else:
        x1, v1 = stop, 0.0
    return i1, min(max(x1, p[_XMIN]), p[_XMAX]), v1 if p[_XMIN] < x1 < p[_XMAX] else 0.0


@numba.njit(cache=True)
def solenoid_sequence(state, voltages, dt, substeps, p):
    """Rows (I, x, v, coil force, M_c) at the end of each ZOH interval of `dt` from state (M_c, x, v): `substeps`
    classical RK4 steps per interval with the inelastic stops (`solenoid_step`); I the coil's current there, with
    the interval's voltage (`coil_current`), M_c the circuit's (I without eddy currents)."""
    out = np.empty((voltages.size, 5))
    i, x, v = state[0], state[1], state[2]
    h = dt / substeps
    for k in range(voltages.size):
        for _ in range(substeps):
            i, x, v = solenoid_step(i, x, v, voltages[k], p, h)
        out[k, 0], out[k, 1], out[k, 2] = coil_current(i, voltages[k], p[_R], p[_GE]), x, v
        out[k, 3], out[k, 4] = coil_terms(i, x, p)[2], i
    return out


@numba.njit(cache=True)
def coil_current(circuit, voltage, resistance, eddy_conductance):
    """The coil's current I = (M_c + G u) / (1 + R G) (A) at the circuit's current M_c and the voltage held: M_c
    itself without eddy currents."""
    return (circuit + eddy_conductance * voltage) / (1.0 + resistance * eddy_conductance)


@numba.njit(cache=True)
def circuit_current(current, voltage, resistance, eddy_conductance):
    """The circuit's current M_c = I (1 + R G) - G u (A) of the coil's current I and the voltage held: coil_current
    inverted."""
    return current * (1.0 + resistance * eddy_conductance) - eddy_conductance * voltage
