"""The discrepancy workflow's real accuracy (issue 22): many records of tests/independent_plant.py (an RK4 plant
written apart from the suite), each with hidden effects the workflow is not told about, diagnosed by
emla_identification.discrepancy.diagnose; the verdicts, the names and the parameters against the truth.

Every case comes from one integer seed (nothing else): the actuator (one of ACTUATORS, each parameter drawn
+-30 %), the sample rate (RATES), the kind (a clean record, one library effect, a random pair of them, or an
effect the library lacks), the effects' strengths (log-uniform over LEVELS, from below the noise floor to
strong) and the record's noise. Rerun one case, with its full JSON, by its seed:

    .venv/bin/python scripts/discrepancy_sweep.py --case SEED [--code COMMIT]

The sweep (`make discrepancy-sweep`, called by `make sweep`):

    .venv/bin/python scripts/discrepancy_sweep.py --cases 240 --workers 2 --out out/discrepancy-sweep.jsonl
    .venv/bin/python scripts/discrepancy_sweep.py --cases 240 --resume          # go on after an interruption
    .venv/bin/python scripts/discrepancy_sweep.py --report-only                 # rewrite the document

runs the cases on dask.distributed (a LocalCluster of --workers processes, one thread each), appends each
result to the JSON-lines file as it finishes (a case that raises is a result too: its one-line error), shows
progress on stderr, and writes docs/discrepancy-sweep.md from the JSON-lines file (`write_report`). The suite
measured is the one committed at --code (default HEAD), exported to out/sweep-code/COMMIT, so that others
reinstalling .venv or editing the work tree meanwhile change nothing; `--code installed` measures .venv's.

Strength over the noise floor: the workflow's own adequacy measure of the NOMINAL model on the record
(`disagreement_nominal` of the JSON): per equation the RMS of the low-band residual the sensor noise does not
explain over the RMS the noise puts there (`size / noise_floor`, an amplitude ratio; `ratio`, the power
ratio, is about 1 + its square); the case's strength is the larger of the two equations. For a pair, each
effect's own strength is measured the same way on the record with that effect alone (same seed, same
parameters: two extra nominal-only diagnoses).
"""
import argparse
import collections
import json
import math
import os
import re
import subprocess
import sys
import time
import traceback
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / 'tests'
SCRIPTS = ROOT / 'scripts'
for _path in (TESTS, SCRIPTS):   # appended: a code snapshot's tests/ (PYTHONPATH, --code) comes first
    if str(_path) not in sys.path:
        sys.path.append(str(_path))

DEFAULT_OUT = ROOT / 'out' / 'discrepancy-sweep.jsonl'
DEFAULT_DOC = ROOT / 'docs' / 'discrepancy-sweep.md'
DURATION = 3.0       # s per record (the workflow's own hidden-effect tests use 3 s)
SPREAD = 0.3         # each nominal parameter drawn within +-30 % of its actuator's
RATES = (2000.0, 3000.0, 5000.0, 10000.0, 20000.0)   # Hz; the nominal rows are first order in Ts: < 5 kHz apart
LOW_RATE = 5000.0
NOMINAL = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping', 'load_force')

# The actuators the parameters are drawn around: tests/actuators.py (no suite import: --code comes after it).
from actuators import ACTUATORS  # noqa: E402  (tests/ is on the path from above)

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
FRICTION = {'coulomb_friction', 'smooth_friction', 'stribeck_friction'}
SENSOR = {'sensor_delay', 'sensor_filter'}
# Pairs the plant cannot make (position_inductance with saturation), that merge into one effect (two springs,
# two frictions, a delay and a filter) or that are one signature (a current-sensor offset is a voltage offset
# of the drive).
EXCLUDED_PAIRS = [{'position_inductance', 'inductance_saturation'}, {'return_spring', 'magnetic_stiffness'},
                  {'drive_voltage_error', 'current_sensor_offset'}, {'sensor_delay', 'sensor_filter'},
                  {'coulomb_friction', 'smooth_friction'}, {'coulomb_friction', 'stribeck_friction'},
                  {'smooth_friction', 'stribeck_friction'}]
# What the workflow may call each hidden effect: a friction by any friction candidate (a Stribeck friction
# may need two), a sensor's lag by a delay or a filter, a current-sensor offset by the drive's voltage offset.
ACCEPTED = {name: {name} for name in LIBRARY}
ACCEPTED.update({name: FRICTION for name in FRICTION})
ACCEPTED.update({name: SENSOR for name in SENSOR})
ACCEPTED['current_sensor_offset'] = {'drive_voltage_error', 'current_sensor_offset'}
KINDS = (('clean', 0.15), ('single', 0.55), ('pair', 0.22), ('outside', 0.08))
FIVE = 5.0   # the "above 5x the noise floor" (size / noise_floor)


# ---------------------------------------------------------------------------------------------- the cases
def _level(rng, lo, hi, level=None):
    u = float(rng.uniform())
    u = u if level is None else float(level)
    return u, float(lo * (hi / lo) ** u)


def _effect_parameters(name, rng, params, rate, level=None):
    """(level in [0, 1], {parameter: value}) of effect `name` drawn for the nominal parameters `params` at the
    sample rate `rate`."""
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
    """The case of `seed`: {seed, kind, actuator, params, rate, duration, effects: {name: parameters}, levels}.
    `kind`, `effects` ({name: parameters or None for a drawn one}), `rate` and `actuator` override the draw
    (the draw of the rest is unchanged); `level` in [0, 1] sets every drawn effect's strength level."""
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


