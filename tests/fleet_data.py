"""A fleet of recordings with known parameters, from tests/independent_data.py's actuator (simulated exactly,
independently of emla_sim): one short CSV per hour of a long run, its resistance rising as a coil warms and its
damping stepping at a chosen recording, each file's time column starting at its hour (so a trend orders them).
"""
import numpy as np
from independent_data import TRUTH, simulate


def fleet_truth(count, *, rise=0.0, thermal_hours=30.0, step_at=None, step=1.3, every_hours=1.0):
    """[{name: true value}] of `count` recordings one every `every_hours`: the resistance R0 (1 + rise (1 -
    exp(-t / thermal_hours))), the damping times `step` from recording `step_at` on (None: no step)."""
    out = []
    for k in range(count):
        hours = k * every_hours
        truth = dict(TRUTH)
        truth['resistance'] = TRUTH['resistance'] * (1.0 + rise * (1.0 - np.exp(-hours / thermal_hours)))
        if step_at is not None and k >= step_at:
            truth['damping'] = TRUTH['damping'] * step
        out.append(truth)
    return out


def write_fleet(directory, truths, *, duration=0.3, sample_period=2e-4, every_hours=1.0, seed=100):
    """One CSV per truth in `directory` (run_000.csv, ...): t (s, from its hour), voltage, current, position in
    SI; the paths."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for k, truth in enumerate(truths):
        t, voltage, current, position = simulate(duration=duration, sample_period=sample_period, seed=seed + k,
                                                 truth=truth)
        start = k * every_hours * 3600.0
        path = directory / f'run_{k:03d}.csv'
        table = np.column_stack((start + t, voltage, current, position))
        np.savetxt(path, table, delimiter=',', header='t,voltage,current,position', comments='', fmt='%.15g')
        paths.append(path)
    return paths
