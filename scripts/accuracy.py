"""The README's identification accuracy table: errors of `emla identify` (greybox.identify) against the true
parameters on closed-loop data the code has not seen (emla_sim.datasets: 10 kHz, 5 mA current noise, 1 um
position quantisation, unless noise-free). Run: .venv/bin/python scripts/accuracy.py (some seconds).
"""
import dataclasses
import sys

import numpy as np
from tqdm import tqdm

from emla_bench import scenarios
from emla_core.parameters import TABLE1
from emla_identification.greybox import identify
from emla_sim.datasets import TABLE2, closed_loop, force_driven, random_parameters

NAMES = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping', 'load_force')


def errors(recording, truth):
    """% for R, L, Km, m, B; N for Fl; and each error in reported standard deviations (NaN: not identified)."""
    result = identify(recording)
    error = np.array([result.parameters[n] - truth[n] if n in result.parameters else np.nan for n in NAMES])
    scale = np.array([abs(truth.get(n, np.nan)) / 100.0 if n != 'load_force' else 1.0 for n in NAMES])
    return error / scale, error / np.array([result.std.get(n, np.nan) for n in NAMES])


def row(label, runs, rms=False, sigmas=True):
    pct = np.abs(np.array([r[0] for r in runs]))
    sig = np.abs(np.array([r[1] for r in runs]))
    cells = ['' if np.isnan(pct[0, j]) else f'{np.sqrt(np.mean(pct[:, j] ** 2)):.3f} / {pct[:, j].max():.3f}'
             if rms else f'{pct[:, j].max():.3f}' for j in range(len(NAMES))]
    worst = f'{np.nanmax(sig):.1f}' if sigmas else ''
    tqdm.write(f'| {label} ({len(runs)} runs) | ' + ' | '.join(cells) + f' | {worst} |', file=sys.stdout)


def main():
    """The table's rows, each from its runs (a run: data and the true parameters), with progress on stderr."""
    rng = np.random.default_rng(2026)
    sets = [TABLE1.replace(load_force=5.0), TABLE1.replace(resistance=8.0, inductance=0.8e-3, load_force=-10.0)] \
        + [random_parameters(rng, load_force=rng.uniform(-10, 10)) for _ in range(5)]
    randoms = [random_parameters(rng, load_force=rng.uniform(-10, 10)) for _ in range(20)]
    controlled = [dataclasses.replace(scenarios.get('default'), seed=100 + seed, duration=2.0) for seed in range(4)]
    forced = [dict(mass=0.036, damping=2.0, load_force=0.0), dict(mass=0.072, damping=4.0, load_force=10.0),
              dict(mass=0.05, damping=3.0, load_force=-5.0)]
    rows = [  # (label, runs as functions giving (recording, truth), options of row())
        ('noise-free, max', [lambda p=p: (closed_loop(p, 0.5, current_noise=0.0, resolution=0.0)[0], p.physical())
                             for p in sets], dict(sigmas=False)),
        ('random sets around Table 1 (+-30 %, Fl +-10 N), 1 s each, rms / max',
         [lambda p=p, seed=seed: (closed_loop(p, 1.0, dither=0.2, seed=seed)[0], p.physical())
          for seed, p in enumerate(randoms)], dict(rms=True)),
        ("the paper's Table 2 conditions, 1 s each, max",
         [lambda c=c: (closed_loop(TABLE1.replace(**c), 1.0, seed=3)[0], TABLE1.replace(**c).physical())
          for c in TABLE2], {}),
        # the inverse-system controller feeds the measured current back at every sample
        ('Table 1 under the adaptive inverse-system controller at 10 kHz, 2 s each, max',
         [lambda s=s: (s.run_case('adaptive').recording, s.params.physical()) for s in controlled], {}),
        ('force/position data only (50 mN force noise), 1 s each, max',
         [lambda j=j, f=f: force_driven(**f, seed=j) for j, f in enumerate(forced)], {}),
    ]
    print('| data | R % | L % | Km % | m % | B % | Fl N | max error / std |')
    print('|---|---|---|---|---|---|---|---|')
    with tqdm(total=sum(len(runs) for _, runs, _ in rows), desc='accuracy', unit='run', file=sys.stderr) as bar:
        for label, runs, options in rows:
            results = []
            for run in runs:
                results.append(errors(*run()))
                bar.update()
            row(label, results, **options)


if __name__ == '__main__':
    main()
