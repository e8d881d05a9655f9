"""The identification's accuracy against the sample rate (README, docs/physics.md §3): `emla identify`
(greybox.identify) on the Table 1 actuator logged at several rates by a generator independent of emla_sim
(tests/independent_data.py: the linear plant discretised exactly by scipy.signal.cont2discrete, PD position loop
with dither, 5 mA current noise, 1 um position quantisation), 1 s per record.

Run: .venv/bin/python scripts/sample_rates.py [rates in Hz, comma-separated] [seeds]   (about a minute)

Prints a Markdown table: per rate and parameter the largest |error| in % over the seeds and, in brackets, the
largest |error| in reported standard deviations; the last column counts the records with a warning (an
equation that does not fit, or an unresolved parameter).
"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / 'tests'))
import independent_data  # noqa: E402

from emla_identification.greybox import identify  # noqa: E402

TRUTH = {'resistance': 4.0, 'inductance': 1.6e-3, 'emf_constant': 10.8, 'mass': 0.036, 'damping': 2.0,
         'load_force': 0.0}   # Table 1
COIL = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping')
SYMBOLS = ('R', 'L', 'Km', 'm', 'B')


def main(rates=(333, 500, 1000, 2000, 5000, 10000, 20000), seeds=range(1, 7)):
    time_constant = TRUTH['inductance'] / TRUTH['resistance']
    print(f'| rate | Ts / (L/R) | {" | ".join(SYMBOLS)} | warned |')
    print('|---' * (len(SYMBOLS) + 3) + '|')
    for rate in rates:
        ts = 1.0 / rate
        errors, sigmas, warned = [], [], 0
        for seed in seeds:
            _, u, i, x = independent_data.simulate(duration=1.0, sample_period=ts, seed=seed, truth=TRUTH)
            result = identify(sample_period=ts, voltage=u, current=i, position=x, points=1)
            errors.append([result.parameters[n] / TRUTH[n] - 1.0 for n in COIL])
            sigmas.append([abs(result.parameters[n] - TRUTH[n]) / result.std[n] for n in COIL])
            warned += bool(result.warnings())
        errors, sigmas = np.abs(errors), np.array(sigmas)
        cells = [f'{100 * errors[:, j].max():.3g} ({sigmas[:, j].max():.1f})' for j in range(len(COIL))]
        print(f'| {rate:g} Hz | {ts / time_constant:.3g} | {" | ".join(cells)} | {warned}/{len(seeds)} |', flush=True)


if __name__ == '__main__':
    main(tuple(float(r) for r in sys.argv[1].split(',')) if len(sys.argv) > 1 else
         (333, 500, 1000, 2000, 5000, 10000, 20000),
         range(1, int(sys.argv[2]) + 1) if len(sys.argv) > 2 else range(1, 7))
