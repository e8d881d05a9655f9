"""The sweep's cases: each one drawn from one integer seed (actuator, sample rate, kind, hidden effects, strengths)."""
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]   # the repository
TESTS = ROOT / 'tests'
if str(TESTS) not in sys.path:   # appended: a code snapshot's tests/ (PYTHONPATH, --code) comes first
    sys.path.append(str(TESTS))

# The actuators the parameters are drawn around: tests/actuators.py (no suite import: --code comes after it).
from actuators import ACTUATORS  # noqa: E402  (tests/ is on the path from above)

DURATION = 3.0       # s per record (the workflow's own hidden-effect tests use 3 s)
SPREAD = 0.3         # each nominal parameter drawn within +-30 % of its actuator's
RATES = (2000.0, 3000.0, 5000.0, 10000.0, 20000.0)   # Hz; the nominal rows are first order in Ts: < 5 kHz apart
LOW_RATE = 5000.0
NOMINAL = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping', 'load_force')

# Library effects of the independent plant and their strength knobs: the first parameter of each is drawn
# log-uniformly within its range (a level u in [0, 1] maps to lo * (hi / lo)^u), the others as
# `_effect_parameters` says. The ranges go from below the noise floor to strong.
LEVELS = {
    'coulomb_friction': {'force': (0.01, 2.0)},
    'smooth_friction': {'force': (0.01, 2.0)},
    'stribeck_friction': {'coulomb': (0.01, 2.0)},
    'return_spring': {'stiffness': (5.0, 3000.0)},
    'magnetic_stiffness': {'stiffness': (5.0, 3000.0)},
    'resistance_drift': {'coefficient': (2e-5, 8e-3)},
    'inductance_saturation': {'saturation_current': (60.0, 2.5)},
    'force_constant_variation': {'scale': (0.01, 4.0)},
    'position_inductance': {'growth': (1.0, 200.0)},
    'drive_voltage_error': {'dead_time_drop': (0.003, 1.0)},
    'current_sensor_offset': {'offset': (1e-3, 0.3)},
    'sensor_delay': {'samples': (0.1, 3.0)},
    'sensor_filter': {'time_constant': (0.02, 2.0)},   # in sample periods
    # outside the library: must not be named
    'quadratic_drag': {'coefficient': (0.05, 8.0)},
    'cogging': {'amplitude': (0.02, 2.0)},
    'time_varying_load': {'amplitude': (0.02, 3.0)},
    'force_saturation': {'saturation_current': (60.0, 3.0)},
}
LIBRARY = ('coulomb_friction', 'smooth_friction', 'stribeck_friction', 'return_spring', 'magnetic_stiffness',
           'resistance_drift', 'inductance_saturation', 'force_constant_variation', 'position_inductance',
           'sensor_delay', 'sensor_filter', 'drive_voltage_error', 'current_sensor_offset')
OUTSIDE = ('quadratic_drag', 'cogging', 'time_varying_load', 'force_saturation')
BENCH = ('sensor_delay', 'sensor_filter', 'drive_voltage_error', 'current_sensor_offset')   # the bench's own
# Pairs the plant cannot make (position_inductance with saturation), that merge into one effect (two springs,
# two frictions, a delay and a filter) or that are one signature (a current-sensor offset is a voltage offset
# of the drive).
EXCLUDED_PAIRS = [{'position_inductance', 'inductance_saturation'}, {'return_spring', 'magnetic_stiffness'},
                  {'drive_voltage_error', 'current_sensor_offset'}, {'sensor_delay', 'sensor_filter'},
                  {'coulomb_friction', 'smooth_friction'}, {'coulomb_friction', 'stribeck_friction'},
                  {'smooth_friction', 'stribeck_friction'}]
KINDS = (('clean', 0.15), ('single', 0.55), ('pair', 0.22), ('outside', 0.08))


def _level(rng, lo, hi, level=None):
    """(u, value): a strength level u in [0, 1] (drawn unless given) and lo * (hi / lo)^u."""
    u = float(rng.uniform())
    u = u if level is None else float(level)
    return u, float(lo * (hi / lo) ** u)