def substeps(case):
    """RK4 steps per sample: h at most 25 us and 0.4 / the stiffest rate (the drive's tanh band, the stuck
    friction contact)."""
    ts = 1.0 / case['rate']
    h = 25e-6
    p = case['params']
    drive = case['effects'].get('drive_voltage_error')
    if drive:
        h = min(h, 0.4 * drive['current_band'] * 0.7 * p['inductance'] / max(drive['dead_time_drop'], 1e-12))
    for name, key in (('coulomb_friction', 'force'), ('stribeck_friction', 'static')):
        friction = case['effects'].get(name)
        if friction:   # the stuck contact: a spring F / presliding, critically damped
            h = min(h, 0.3 / math.sqrt(friction[key] / friction.get('presliding', 2e-6) / p['mass']))
    friction = case['effects'].get('smooth_friction')
    if friction:   # dF/dv = Fc / v_s at v = 0
        h = min(h, 1.0 * friction['speed'] * p['mass'] / friction['force'])
    return max(4, int(math.ceil(ts / h)))


def simulate(case, effects=None):
    """(Recording, truth) of the case (with `effects` instead of the case's, if given)."""
    from independent_plant import record
    effects = case['effects'] if effects is None else effects
    delays = effects.get('sensor_delay')
    others = [(name, p) for name, p in effects.items() if name != 'sensor_delay']
    return record(case['duration'], params=case['params'], effects=others, seed=case['seed'],
                  delays=delays, sample_period=1.0 / case['rate'], substeps=substeps(dict(case, effects=effects)))


# ---------------------------------------------------------------------------------------------- the truth
def expected(case, recording):
    """What a right answer is: ({nominal parameter: true value}, {effect parameter: (true value, exact form,
    tolerance)}); a parameter reported without a standard deviation (a delay, a filter's time constant) is
    right within its tolerance, the others are judged in their standard deviations.

    The candidates centre their position terms on the MEAN measured position xm over the window the workflow
    analyses (the record less its last MAX_DELAY samples, kept for re-alignment: over the whole record xm was
    1.65 um off in case 74, and k xm put its load force 1.27 mN, 8.7 sigma, off), so the truth is moved there:
    a spring k (x - x0) is k (x - xm) plus a load force k (xm - x0); Km0 (1 + a d + b d^2) about xm has
    Km(xm), slope Km0 (a + 2 b (xm - xc)) and curvature Km0 b exactly; the plant's L0 exp(g (x - xc)) is
    L(xm) (1 + g d + g^2 d^2 / 2 + ...), whose quadratic is only its Taylor start (not exact). A current-sensor
    offset I0 is the drive's V0 = -R I0 (the workflow reports I0 as `equivalent_current_offset`) and adds
    Km I0 to the load force. The resistance rise is the plant's R(end) - R0 (the candidate's heating shape,
    a low-pass of I^2, is not the plant's R(T) I^2: not exact). A filter of time constant tau is, at low
    frequency, a delay of tau (not exact: a delay named for a filter is judged within 25 %)."""
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


# ---------------------------------------------------------------------------------------------- the checks
_PERCENT = re.compile(r'(?<![\w.])(-?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*%')
_NONFINITE = re.compile(r'(?<![\w])[-+]?(?:nan|inf|infinity)(?![\w])', re.IGNORECASE)


def numeric_problems(value, where='json'):
    """Every NaN/inf number, 'nan'/'inf' text and percentage below -100 % in a JSON-like value or a text:
    [{where, what, text}] (`where` with list indices as [i], `what` one of nan, inf, percentage < -100 %)."""
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


def report_text(diagnosis):
    """The Markdown of `emla discrepancy --report` for the diagnosis (without its figures when the report
    module allows it)."""
    try:
        from emla_identification.discrepancy.locate import localise
        from emla_identification.discrepancy.report import _markdown
        return _markdown(diagnosis, localise(diagnosis.nominal))
    except (ImportError, TypeError, AttributeError):   # the private function changed: the whole report
        import tempfile

        from emla_identification.discrepancy.report import write_report
        with tempfile.TemporaryDirectory() as directory:
            return Path(write_report(diagnosis, directory)).read_text()


def _strength(disagreement):
    """(size / noise_floor, power ratio) of the worse equation: the strength over the noise floor."""
    best = (0.0, 0.0)
    for d in disagreement.values():
        floor = d.get('noise_floor') or 0.0
        amplitude = d['size'] / floor if floor > 0 else math.inf
        best = max(best, (amplitude, d.get('ratio', math.nan)))
    return best


def _sigma(value, truth, std):
    if value is None or truth is None or not std or not math.isfinite(std):
        return None
    return (value - truth) / std


