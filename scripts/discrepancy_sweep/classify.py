"""What a right answer is for a case and how each result is judged against it: truth, names, verdicts, numbers."""
import math
import re

import numpy as np

from .cases import LIBRARY

FRICTION = {'coulomb_friction', 'smooth_friction', 'stribeck_friction'}
SENSOR = {'sensor_delay', 'sensor_filter'}
# What the workflow may call each hidden effect: a friction by any friction candidate (a Stribeck friction
# may need two), a sensor's lag by a delay or a filter, a current-sensor offset by the drive's voltage offset.
ACCEPTED = {name: {name} for name in LIBRARY}
ACCEPTED.update({name: FRICTION for name in FRICTION})
ACCEPTED.update({name: SENSOR for name in SENSOR})
ACCEPTED['current_sensor_offset'] = {'drive_voltage_error', 'current_sensor_offset'}
FIVE = 5.0   # the "above 5x the noise floor" (size / noise_floor)
OUTCOMES = ('adequate', 'explained, right', 'explained, wrong or extra name', 'unexplained, right name(s)',
            'unexplained, wrong name', 'unexplained, nothing named', 'failed')


def expected(case, recording):
    """The truth a case's result is judged against, moved to the candidates' parameterisation.

    The candidates centre their position terms on the MEAN measured position xm over the window the workflow
    analyses (the record less its last MAX_DELAY samples, kept for re-alignment: over the whole record xm was
    once 1.65 um off, which put a strong spring's load force 1.27 mN, 8.7 sigma, off), so the truth is moved
    there: a spring k (x - x0) is k (x - xm) plus a load force k (xm - x0); Km0 (1 + a d + b d^2) about xm has
    Km(xm), slope Km0 (a + 2 b (xm - xc)) and curvature Km0 b exactly; the plant's L0 exp(g (x - xc)) is
    L(xm) (1 + g d + g^2 d^2 / 2 + ...), whose quadratic is only its Taylor start (not exact). A current-sensor
    offset I0 is the drive's V0 = -R I0 (the workflow reports I0 as `equivalent_current_offset`) and adds
    Km I0 to the load force. The resistance rise is the plant's R(end) - R0 (the candidate's heating shape,
    a low-pass of I^2, is not the plant's R(T) I^2: not exact). A filter of time constant tau is, at low
    frequency, a delay of tau (not exact: a delay named for a filter is judged within 25 %).

    Parameters
    ----------
    case : dict
        The case (`make_case`).
    recording : Recording
        Its record (`simulate`).

    Returns
    -------
    tuple of (dict, dict)
        {nominal parameter: true value} and {effect parameter: (true value, exact form, tolerance)}. A
        parameter reported without a standard deviation (a delay, a filter's time constant) is right within
        its tolerance; the others are judged in their standard deviations. The resistance rise's truth is
        None here: it is the plant's, filled in by `run_case`.
    """
    p = dict(case['params'])
    from emla_identification.discrepancy.data import Data
    xm = float(np.mean(Data.from_recording(recording).signals['position']))
    ts = 1.0 / case['rate']
    out = {}
    for name, e in case['effects'].items():
        if name == 'coulomb_friction':
            out['coulomb_force'] = (e['force'], True, None)
            out['friction_force'] = (e['force'], False, None)
            # the plant's stuck contact: critically damped (tests/independent_plant.py); the candidate's band is
            # searched on a grid, so its damping is compared for information
            out['presliding_damping'] = (2.0 * math.sqrt(p['mass'] * e['force'] / e.get('presliding', 2e-6)),
                                         False, None)
        elif name == 'smooth_friction':
            out['friction_force'] = (e['force'], True, None)
            out['coulomb_force'] = (e['force'], False, None)
        elif name == 'stribeck_friction':
            out['coulomb_force'] = (e['coulomb'], True, None)
            out['stribeck_force'] = (e['static'] - e['coulomb'], True, None)
            out['friction_force'] = (e['coulomb'], False, None)
            out['presliding_damping'] = (2.0 * math.sqrt(p['mass'] * e['static'] / e['presliding']), False, None)
        elif name == 'return_spring':
            out['spring_stiffness'] = (e['stiffness'], True, None)
            p['load_force'] += e['stiffness'] * (xm - e.get('rest_position', 0.0))
        elif name == 'magnetic_stiffness':
            out['spring_stiffness'] = (-e['stiffness'], True, None)
            p['load_force'] -= e['stiffness'] * (xm - e.get('center', 0.0))
        elif name == 'force_constant_variation':
            d, km0 = xm - e['center'], case['params']['emf_constant']
            p['emf_constant'] = km0 * (1.0 + e['slope'] * d + e['curvature'] * d * d)
            out['emf_constant_slope'] = (km0 * (e['slope'] + 2.0 * e['curvature'] * d), True, None)
            out['emf_constant_curvature'] = (km0 * e['curvature'], True, None)
        elif name == 'position_inductance':
            lx = case['params']['inductance'] * math.exp(e['growth'] * (xm - e['center']))
            p['inductance'] = lx
            out['inductance_slope'] = (e['growth'] * lx, False, None)
            out['inductance_curvature'] = (0.5 * e['growth'] ** 2 * lx, False, None)
        elif name == 'inductance_saturation':
            out['equivalent_saturation_current'] = (e['saturation_current'], True, None)
            out['inductance_quadratic'] = (-case['params']['inductance'] / e['saturation_current'] ** 2, True, None)
        elif name == 'resistance_drift':
            out['resistance_rise'] = (None, False, None)   # filled in by run_case from the plant's truth
        elif name == 'drive_voltage_error':
            out['dead_time_drop'] = (e['dead_time_drop'], True, None)
            out['voltage_offset'] = (e['offset'], True, None)
        elif name == 'current_sensor_offset':
            out['equivalent_current_offset'] = (e['offset'], True, None)
            p['load_force'] += case['params']['emf_constant'] * e['offset']
        elif name == 'sensor_delay':
            for signal in ('current', 'position'):
                if e[signal]:
                    out[f'{signal}_delay'] = (e[signal] * ts, True, 0.1 * ts)
        elif name == 'sensor_filter':
            for signal in ('current', 'position'):
                if e[f'{signal}_cutoff']:
                    tau = 1.0 / (2.0 * math.pi * e[f'{signal}_cutoff'])
                    out[f'{signal}_filter_time_constant'] = (tau, True, 0.1 * tau)
                    out[f'{signal}_delay'] = (tau, False, 0.25 * tau)
    return p, out


