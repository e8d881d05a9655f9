"""Simulate and diagnose one case, and run many on dask.distributed workers, their results in a JSON-lines file."""
import json
import math
import os
import sys
import tempfile
import time
import traceback
from pathlib import Path

from .cases import DURATION, NOMINAL, ROOT, TESTS, make_case
from .classify import expected, numeric_problems


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
    """Record the case on tests/independent_plant.py (an RK4 plant written apart from the suite).

    Parameters
    ----------
    case : dict
        The case (`make_case`).
    effects : dict, optional
        {name: parameters} in place of the case's hidden effects.

    Returns
    -------
    tuple of (Recording, dict)
        The record and the plant's truth.
    """
    from independent_plant import record
    effects = case['effects'] if effects is None else effects
    delays = effects.get('sensor_delay')
    others = [(name, p) for name, p in effects.items() if name != 'sensor_delay']
    return record(case['duration'], params=case['params'], effects=others, seed=case['seed'],
                  delays=delays, sample_period=1.0 / case['rate'], substeps=substeps(dict(case, effects=effects)))


def report_text(diagnosis):
    """The Markdown of `emla discrepancy --report` for a diagnosis, without its figures where the suite measured
    has `report.markdown` (before it: the whole report, figures drawn)."""
    try:
        from emla_identification.discrepancy.locate import localise
        from emla_identification.discrepancy.report import markdown
        return markdown(diagnosis, localise(diagnosis.nominal))
    except (ImportError, TypeError, AttributeError):
        from emla_identification.discrepancy.report import write_report
        with tempfile.TemporaryDirectory() as directory:
            return Path(write_report(diagnosis, directory)).read_text()


def _strength(disagreement):
    """(size / noise_floor, power ratio) of the worse equation: the strength over the noise floor.

    Per equation the RMS of the low-band residual the sensor noise does not explain over the RMS the noise puts
    there (an amplitude ratio; the power ratio is about 1 + its square).
    """
    best = (0.0, 0.0)
    for d in disagreement.values():
        floor = d.get('noise_floor') or 0.0
        amplitude = d['size'] / floor if floor > 0 else math.inf
        best = max(best, (amplitude, d.get('ratio', math.nan)))
    return best


def _sigma(value, truth, std):
    """(value - truth) / std, or None where any of them is missing or the std is not finite and positive."""
    if value is None or truth is None or not std or not math.isfinite(std):
        return None
    return (value - truth) / std


def run_case(case, report=True):
    """Simulate and diagnose one case (never raises: a case that raises is a result, its one-line error).

    The case's strength is the nominal model's on the record (`disagreement_nominal`, see `_strength`); for a
    pair, each effect's own strength is measured the same way on the record with that effect alone (same seed,
    same parameters: two extra nominal-only diagnoses).

    Parameters
    ----------
    case : dict
        The case (`make_case`).
    report : bool
        Check the report's Markdown text for NaN/inf and impossible percentages too, not only the JSON.

    Returns
    -------
    dict
        The result, JSON-able: the verdict, the names, the strengths, the re-identified parameters' errors in
        their sigmas, the named effects' parameters against the truth, the numeric problems, the seconds taken.
    """
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


def read_results(path):
    """{seed: result} of a JSON-lines file (the last line of a seed wins; a torn last line is skipped; no file:
    none)."""
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


def summary(r):
    """One line of a result: its verdict, names and strength, or its error."""
    if r.get('error'):
        return f'FAILED {r["error"][:120]}'
    return f'{r["verdict"]} {",".join(r["named"]) or "-"} (strength {r["strength"]:.3g})'


def sweep(seeds, out, workers, resume=False, duration=DURATION, report=True):
    """Run the cases of some seeds on a dask.distributed LocalCluster, each result appended to a JSON-lines file
    as it finishes, the progress on stderr.

    Parameters
    ----------
    seeds : list of int
        The cases' seeds.
    out : str or Path
        The JSON-lines file (started afresh unless `resume`).
    workers : int
        Worker processes, one thread each.
    resume : bool
        Keep the results already in `out` and skip their seeds.
    duration : float
        Each record's length in s.
    report : bool
        Check each report's Markdown text too (`run_case`).

    Returns
    -------
    dict
        {seed: result} of every seed.
    """
    import logging

    from dask.distributed import Client, LocalCluster, as_completed

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = read_results(out) if resume else {}
    if not resume:
        out.write_text('')
    todo = [s for s in seeds if s not in done]
    print(f'{len(seeds)} cases, {len(seeds) - len(todo)} already in {out}, {len(todo)} to run on {workers} '
          f'worker(s)', file=sys.stderr, flush=True)
    if not todo:
        return {s: done[s] for s in seeds}
    # the workers import this package (and tests/independent_plant) by name
    os.environ['PYTHONPATH'] = os.pathsep.join([p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep) if p] +
                                               [str(ROOT), str(TESTS)])
    start = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=':0',
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        futures = {client.submit(run_case, make_case(s, duration=duration), report, pure=False,
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
                      f'{r["rate"] / 1000:g} kHz: {summary(r)} ({r.get("seconds", 0):.1f} s; elapsed '
                      f'{elapsed / 60:.1f} min, left ~{eta / 60:.1f} min)', file=sys.stderr, flush=True)
    return {s: done[s] for s in seeds}