def run_case(case, report=True):
    """Simulate and diagnose one case; the result as a JSON-able dict (never raises)."""
    start = time.perf_counter()
    out = {'seed': case['seed'], 'case': case, 'hidden': sorted(case['effects']), 'kind': case['kind'],
           'rate': case['rate'], 'code': os.environ.get('EMLA_SWEEP_CODE', 'installed'), 'error': None}
    try:
        from emla_identification.discrepancy.workflow import diagnose
        try:
            recording, truth = simulate(case)
        except RuntimeError as exc:   # the plant's loop went unstable: no record, not the workflow's failure
            out['simulation_failed'] = True
            raise exc
        nominal_truth, effect_truth = expected(case, recording)
        if 'resistance_rise' in effect_truth:
            effect_truth['resistance_rise'] = (truth['resistance_final'] - case['params']['resistance'], False, None)
        diagnosis = diagnose(recording)
        result = diagnosis.to_dict()
        out['verdict'] = result['verdict']
        out['named'] = [e['effect'] for e in result['effects']]
        out['strength'], out['power_ratio'] = _strength(result['disagreement_nominal'])
        out['final_strength'] = _strength(result['disagreement'])[0]
        out['disagreement_nominal'] = {k: {'size': v['size'], 'noise_floor': v['noise_floor'], 'ratio': v['ratio'],
                                           'depends_on': [d['signal'] for d in v.get('depends_on', [])[:2]]}
                                       for k, v in result['disagreement_nominal'].items()}
        out['disagreement_final'] = {k: {'ratio': v['ratio'], 'adequate': v['adequate'],
                                         'depends_on': [d['signal'] for d in v.get('depends_on', [])[:2]]}
                                     for k, v in result['disagreement'].items()}
        out['candidates'] = [{'effect': c['effect'], 'score': c['score'], 'significant': c['significant']}
                             for c in result['candidates'][:3]]
        final, std = result['reidentified_parameters'], result['reidentified_parameters_std']
        out['nominal_sigma'] = {k: _sigma(final.get(k), nominal_truth[k], std.get(k)) for k in NOMINAL}
        out['nominal_error'] = {k: (final[k] / nominal_truth[k] - 1.0) if nominal_truth[k] else final[k]
                                for k in NOMINAL if k in final}
        added, added_std = result['added_parameters'], result['added_parameters_std']
        out['effect_parameters'] = {}
        for k, (t, exact, tolerance) in effect_truth.items():
            if k in added:
                sigma = _sigma(added[k], t, added_std.get(k))
                out['effect_parameters'][k] = {
                    'value': added[k], 'std': added_std.get(k), 'truth': t, 'exact': exact, 'sigma': sigma,
                    'held_at_zero': k in result.get('held_at_zero', ()),   # (older commits: no key)
                    'within': (abs(sigma) <= 3.0 if sigma is not None else
                               abs(added[k] - t) <= tolerance if tolerance is not None else None)}
        problems = numeric_problems(result)
        if report:
            problems += numeric_problems(report_text(diagnosis), 'report.md')
        out['numeric_problems'] = problems
        out['warnings'] = list(result.get('warnings', []))
        if case['kind'] == 'pair':   # each effect's own strength: the nominal model on the record with it alone
            out['single_strength'] = {}
            for name in case['effects']:
                alone, _ = simulate(case, {name: case['effects'][name]})
                out['single_strength'][name] = _strength(diagnose(alone, names=[]).to_dict()['disagreement_nominal'])[0]
    except Exception as exc:   # a case that raises is a result: its one-line error
        out['error'] = f'{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ""}'[:400]
        out['traceback'] = traceback.format_exc(limit=6)[-2000:]
    out['seconds'] = round(time.perf_counter() - start, 2)
    return out


# ---------------------------------------------------------------------------------------------- the code
PACKAGES = ('emla_core', 'emla_identification', 'emla_sim')


def code_snapshot(revision):
    """(commit, [paths]) of the suite's packages and tests/independent_plant.py at `revision`, exported once
    under out/sweep-code/COMMIT: others may reinstall .venv or edit the work tree while a sweep runs, and the
    document names the commit it measured. tests/actuators.py stays the work tree's: the cases are drawn from it
    (before the code is chosen), and independent_plant reads its nominal set from the same module."""
    import shutil
    import tarfile
    import tempfile
    sha = subprocess.run(['git', 'rev-parse', '--verify', f'{revision}^{{commit}}'], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout.strip()
    dest = ROOT / 'out' / 'sweep-code' / sha
    if not (dest / '.complete').exists():
        dest.parent.mkdir(parents=True, exist_ok=True)
        (dest.parent / 'COLCON_IGNORE').touch()   # copies of the packages: colcon builds the work tree's alone
        with tempfile.TemporaryDirectory(dir=dest.parent) as tmp:
            archive = Path(tmp) / 'code.tar'
            subprocess.run(['git', 'archive', '-o', str(archive), sha, *PACKAGES, 'tests/independent_plant.py'],
                           cwd=ROOT, check=True)
            with tarfile.open(archive) as tar:
                tar.extractall(Path(tmp) / 'tree', filter='data')
            (Path(tmp) / 'tree' / '.complete').write_text(sha + '\n')
            if dest.exists():
                shutil.rmtree(dest)
            (Path(tmp) / 'tree').rename(dest)
    return sha, [str(dest / p) for p in PACKAGES] + [str(dest / 'tests')]


def use_code(revision):
    """Make this process and the workers it starts import the suite at `revision` ('installed': .venv's).
    Returns the commit (or 'installed')."""
    if revision == 'installed':
        os.environ['EMLA_SWEEP_CODE'] = 'installed'
        return 'installed'
    if any(name in sys.modules for name in PACKAGES + ('independent_plant',)):
        raise RuntimeError('use_code must run before the suite is imported')
    sha, paths = code_snapshot(revision)
    sys.path[0:0] = paths
    os.environ['PYTHONPATH'] = os.pathsep.join(paths + [p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep)
                                                        if p])
    os.environ['EMLA_SWEEP_CODE'] = sha
    return sha


# ---------------------------------------------------------------------------------------------- the sweep
def _read(path):
    """{seed: result} of a JSON-lines file (the last line of a seed wins; a torn last line is skipped)."""
    results = {}
    if not Path(path).exists():
        return results
    for line in Path(path).read_text().splitlines():
        try:
            r = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(r, dict) and 'seed' in r:
            results[int(r['seed'])] = r
    return results


def _summary(r):
    if r.get('error'):
        return f'FAILED {r["error"][:120]}'
    return f'{r["verdict"]} {",".join(r["named"]) or "-"} (strength {r["strength"]:.3g})'