_PERCENT = re.compile(r'(?<![\w.])(-?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*%')
_NONFINITE = re.compile(r'(?<![\w])[-+]?(?:nan|inf|infinity)(?![\w])', re.IGNORECASE)


def numeric_problems(value, where='json'):
    """Every NaN/inf number, 'nan'/'inf' text and percentage below -100 % in a JSON-like value or a text.

    Parameters
    ----------
    value : dict, list, number or str
        The diagnosis's JSON (as Python values) or a report's text.
    where : str
        The path of `value` in what is checked (list indices are written [i]).

    Returns
    -------
    list of dict
        [{where, what, text}], `what` one of 'nan', 'inf', 'percentage < -100 %'.
    """
    problems = []
    if isinstance(value, dict):
        for k, v in value.items():
            problems += numeric_problems(v, f'{where}.{k}')
    elif isinstance(value, (list, tuple)):
        for v in value:
            problems += numeric_problems(v, f'{where}[i]')
    elif isinstance(value, bool) or value is None:
        pass
    elif isinstance(value, (int, float, np.floating, np.integer)):
        if not math.isfinite(float(value)):
            problems.append({'where': where, 'what': 'nan' if math.isnan(float(value)) else 'inf',
                             'text': repr(value)})
    elif isinstance(value, str):
        for line in value.splitlines():
            found = [('nan' if 'nan' in m.group(0).lower() else 'inf') for m in _NONFINITE.finditer(line)]
            found += ['percentage < -100 %' for m in _PERCENT.finditer(line) if float(m.group(1)) < -100.0]
            for what in dict.fromkeys(found):
                problems.append({'where': where, 'what': what, 'text': line.strip()[:240]})
    return problems


def accepted_names(hidden):
    """The set of names the workflow may give for the hidden effects `hidden` (any of them)."""
    return set().union(*(ACCEPTED.get(h, set()) for h in hidden)) if hidden else set()


def _right(r):
    """Every hidden library effect named by an accepted name, and nothing else named."""
    hidden = [h for h in r['hidden'] if h in ACCEPTED]
    named = set(r['named'])
    return all(named & ACCEPTED[h] for h in hidden) and named <= accepted_names(hidden)


def outcome(r):
    """The result's verdict and names against the truth.

    Parameters
    ----------
    r : dict
        A case's result (`run_case`).

    Returns
    -------
    str
        One of `OUTCOMES`.
    """
    if r.get('error'):
        return 'failed'
    if r['verdict'] == 'adequate':
        return 'adequate'
    named, accepted = set(r['named']), accepted_names(r['hidden'])
    right = bool(named) and _right(r)
    if r['verdict'] == 'explained':
        return 'explained, right' if right else 'explained, wrong or extra name'
    if not named:
        return 'unexplained, nothing named'
    return 'unexplained, right name(s)' if named <= accepted else 'unexplained, wrong name'


def success(r):
    """Whether the case came out as it should (a library effect below 5x the floor is not judged: see `counted`).

    A clean record: adequate, nothing named; an effect outside the library: nothing named; library effects:
    explained, each named by an accepted name and nothing else named.
    """
    if r.get('error'):
        return False
    kind = r['kind']
    if kind == 'clean':
        return r['verdict'] == 'adequate' and not r['named']
    if kind == 'outside':
        return not r['named']
    if kind == 'single':
        return r['verdict'] == 'explained' and _right(r)
    return r['verdict'] == 'explained' and _right(r)


def counted(r):
    """Whether the case is in the issue's "above 5x the noise floor" population (library effects).

    A pair counts when each of its effects alone is above 5x; a case that raised counts (a failure is a miss).
    """
    if r.get('error'):
        s = r['case'].get('levels', {})
        return bool(s)   # unknown strength: counted (a failure is a miss)
    if r['kind'] == 'single':
        return r['strength'] > FIVE
    if r['kind'] == 'pair':
        return min(r.get('single_strength', {'': 0.0}).values()) > FIVE
    return False


def right_model(r):
    """Whether the final model has the right structure: a clean record adequate, or every hidden library effect
    named and explained (the population the re-identified parameters are judged on)."""
    return not r.get('error') and r['kind'] in ('clean', 'single', 'pair') and success(r)


def exact_sigmas(r):
    """{parameter: sigma} of the re-identified nominal parameters whose truth is exact for the case."""
    out = {k: v for k, v in r.get('nominal_sigma', {}).items() if v is not None}
    if 'position_inductance' in r['hidden']:
        out.pop('inductance', None)   # L(xm) of an exponential L(x) fitted by a quadratic: not exact
    return out


def unstable(r):
    """Whether the case made no record: the plant's loop went unstable (independent_plant raises this
    RuntimeError)."""
    return bool(r.get('simulation_failed') or (r.get('error') or '').startswith('RuntimeError: the loop went unstable'))
