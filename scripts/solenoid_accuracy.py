"""The solenoid identification's accuracy (docs/physics.md §9.1): emla_identification.solenoid on records of the
independent generator (tests/solenoid_generator.py: flux state by scipy DOP853, end stops by events, 5 mA current
noise, a 4.9 mA current ADC step, 1 um position steps).

Run: .venv/bin/python scripts/solenoid_accuracy.py [rate Hz] [seconds] [first seed] [records]   (5 kHz, 2 s, 1, 6)

Prints a Markdown row: per parameter the largest |error| in % over the records and, in brackets, the largest
|error| in reported standard deviations; then the fit ratios' range and the records with a warning.
"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / 'tests'))
import solenoid_generator  # noqa: E402

from emla_identification.solenoid import identify_solenoid  # noqa: E402


def main(rate=5000.0, duration=2.0, first=1, records=6):
    errors, sigmas, ratios, warned = [], [], [], 0
    for seed in range(first, first + records):
        recording, truth = solenoid_generator.record(duration=duration, rate=rate, seed=seed)
        result = identify_solenoid(recording)
        errors.append([100 * (result.parameters[k] / v - 1) for k, v in truth.items()])
        sigmas.append([(result.parameters[k] - v) / result.std[k] for k, v in truth.items()])
        ratios += [f.ratio for f in result.fit.values()]
        warned += bool(result.warnings())
    worst, spread = np.abs(errors).max(axis=0), np.abs(sigmas).max(axis=0)
    cells = ' | '.join(f'{e:.2g} % ({s:.1f})' for e, s in zip(worst, spread))
    print(f'| {rate:g} Hz, {records} x {duration:g} s | {cells} |')
    print(f'fit ratios {min(ratios):.2f}-{max(ratios):.2f}; warned {warned}/{records}')


if __name__ == '__main__':
    args = sys.argv[1:]
    main(*(float(a) if j < 2 else int(a) for j, a in enumerate(args)))
