"""The solenoid's sensorless position (docs/physics.md §9.2): emla_identification.solenoid_observer on records of
the independent generator (tests/solenoid_generator.py), the model identified on seed 31, the observer on other
seeds from their voltage and current alone, against their position.

Run: .venv/bin/python scripts/observer_accuracy.py [first seed] [records] [plot.png]   (32, 8, no plot)

Prints, for R constant and rising 20 % over the record, offline (smoothed) and causal: the range over the records
of the RMS position error (um and % of the stroke), of the share of samples within 3 reported sigmas (all, in
flight), of R's end error in its sigmas and of the held samples; the plot is the first record's, R rising.
"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / 'tests'))
import solenoid_generator  # noqa: E402

from emla_cli.observer_plot import save_observer_plot  # noqa: E402
from emla_identification.solenoid import identify_solenoid  # noqa: E402
from emla_identification.solenoid_observer import observe_position, observer_model  # noqa: E402

RATE, SECONDS, RISE = 5000.0, 2.0, 0.2
STROKE = solenoid_generator.STOPS[1] - solenoid_generator.STOPS[0]


def figures(params, noise, recording, final, smooth):
    """(RMS error m, within 3 sigma all / in flight, R's end error in sigmas, held share) of one record."""
    u, i, x = (recording.signals[name] for name in ('voltage', 'current', 'position'))
    estimate = observe_position(params, recording.sample_period, u, i, current_noise=noise, smooth=smooth)
    error = estimate.position - x
    inside = np.abs(error) <= 3 * estimate.position_std
    flight = (x > solenoid_generator.STOPS[0]) & (x < solenoid_generator.STOPS[1])
    return (np.sqrt(np.mean(error ** 2)), inside.mean(), inside[flight].mean(),
            abs(estimate.resistance[-1] - final) / estimate.resistance_std[-1], estimate.held.mean()), estimate


def main(first=32, records=8, plot=None):
    bench, _ = solenoid_generator.record(duration=SECONDS, rate=RATE, seed=31)
    params, noise = observer_model(identify_solenoid(bench))
    for rise in (0.0, RISE):
        rows = {True: [], False: []}
        for seed in range(first, first + records):
            recording, truth = solenoid_generator.record(duration=SECONDS, rate=RATE, seed=seed,
                                                         resistance_rise=rise)
            final = truth['resistance'] * (1 + rise * (1 - 0.5 / len(recording)))
            for smooth in rows:
                row, estimate = figures(params, noise, recording, final, smooth)
                rows[smooth].append(row)
                if plot and smooth and rise and seed == first:
                    save_observer_plot(plot, recording.time, estimate, recording.signals['position'],
                                       f'independent generator, seed {seed}: R +{100 * rise:.0f} %, position '
                                       f'from the coil')
        for smooth, values in rows.items():
            rms, inside, flight, r_sigma, held = np.array(values).T
            print(f'R {"rising 20 %" if rise else "constant"}, {"smoothed" if smooth else "causal"}: '
                  f'{1e6 * rms.min():.1f}-{1e6 * rms.max():.1f} um ({100 * rms.min() / STROKE:.2f}-'
                  f'{100 * rms.max() / STROKE:.2f} %); within 3 sigma {100 * inside.min():.1f}-'
                  f'{100 * inside.max():.1f} % (in flight {100 * flight.min():.1f}-{100 * flight.max():.1f} %); '
                  f'R at the end within {r_sigma.max():.1f} sigma; held {100 * held.min():.1f}-'
                  f'{100 * held.max():.1f} %')


if __name__ == '__main__':
    args = sys.argv[1:]
    main(*(int(a) for a in args[:2]), *args[2:3])