def sweep(seeds, out, workers, resume=False, duration=DURATION, report=True):
    """Run the cases of `seeds` on a dask.distributed LocalCluster of `workers` processes, appending each
    result to the JSON-lines file `out` as it finishes; with `resume` the seeds already in `out` are skipped.
    Returns {seed: result} of every seed."""
    import logging

    from dask.distributed import Client, LocalCluster, as_completed

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = _read(out) if resume else {}
    if not resume:
        out.write_text('')
    todo = [s for s in seeds if s not in done]
    print(f'{len(seeds)} cases, {len(seeds) - len(todo)} already in {out}, {len(todo)} to run on {workers} '
          f'worker(s)', file=sys.stderr, flush=True)
    if not todo:
        return {s: done[s] for s in seeds}
    # the workers import this module (and tests/independent_plant) by name
    os.environ['PYTHONPATH'] = os.pathsep.join([p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep) if p] +
                                               [str(SCRIPTS), str(TESTS)])
    import discrepancy_sweep as module  # by reference, not by value, in the tasks
    start = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=':0',
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        futures = {client.submit(module.run_case, module.make_case(s, duration=duration), report, pure=False,
                                 key=f'case-{s}'): s for s in todo}
        with out.open('a') as f:
            for n, future in enumerate(as_completed(futures), 1):
                seed = futures[future]
                try:
                    r = future.result()
                except Exception as exc:   # the worker died or the task could not run: a failure, the rest go on
                    r = {'seed': seed, 'case': make_case(seed, duration=duration), 'error':
                         f'{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ""}'[:400]}
                    r.update(hidden=sorted(r['case']['effects']), kind=r['case']['kind'], rate=r['case']['rate'])
                f.write(json.dumps(r) + '\n')
                f.flush()
                done[seed] = r
                elapsed = time.perf_counter() - start
                eta = elapsed / n * (len(todo) - n)
                print(f'[{n}/{len(todo)}] seed {seed} {r["kind"]} {"+".join(r["hidden"]) or "clean"} '
                      f'{r["rate"] / 1000:g} kHz: {_summary(r)} ({r.get("seconds", 0):.1f} s; elapsed '
                      f'{elapsed / 60:.1f} min, left ~{eta / 60:.1f} min)', file=sys.stderr, flush=True)
    return {s: done[s] for s in seeds}


# ---------------------------------------------------------------------------------------------- the report
COIL = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')
SYMBOL = {'resistance': 'R', 'inductance': 'L', 'emf_constant': 'Km', 'mass': 'm', 'damping': 'B',
          'load_force': 'Fl'}
BINS = ((0.0, 1.58, '< 1.58 (adequate by the workflow\'s own test)'), (1.58, 5.0, '1.58-5'), (5.0, 20.0, '5-20'),
        (20.0, 100.0, '20-100'), (100.0, math.inf, '>= 100'))
OUTCOMES = ('adequate', 'explained, right', 'explained, wrong or extra name', 'unexplained, right name(s)',
            'unexplained, wrong name', 'unexplained, nothing named', 'failed')


def _accepted(hidden):
    return set().union(*(ACCEPTED.get(h, set()) for h in hidden)) if hidden else set()


def _right(r):
    """Every hidden library effect named by an accepted name, and nothing else named."""
    hidden = [h for h in r['hidden'] if h in ACCEPTED]
    named = set(r['named'])
    return all(named & ACCEPTED[h] for h in hidden) and named <= _accepted(hidden)


def outcome(r):
    if r.get('error'):
        return 'failed'
    if r['verdict'] == 'adequate':
        return 'adequate'
    named, accepted = set(r['named']), _accepted(r['hidden'])
    right = bool(named) and _right(r)
    if r['verdict'] == 'explained':
        return 'explained, right' if right else 'explained, wrong or extra name'
    if not named:
        return 'unexplained, nothing named'
    return 'unexplained, right name(s)' if named <= accepted else 'unexplained, wrong name'


def success(r):
    """Did the case come out as it should? (A library effect below 5x the floor is not judged: see counted.)"""
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
    """Is the case in the issue's "above 5x the noise floor" population (library effects)?"""
    if r.get('error'):
        s = r['case'].get('levels', {})
        return bool(s)   # unknown strength: counted (a failure is a miss)
    if r['kind'] == 'single':
        return r['strength'] > FIVE
    if r['kind'] == 'pair':
        return min(r.get('single_strength', {'': 0.0}).values()) > FIVE
    return False


def right_model(r):
    """The final model has the right structure: a clean record adequate, or every hidden library effect named
    and explained (the population the re-identified parameters are judged on)."""
    return not r.get('error') and r['kind'] in ('clean', 'single', 'pair') and success(r)


def _sigmas(r):
    """{parameter: sigma} of the re-identified nominal parameters whose truth is exact for the case."""
    out = {k: v for k, v in r.get('nominal_sigma', {}).items() if v is not None}
    if 'position_inductance' in r['hidden']:
        out.pop('inductance', None)   # L(xm) of an exponential L(x) fitted by a quadratic: not exact
    return out


def _rate(cases, good):
    n = len(cases)
    k = sum(1 for c in cases if good(c))
    return f'{k}/{n} ({100.0 * k / n:.1f} %)' if n else '0/0 (-)'


def _fmt_effects(effects):
    parts = []
    for name, p in effects.items():
        values = ', '.join(f'{k}={v:.3g}' if isinstance(v, float) else f'{k}={v}' for k, v in p.items())
        parts.append(f'{name}({values})')
    return '; '.join(parts) or 'none'


def _rerun(r):
    extra = f' --duration {r["case"]["duration"]:g}' if r['case']['duration'] != DURATION else ''
    code = r.get('code', 'installed')
    extra += f' --code {code[:12]}' if code != 'installed' else ' --code installed'
    return f'`.venv/bin/python scripts/discrepancy_sweep.py --case {r["seed"]}{extra}`'


def _miss_reason(r):
    if r.get('error'):
        return f'raised: {r["error"][:160]}'
    o = outcome(r)
    if r['kind'] == 'clean':
        return f'clean record called {r["verdict"]}' + (f', named {", ".join(r["named"])}' if r['named'] else '')
    if r['kind'] == 'outside':
        return f'an effect outside the library named {", ".join(r["named"])}'
    left = ', '.join(f'{k} {v["ratio"]:.3g}' for k, v in r.get('disagreement_final', {}).items()
                     if not v['adequate'])
    best = r.get('candidates') or [{}]
    why = o + (f'; left (power ratio): {left}' if left else '')
    if not r['named'] and best[0]:
        why += f'; best candidate {best[0]["effect"]} (score {best[0]["score"]:.3g}, ' \
               f'{"significant" if best[0]["significant"] else "not significant"})'
    return why