def _effect_parameters(name, rng, params, rate, level=None):
    """Draw the parameters of one hidden effect.

    Parameters
    ----------
    name : str
        The effect, a key of `LEVELS`.
    rng : numpy.random.Generator
        The case's generator (every draw of the case comes from it, in order).
    params : dict
        The case's nominal parameters.
    rate : float
        The sample rate in Hz (a filter's time constant is drawn in sample periods).
    level : float, optional
        The strength level in [0, 1]; drawn if not given.

    Returns
    -------
    tuple of (float, dict)
        The level and {parameter: value} of the effect.
    """
    knob, (lo, hi) = next(iter(LEVELS[name].items()))
    u, value = _level(rng, lo, hi, level)
    sign = float(rng.choice([-1.0, 1.0]))
    centre = float(rng.uniform(0.5e-3, 2.0e-3))
    if name == 'sensor_delay':   # whole samples (half the cases) or fractional ones
        which = str(rng.choice(['current', 'position', 'both']))
        d = float(min(3, max(1, round(value)))) if rng.uniform() < 0.5 else round(value, 3)
        return u, {'current': d if which in ('current', 'both') else 0,
                   'position': d if which in ('position', 'both') else 0}
    if name == 'sensor_filter':   # first-order low-pass of tau = value sample periods
        which = str(rng.choice(['current', 'current', 'position', 'both']))
        cutoff = rate / (2.0 * math.pi * value)
        return u, {'current_cutoff': cutoff if which in ('current', 'both') else 0.0,
                   'position_cutoff': cutoff if which in ('position', 'both') else 0.0}
    if name == 'smooth_friction':
        return u, {'force': value, 'speed': float(10 ** rng.uniform(-3.0, -2.0))}
    if name == 'stribeck_friction':
        return u, {'coulomb': value, 'static': value * float(rng.uniform(1.2, 2.5)),
                   'speed': float(10 ** rng.uniform(-2.5, -1.5)), 'presliding': 2e-6}
    if name == 'force_constant_variation':
        return u, {'slope': 30.0 * value * sign, 'curvature': -3.0e4 * value, 'center': centre}
    if name == 'drive_voltage_error':
        return u, {'dead_time_drop': value, 'offset': float(value * rng.uniform(-0.5, 0.5)),
                   'current_band': float(10 ** rng.uniform(-2.0, -1.0))}
    if name == 'current_sensor_offset':
        return u, {'offset': value * sign}
    if name == 'return_spring':
        return u, {'stiffness': value, 'rest_position': float(rng.uniform(-1e-3, 3e-3))}
    if name == 'magnetic_stiffness':
        return u, {'stiffness': value, 'center': float(rng.uniform(-1e-3, 3e-3))}
    if name == 'position_inductance':
        return u, {'growth': value * sign, 'center': centre}
    if name == 'cogging':
        return u, {'amplitude': value, 'pitch': float(rng.uniform(0.8e-3, 2.0e-3)),
                   'phase': float(rng.uniform(0, 1e-3))}
    if name == 'time_varying_load':
        return u, {'amplitude': value, 'period': float(rng.uniform(0.4, 1.5)), 'phase': float(rng.uniform(0, 6.28))}
    return u, {knob: value}


def make_case(seed, kind=None, effects=None, rate=None, actuator=None, duration=DURATION, level=None):
    """The case of a seed: its actuator, nominal parameters, sample rate, kind and hidden effects.

    Every argument but `seed` overrides a part of the draw; the draw of the rest is unchanged.

    Parameters
    ----------
    seed : int
        The case's seed: everything else is drawn from it.
    kind : str, optional
        'clean', 'single', 'pair' or 'outside' (the library's effects, or one outside the library).
    effects : dict, optional
        {name: parameters, or None for drawn ones}, in place of the kind's drawn effects.
    rate : float, optional
        The sample rate in Hz.
    actuator : str, optional
        A key of `ACTUATORS` the nominal parameters are drawn around.
    duration : float
        The record's length in s.
    level : float, optional
        The strength level in [0, 1] of every drawn effect.

    Returns
    -------
    dict
        {seed, kind, actuator, params, rate, duration, effects: {name: parameters}, levels: {name: level or
        None for a given effect}}.
    """
    rng = np.random.default_rng([seed, 22])
    names = [k for k, _ in KINDS]
    drawn_kind = str(rng.choice(names, p=[w for _, w in KINDS]))
    drawn_actuator = str(rng.choice(list(ACTUATORS)))
    drawn_rate = float(rng.choice(RATES))
    base = ACTUATORS[actuator or drawn_actuator]
    params = {k: (float(v * (1.0 + SPREAD * rng.uniform(-1.0, 1.0))) if k != 'load_force' else float(v))
              for k, v in base.items()}
    kind = kind or drawn_kind
    if effects is None:
        if kind == 'clean':
            chosen = []
        elif kind == 'single':
            chosen = [str(rng.choice(LIBRARY))]
        elif kind == 'outside':
            chosen = [str(rng.choice(OUTSIDE))]
        else:
            while True:
                chosen = [str(c) for c in rng.choice(LIBRARY, size=2, replace=False)]
                if set(chosen) not in EXCLUDED_PAIRS:
                    break
        effects = {name: None for name in chosen}
    drawn, levels = {}, {}
    for name, given in effects.items():
        u, parameters = (_effect_parameters(name, rng, params, float(rate or drawn_rate), level)
                         if name in LEVELS else (None, {}))
        drawn[name] = dict(given) if given is not None else parameters
        levels[name] = u if given is None else None
    return {'seed': int(seed), 'kind': kind, 'actuator': actuator or drawn_actuator, 'params': params,
            'rate': float(rate or drawn_rate), 'duration': float(duration), 'effects': drawn, 'levels': levels}
