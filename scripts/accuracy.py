"""The README's identification accuracy table: errors of `emla identify` (greybox.identify) against the true
parameters on closed-loop data the code has not seen (emla_sim.datasets: 10 kHz, 5 mA current noise, 1 um
position quantisation, unless noise-free). Run: .venv/bin/python scripts/accuracy.py (some seconds).
"""
import dataclasses

import numpy as np

from emla_control import scenarios
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
    print(f'| {label} ({len(runs)} runs) | ' + ' | '.join(cells) + f' | {worst} |', flush=True)


def main():
    print('| data | R % | L % | Km % | m % | B % | Fl N | max error / std |')
    print('|---|---|---|---|---|---|---|---|')
    rng = np.random.default_rng(2026)
    sets = [TABLE1.replace(load_force=5.0), TABLE1.replace(resistance=8.0, inductance=0.8e-3, load_force=-10.0)] \
        + [random_parameters(rng, load_force=rng.uniform(-10, 10)) for _ in range(5)]
    row('noise-free, max', [errors(closed_loop(p, 0.5, current_noise=0.0, resolution=0.0)[0], p.physical())
                            for p in sets], sigmas=False)
    runs = []
    for seed in range(20):
        p = random_parameters(rng, load_force=rng.uniform(-10, 10))
        runs.append(errors(closed_loop(p, 1.0, dither=0.2, seed=seed)[0], p.physical()))
    row('random sets around Table 1 (+-30 %, Fl +-10 N), 1 s each, rms / max', runs, rms=True)
    row("the paper's Table 2 conditions, 1 s each, max",
        [errors(closed_loop(TABLE1.replace(**c), 1.0, seed=3)[0], TABLE1.replace(**c).physical()) for c in TABLE2])
    runs = []
    for seed in range(4):  # the inverse-system controller feeds the measured current back at every sample
        scenario = dataclasses.replace(scenarios.get('default'), seed=100 + seed, duration=2.0)
        runs.append(errors(scenario.run_case('adaptive').recording, scenario.params.physical()))
    row('Table 1 under the adaptive inverse-system controller at 10 kHz, 2 s each, max', runs)
    sets = [dict(mass=0.036, damping=2.0, load_force=0.0), dict(mass=0.072, damping=4.0, load_force=10.0),
            dict(mass=0.05, damping=3.0, load_force=-5.0)]
    row('force/position data only (50 mN force noise), 1 s each, max',
        [errors(*force_driven(**s, seed=j)) for j, s in enumerate(sets)])


if __name__ == '__main__':
    main()