def _percentile(values, q):
    return float(np.percentile(values, q)) if len(values) else math.nan


def _unstable(r):
    """No record: the plant's loop went unstable (independent_plant raises this RuntimeError)."""
    return bool(r.get('simulation_failed') or (r.get('error') or '').startswith('RuntimeError: the loop went unstable'))


def write_report(results, path=DEFAULT_DOC, command=None):
    """Write the Markdown document of a sweep's results ({seed: result} or a list) to `path`."""
    every = sorted(results.values() if isinstance(results, dict) else results, key=lambda r: r['seed'])
    unstable = [r for r in every if _unstable(r)]
    rs = [r for r in every if not _unstable(r)]   # a record was made
    ok = [r for r in rs if not r.get('error')]
    lines = []
    add = lines.append
    codes = collections.Counter(r.get('code', 'installed') for r in rs)
    commit = ', '.join((c[:12] if c != 'installed' else 'the code installed in .venv')
                       + (f' ({n} cases)' if len(codes) > 1 else '') for c, n in sorted(codes.items())) or '?'
    durations = sorted({r['case']['duration'] for r in rs})
    seeds = [r['seed'] for r in every]
    add('# The discrepancy workflow on a sweep of independent records')
    add('')
    add(f'Generated by `scripts/discrepancy_sweep.py` ({time.strftime("%Y-%m-%d")}; the suite measured at commit '
        f'{commit}):')
    add('')
    add('```bash')
    add(command or '.venv/bin/python scripts/discrepancy_sweep.py --report-only')
    add('```')
    add('')
    skipped = sorted(set(range(min(seeds), max(seeds) + 1)) - set(seeds)) if seeds else []
    add(f'{len(every)} cases (seeds {min(seeds) if seeds else "-"}..{max(seeds) if seeds else "-"}'
        + (f', but for {", ".join(map(str, skipped))}, not run' if skipped else '') + '; '
        f'{len(unstable)} of them made no record: the plant\'s loop went unstable, listed at the end), '
        f'{", ".join(f"{d:g}" for d in durations)} s each, {sum(r.get("seconds", 0) for r in rs) / 60:.1f} '
        f'worker-minutes. Any case reruns alone with `.venv/bin/python scripts/discrepancy_sweep.py --case SEED` '
        '(it prints the result, with the JSON\'s key figures).')
    add('')
    add('## How the cases are made')
    add('')
    add('Each case is drawn from its seed alone. The plant is `tests/independent_plant.py` (fixed-step RK4 at '
        'h <= 25 us, written apart from the suite; PID position loop on a square stroke with a voltage dither, '
        '5 mA current noise, 1 um position quantisation). The nominal parameters are drawn within +-30 % of one of '
        f'{", ".join(ACTUATORS)} (`ACTUATORS` in the script), the sample rate from '
        f'{", ".join(f"{x / 1000:g}" for x in RATES)} kHz. The kind: a clean record (15 %), one library effect '
        '(55 %), a random pair of library effects (22 %), one effect outside the library (8 %). An effect\'s '
        'strength is drawn log-uniformly over a range (`LEVELS`) that runs from below the noise floor to strong '
        '(about a decade and a half of the resulting strength, more for some). The library effects: '
        f'{", ".join(LIBRARY)}; the bench\'s own imperfections among them: `sensor_delay` (current, position or both; '
        'whole samples 1-3 or fractional 0.1-3), `sensor_filter` (a first-order low-pass of 0.02-2 sample periods '
        'on the current, the position or both), `drive_voltage_error` (dead-time drop 3 mV-1 V, offset, fade '
        'current 10-100 mA) and `current_sensor_offset` (1-300 mA). Outside the library: '
        f'{", ".join(OUTSIDE)}.')
    add('')
    add('**Strength over the noise floor.** The workflow\'s own adequacy figures for the NOMINAL model on the '
        'record (`disagreement_nominal`): per equation the RMS of the low-band residual the sensor noise does not '
        'explain over the RMS the noise puts in that band (`size / noise_floor`, an amplitude ratio; the power '
        'ratio `ratio` is about 1 + its square, and the workflow calls an equation adequate up to a power ratio of '
        '3.5, i.e. an amplitude ratio of 1.58). A case\'s strength is the larger of its two equations. "Above 5x '
        'the noise floor" is an amplitude ratio above 5 (power ratio above ~26). For a pair, each effect\'s own '
        'strength is measured the same way on the same record with that effect alone; the pair counts when both '
        'are above 5x.')
    add('')
    add('**Judged right.** A clean record: verdict `adequate`, nothing named. A library effect (or pair): verdict '
        '`explained`, each hidden effect named, and nothing else named. A name is right for its family: a friction '
        '(Coulomb, smooth or Stribeck) by any friction candidate (a Stribeck friction may take two), a sensor\'s lag '
        '(delay or filter) by `sensor_delay` or `sensor_filter`, a current-sensor offset by `drive_voltage_error` '
        '(the same signature, V0 = -R I0) or its own name; the names table shows which exactly. An effect outside the '
        'library: nothing named. Parameters: the re-identified R, L, Km, m, B (and Fl) against the truth in '
        'their reported standard deviations, on the cases judged right (where the final model has the right '
        'structure); the truth is moved to the candidates\' parameterisation (centres at the mean measured '
        'position: see `expected` in the script).')
    add('')

    # ---------------------------------------------------------------- headline
    def split(pred):
        every = [r for r in rs if pred(r)]
        return [r for r in every if r['rate'] >= LOW_RATE], [r for r in every if r['rate'] < LOW_RATE], every

    def row(label, pred, good):
        hi, lo, every = split(pred)
        return f'| {label} | {_rate(hi, good)} | {_rate(lo, good)} | {_rate(every, good)} |'

    def coil_within(r):
        s = _sigmas(r)
        return all(abs(s[k]) <= 3.0 for k in COIL if k in s)

    numeric_bad = [r for r in ok if r.get('numeric_problems')]
    add('## Headline')
    add('')
    add('| measure | 5-20 kHz | 2-3 kHz | all |')
    add('|---|---|---|---|')
    add(row('clean records called adequate (nothing named)', lambda r: r['kind'] == 'clean', success))
    add(row('one library effect above 5x the floor: named and explained',
            lambda r: r['kind'] == 'single' and counted(r), success))
    add(row('... of them: named (right name, any verdict)', lambda r: r['kind'] == 'single' and counted(r),
            lambda r: not r.get('error') and bool(set(r['named']) & _accepted(r['hidden']))))
    add(row('a bench imperfection above 5x: named and explained',
            lambda r: r['kind'] == 'single' and counted(r) and r['hidden'][0] in BENCH, success))
    add(row('a pair, both above 5x: both named and explained', lambda r: r['kind'] == 'pair' and counted(r), success))
    add(row('an effect outside the library: nothing named', lambda r: r['kind'] == 'outside', success))
    add(row('re-identified R, L, Km, m, B all within 3 sigma (cases judged right)', right_model, coil_within))
    add(row('... and Fl within 3 sigma too', right_model,
            lambda r: coil_within(r) and abs(_sigmas(r).get('load_force', 0.0)) <= 3.0))
    add(row('cases with NaN/inf or a percentage below -100 % in the JSON or report text', lambda r: not r.get('error'),
            lambda r: bool(r.get('numeric_problems'))))
    add(row('cases where the workflow raised', lambda r: True, lambda r: bool(r.get('error'))))
    add('')
    add('The issue asks for: clean records never named, library effects above 5x named and explained in >= 95 %, '
        'pairs >= 90 %, parameters within 3 sigma >= 95 %, no NaN or impossible percentage anywhere.')
    add('')

    # ---------------------------------------------------------------- confusion matrix
    def label(r):
        if r['kind'] == 'clean':
            return 'clean'
        if r['kind'] == 'pair':
            return 'pair (any)'
        return r['hidden'][0] + (' (outside the library)' if r['kind'] == 'outside' else '')

    add('## Confusion matrix: hidden effect vs verdict and names')
    add('')
    add('All strengths (the weak ones included: an effect below the floor is rightly called adequate). '
        '"right": the hidden effect(s) named and nothing else.')
    add('')
    add(f'| hidden | n | {" | ".join(OUTCOMES)} |')
    add('|---|---|' + '---|' * len(OUTCOMES))
    labels = sorted({label(r) for r in rs}, key=lambda s: (s != 'clean', 'outside' in s, s == 'pair (any)', s))
    for lab in labels:
        group = [r for r in rs if label(r) == lab]
        counts = [sum(1 for r in group if outcome(r) == o) for o in OUTCOMES]
        add(f'| {lab} | {len(group)} | {" | ".join(str(c) if c else "." for c in counts)} |')
    add('')
    add('The same, above 5x the floor only (single effects and pairs):')
    add('')
    add(f'| hidden | n | {" | ".join(OUTCOMES)} |')
    add('|---|---|' + '---|' * len(OUTCOMES))
    for lab in labels:
        group = [r for r in rs if label(r) == lab and counted(r)]
        if group:
            counts = [sum(1 for r in group if outcome(r) == o) for o in OUTCOMES]
            add(f'| {lab} | {len(group)} | {" | ".join(str(c) if c else "." for c in counts)} |')
    add('')
    names = sorted({n for r in ok for n in r['named']})
    add('Hidden effect vs the names given (a case may give several; "none": nothing named):')
    add('')
    add(f'| hidden | n | {" | ".join(names)} | none |')
    add('|---|---|' + '---|' * (len(names) + 1))
    hidden_names = sorted({h for r in rs for h in r['hidden']}, key=lambda h: (h in OUTSIDE, h))
    for h in ['clean'] + hidden_names:
        group = [r for r in ok if (h == 'clean' and not r['hidden']) or h in r['hidden']]
        cells = [sum(1 for r in group if n in r['named']) for n in names]
        none = sum(1 for r in group if not r['named'])
        add(f'| {h}{" (outside)" if h in OUTSIDE else ""} | {len(group)} | '
            f'{" | ".join(str(c) if c else "." for c in cells)} | {none or "."} |')
    add('')

    # ---------------------------------------------------------------- by strength, by rate
    add('## Named and explained, by strength over the floor (one library effect)')
    add('')
    add(f'| effect | {" | ".join(b[2] for b in BINS)} |')
    add('|---|' + '---|' * len(BINS))
    for h in [x for x in LIBRARY if any(r['kind'] == 'single' and r['hidden'] == [x] for r in ok)]:
        cells = []
        for lo, hi, _ in BINS:
            group = [r for r in ok if r['kind'] == 'single' and r['hidden'] == [h] and lo <= r['strength'] < hi]
            k = sum(1 for r in group if success(r))
            ad = sum(1 for r in group if r['verdict'] == 'adequate')
            cells.append(f'{k}/{len(group)}' + (f' ({ad} adequate)' if ad else '') if group else '')
        add(f'| {h} | {" | ".join(cells)} |')
    add('')
    add('## By sample rate')
    add('')
    add('| rate | clean adequate | one effect > 5x right | pair > 5x right | outside: nothing named | '
        'R, L, Km, m, B within 3 sigma (judged right) | numeric problems | raised |')
    add('|---|---|---|---|---|---|---|---|')
    for rate in sorted({r['rate'] for r in rs}):
        g = [r for r in rs if r['rate'] == rate]
        add(f'| {rate / 1000:g} kHz | {_rate([r for r in g if r["kind"] == "clean"], success)} | '
            f'{_rate([r for r in g if r["kind"] == "single" and counted(r)], success)} | '
            f'{_rate([r for r in g if r["kind"] == "pair" and counted(r)], success)} | '
            f'{_rate([r for r in g if r["kind"] == "outside"], success)} | '
            f'{_rate([r for r in g if right_model(r)], coil_within)} | '
            f'{_rate([r for r in g if not r.get("error")], lambda r: bool(r.get("numeric_problems")))} | '
            f'{_rate(g, lambda r: bool(r.get("error")))} |')
    add('')
    add('## By actuator')
    add('')
    add('| actuator | clean adequate | one effect > 5x right | pair > 5x right | R, L, Km, m, B within 3 sigma |')
    add('|---|---|---|---|---|')
    for act in ACTUATORS:
        g = [r for r in rs if r['case']['actuator'] == act]
        if g:
            add(f'| {act} | {_rate([r for r in g if r["kind"] == "clean"], success)} | '
                f'{_rate([r for r in g if r["kind"] == "single" and counted(r)], success)} | '
                f'{_rate([r for r in g if r["kind"] == "pair" and counted(r)], success)} | '
                f'{_rate([r for r in g if right_model(r)], coil_within)} |')
    add('')

    # ---------------------------------------------------------------- parameters
    add('## Parameter errors in standard deviations')
    add('')
    add('Re-identified nominal parameters, (estimate - truth) / reported sigma, on the cases judged right '
        '(all rates; the 2-3 kHz ones apart in the second table):')
    add('')
    for title, pred in (('5-20 kHz', lambda r: r['rate'] >= LOW_RATE), ('2-3 kHz', lambda r: r['rate'] < LOW_RATE)):
        group = [r for r in rs if right_model(r) and pred(r)]
        add(f'{title}, {len(group)} cases:')
        add('')
        add('| parameter | n | median abs | 95th percentile abs | max abs | within 3 sigma | median abs error % |')
        add('|---|---|---|---|---|---|---|')
        for k in NOMINAL:
            z = np.array([abs(_sigmas(r)[k]) for r in group if k in _sigmas(r)])
            e = np.array([abs(r['nominal_error'][k]) for r in group if k in r.get('nominal_error', {})
                          and k != 'load_force'])
            if len(z):
                within = f'{int(np.sum(z <= 3))}/{len(z)} ({100 * np.mean(z <= 3):.1f} %)'
                err = f'{100 * np.median(e):.3g}' if len(e) else '(N, truth 0)'
                add(f'| {SYMBOL[k]} | {len(z)} | {np.median(z):.2f} | {_percentile(z, 95):.2f} | {z.max():.3g} | '
                    f'{within} | {err} |')
        add('')
    add('The named effects\' parameters against the truth (every case where the parameter was reported; "exact form": '
        'the candidate\'s form is the plant\'s; the others compare different forms, for information). A delay\'s '
        'or a filter\'s time constant has no standard deviation: it is right within 0.1 sample (delay) or 10 % '
        '(time constant; 25 % for a delay named for a filter):')
    add('')
    add('| parameter | exact form | n | median abs sigma | max abs sigma | within 3 sigma | median abs error % |')
    add('|---|---|---|---|---|---|---|')
    pnames = sorted({k for r in ok for k in r.get('effect_parameters', {})})
    for k in pnames:
        entries = [r['effect_parameters'][k] for r in ok if k in r.get('effect_parameters', {})]
        for exact in (True, False):
            group = [e for e in entries if e['exact'] == exact]
            if not group:
                continue
            z = np.array([abs(e['sigma']) for e in group if e['sigma'] is not None])
            rel = np.array([abs(e['value'] / e['truth'] - 1.0) for e in group if e['truth']])
            within = sum(1 for e in group if e['within'])
            zs = (f'{np.median(z):.2f} | {z.max():.3g}' if len(z) else 'no sigma | ')
            add(f'| {k} | {"yes" if exact else "no"} | {len(group)} | {zs} | {within}/{len(group)}'
                f'{"" if len(z) else " (within tolerance)"} | {100 * np.median(rel) if len(rel) else math.nan:.3g} |')
    add('')

    # ---------------------------------------------------------------- numeric problems
    add('## NaN, inf and impossible percentages')
    add('')
    if not numeric_bad:
        add('None in any case\'s JSON or report text.')
    else:
        kinds = {}
        for r in numeric_bad:
            for p in r['numeric_problems']:
                kinds.setdefault((p['where'], p['what']), []).append((r['seed'], p['text']))
        add(f'{len(numeric_bad)} of {len(ok)} cases. By where and what (cases; first seeds; an example):')
        add('')
        add('| where | what | cases | seeds | example |')
        add('|---|---|---|---|---|')
        for (where, what), found in sorted(kinds.items(), key=lambda kv: -len({s for s, _ in kv[1]})):
            s = sorted({seed for seed, _ in found})
            first = ', '.join(map(str, s[:8])) + (' ...' if len(s) > 8 else '')
            example = found[0][1].replace('|', '/')[:200]
            add(f'| `{where}` | {what} | {len(s)} | {first} | seed {found[0][0]}: "{example}" |')
    add('')

    # ---------------------------------------------------------------- misses
    add('## Every miss, by case')
    add('')
    add('Counted misses (the headline\'s populations: clean records, library effects and pairs above 5x, effects '
        'outside the library, cases that raised). Strength: size / noise_floor of the nominal model (for a pair, '
        'each effect\'s alone).')
    add('')
    add('| seed | rate | actuator | hidden | strength | verdict | named | what went wrong | rerun |')
    add('|---|---|---|---|---|---|---|---|---|')

    def miss_row(r):
        strength = ('' if r.get('error') else
                    ', '.join(f'{v:.3g}' for v in r['single_strength'].values()) if r['kind'] == 'pair'
                    else f'{r["strength"]:.3g}')
        return (f'| {r["seed"]} | {r["rate"] / 1000:g} kHz | {r["case"]["actuator"]} | '
                f'{_fmt_effects(r["case"]["effects"])} | {strength} | {r.get("verdict", "-")} | '
                f'{", ".join(r.get("named", [])) or "-"} | {_miss_reason(r)} | {_rerun(r)} |')

    for r in rs:
        judged = r.get('error') or r['kind'] in ('clean', 'outside') or counted(r)
        if judged and not success(r):
            add(miss_row(r))
    add('')
    add('Re-identified parameters beyond 3 sigma on cases judged right:')
    add('')
    add('| seed | rate | actuator | hidden | parameters beyond 3 sigma (sigma; error %) | rerun |')
    add('|---|---|---|---|---|---|')
    for r in rs:
        if right_model(r):
            s = _sigmas(r)
            beyond = [f'{SYMBOL[k]} {s[k]:+.1f} ({100 * r["nominal_error"][k]:+.3g} %)' if k != 'load_force' else
                      f'Fl {s[k]:+.1f} ({r["nominal_error"][k]:+.3g} N)' for k in NOMINAL if k in s and abs(s[k]) > 3]
            if beyond:
                add(f'| {r["seed"]} | {r["rate"] / 1000:g} kHz | {r["case"]["actuator"]} | '
                    f'{_fmt_effects(r["case"]["effects"])} | {"; ".join(beyond)} | {_rerun(r)} |')
    add('')
    add('Library effects at or below 5x the floor that were not named and explained (not counted; most are rightly '
        'adequate or too weak to resolve):')
    add('')
    weak = [r for r in ok if r['kind'] in ('single', 'pair') and not counted(r) and not success(r)]
    add(f'{len(weak)} cases: ' + ', '.join(f'{r["seed"]} ({"+".join(r["hidden"])}, {outcome(r)})' for r in weak))
    add('')
    add('Cases whose record could not be made (the independent plant\'s PID loop went unstable; not counted):')
    add('')
    add(', '.join(f'{r["seed"]} ({"+".join(r["hidden"]) or "clean"}, {r["case"]["actuator"]}, '
                  f'{r["rate"] / 1000:g} kHz: {r["error"][:80]})' for r in unstable) or 'none.')
    add('')
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text('\n'.join(lines))
    return Path(path)


