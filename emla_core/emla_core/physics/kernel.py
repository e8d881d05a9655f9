"""The plant's compiled right-hand side with the built-in effects that give `kernel_values` (numba), and the
same right-hand side through the effects' hooks for any other effect (docs/physics.md §2, §6).

Both evaluate, at the state (I, x, v, T), the resistance R(T), the incremental inductance l, the back-EMF
coefficient e and the coil force F of the flux linkage L I + Km x + the effects' psi_e(x, I), and hand them to
equations.coil_rates: the one right-hand side of the suite.
"""
import math

import numba
import numpy as np

from emla_core.parameters import PARAMETER_NAMES

from .effect import AMBIENT_TEMPERATURE
from .effects.force_constant_variation import emf_change
from .effects.inductance_saturation import inductance_change
from .effects.resistance_drift import drift_factor, thermal_rate
from .effects.return_spring import spring_force
from .equations import coil_rates

# The kernel vector holds the six physical parameters (PARAMETER_NAMES order), then these effect slots, each
# at the value that switches its part of the physics off.
NEUTRAL = {
    'coulomb_force': 0.0, 'spring_stiffness': 0.0, 'spring_center': 0.0,
    'temperature_coefficient': 0.0, 'ambient_temperature': AMBIENT_TEMPERATURE,
    'thermal_resistance': math.inf, 'thermal_capacitance': math.inf,
    'inductance_quadratic': 0.0, 'saturation_current': math.inf,
    'emf_constant_slope': 0.0, 'emf_constant_curvature': 0.0, 'emf_constant_center': 0.0,
}
SLOTS = PARAMETER_NAMES + tuple(NEUTRAL)
(_R, _L, _KM, _M, _B, _FL, _FC, _K, _XS, _ALPHA, _TAMB, _RTH, _CTH, _L2, _ISAT, _K1, _K2, _XK) = range(len(SLOTS))


def kernel_vector(params, effects):
    """The compiled dynamics' parameter vector, or None if some effect has no kernel values."""
    values = dict(NEUTRAL, **params.physical())
    for effect in effects:
        contribution = effect.kernel_values()
        if contribution is None:
            return None
        unknown = set(contribution) - set(NEUTRAL)
        if unknown:
            raise ValueError(f'{type(effect).__name__}.kernel_values() has unknown slots {sorted(unknown)}')
        values.update(contribution)
    return np.array([values[slot] for slot in SLOTS])


@numba.njit(cache=True)
def _emf(x, p):
    return p[_KM] + emf_change(x, p[_K1], p[_K2], p[_XK])


@numba.njit(cache=True)
def _derivatives(i, x, v, temp, u, p, h):
    r = p[_R] * drift_factor(temp, p[_ALPHA], p[_TAMB])
    emf = _emf(x, p)
    inductance = p[_L] + inductance_change(i, p[_L2], p[_ISAT])
    load = p[_FL] + spring_force(x, p[_K], p[_XS])
    di, dv = coil_rates(i, v, u, r, inductance, emf, emf * i, p[_M], p[_B], load, p[_FC], h)
    return di, v, dv, thermal_rate(temp, r * i * i, p[_TAMB], p[_RTH], p[_CTH])


@numba.njit(cache=True)
def integrate_interval(i, x, v, temp, u, dt, substeps, p):
    """(I, x, v, T) after dt at constant voltage u: `substeps` classical RK4 steps."""
    h = dt / substeps
    for _ in range(substeps):
        a0, a1, a2, a3 = _derivatives(i, x, v, temp, u, p, h)
        b0, b1, b2, b3 = _derivatives(i + 0.5 * h * a0, x + 0.5 * h * a1, v + 0.5 * h * a2,
                                      temp + 0.5 * h * a3, u, p, h)
        c0, c1, c2, c3 = _derivatives(i + 0.5 * h * b0, x + 0.5 * h * b1, v + 0.5 * h * b2,
                                      temp + 0.5 * h * b3, u, p, h)
        d0, d1, d2, d3 = _derivatives(i + h * c0, x + h * c1, v + h * c2, temp + h * c3, u, p, h)
        i += h / 6.0 * (a0 + 2.0 * (b0 + c0) + d0)
        x += h / 6.0 * (a1 + 2.0 * (b1 + c1) + d1)
        v += h / 6.0 * (a2 + 2.0 * (b2 + c2) + d2)
        temp += h / 6.0 * (a3 + 2.0 * (b3 + c3) + d3)
    return i, x, v, temp


@numba.njit(cache=True)
def integrate_sequence(state, voltages, dt, substeps, p):
    """Rows (I, x, v, T, coil force) at the end of each ZOH interval, from state (I, x, v, T)."""
    out = np.empty((voltages.size, 5))
    i, x, v, temp = state[0], state[1], state[2], state[3]
    for k in range(voltages.size):
        i, x, v, temp = integrate_interval(i, x, v, temp, voltages[k], dt, substeps, p)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = i, x, v, temp
        out[k, 4] = _emf(x, p) * i
    return out


def coil_state(params, effects, current, position):
    """(l, e, F): incremental inductance, back-EMF coefficient and coil force at (I, x) through the hooks."""
    inductance, emf, force = params.inductance, params.emf_constant, params.emf_constant * current
    for effect in effects:
        dl, de, df = effect.flux_terms(position, current)
        inductance, emf, force = inductance + dl, emf + de, force + df
    return inductance, emf, force


def hook_rates(params, effects, state, u, h):
    """d(I, x, v, T)/dt through the effects' hooks (any effect, in Python)."""
    i, x, v, temp = state
    resistance = params.resistance * math.prod(effect.resistance_factor(temp) for effect in effects)
    inductance, emf, force = coil_state(params, effects, i, x)
    load = params.load_force + sum(effect.extra_force(x, v) for effect in effects)
    di, dv = coil_rates(i, v, u, resistance, inductance, emf, force, params.mass, params.damping, load,
                        sum(effect.friction_level() for effect in effects), h)
    return np.array([di, v, dv, sum(effect.temperature_rate(temp, resistance * i * i) for effect in effects)])