# ---------------------------------------------------------------------------------------------- the command
def seed_list(text):
    """--seeds: whole numbers separated by commas."""
    try:
        return [int(s) for s in text.split(',') if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r} is not whole numbers separated by commas') from None


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--cases', type=int, default=240, help='number of cases (default 240)')
    parser.add_argument('--first-seed', type=int, default=1, help='the cases are seeds FIRST..FIRST+CASES-1')
    parser.add_argument('--workers', type=int, default=os.cpu_count() or 1,
                        help='dask worker processes (default: the core count)')
    parser.add_argument('--out', type=Path, default=DEFAULT_OUT, help=f'JSON-lines results (default {DEFAULT_OUT})')
    parser.add_argument('--doc', type=Path, default=DEFAULT_DOC, help=f'the report (default {DEFAULT_DOC})')
    parser.add_argument('--resume', action='store_true', help='keep the results in --out and run only the rest '
                        '(without it --out is started afresh)')
    parser.add_argument('--report-only', action='store_true', help='write --doc from --out, run nothing')
    parser.add_argument('--case', type=int, metavar='SEED', help='run the case of SEED alone, print its result')
    parser.add_argument('--seeds', type=seed_list, metavar='S,S,...',
                        help='the cases of these seeds instead of --first-seed/--cases (a rerun of some)')
    parser.add_argument('--duration', type=float, default=DURATION, help=f'record length in s (default {DURATION:g})')
    parser.add_argument('--code', default='HEAD', metavar='REVISION',
                        help='the suite\'s code to measure: a git revision (default HEAD: its committed packages and '
                        'tests/independent_plant.py, exported to out/sweep-code/), or "installed" for .venv\'s')
    parser.add_argument('--no-report-text', action='store_true',
                        help='check only the JSON for NaN/inf and percentages, not the Markdown report text')
    args = parser.parse_args(argv)
    if not args.report_only:
        code = use_code(args.code)
        print(f'measuring the code at {code}', file=sys.stderr)
    if args.case is not None:
        case = make_case(args.case, duration=args.duration)
        r = run_case(case, report=not args.no_report_text)
        print(json.dumps(r, indent=1))
        print(f'seed {args.case}: {case["kind"]} {_fmt_effects(case["effects"])} on {case["actuator"]} at '
              f'{case["rate"] / 1000:g} kHz -> {_summary(r)}; outcome: {outcome(r)}; '
              f'{"right" if success(r) else "MISS"}', file=sys.stderr)
        return 0 if not r.get('error') else 1
    seeds = args.seeds or list(range(args.first_seed, args.first_seed + args.cases))
    if args.report_only:
        results = _read(args.out)
    else:
        results = sweep(seeds, args.out, args.workers, resume=args.resume, duration=args.duration,
                        report=not args.no_report_text)
    command = ('.venv/bin/python scripts/discrepancy_sweep.py ' +
               ' '.join(a for a in (argv if argv is not None else sys.argv[1:]) if a != '--report-only')).strip()
    path = write_report(results, args.doc, command=command)
    print(f'{len(results)} cases; report written to {path}', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
