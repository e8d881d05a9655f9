"""The issue-23 demonstration: 200 recordings from the independent generator (tests/fleet_data.py: 0.3 s at
5 kHz each, one an hour; R rising 26.7 % with a 60 h thermal time constant, the damping x1.3 from recording
120; one corrupt file among them) trended on the embedded Dask cluster, then checked against the truth; and
the same on a fleet without a change. About 5 minutes on 2 cores.

    .venv/bin/python scripts/trend_fleet.py [WORKERS]
"""
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / 'tests'))
from fleet_data import fleet_truth, write_fleet  # noqa: E402

COUNT, STEP_AT = 200, 120


def main(workers=None):
    from emla_identification import trend
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        truths = fleet_truth(COUNT, rise=0.267, thermal_hours=60.0, step_at=STEP_AT, step=1.3)
        write_fleet(folder / 'step', truths)
        (folder / 'step' / 'run_corrupt.csv').write_text('t,voltage,current,position\n0,1\n')
        quiet = fleet_truth(COUNT)
        write_fleet(folder / 'quiet', quiet, seed=5000)
        started = time.monotonic()
        result = trend([folder / 'step'], workers=workers)
        worst = max(abs(r['parameters']['resistance'] / t['resistance'] - 1)
                    for r, t in zip(result.recordings, truths))
        print(f'{len(result.recordings)} identified, failed: {[f["path"] for f in result.failed]}, '
              f'{result.seconds:.0f} s on {result.workers} workers ({len(result.recordings) / result.seconds:.2f}/s)')
        print(f'largest R error {100 * worst:.3f} %; changes: '
              f'{[(c["parameter"], c["index"], round(c["sigma"])) for c in result.changes]} (step at {STEP_AT})')
        calm = trend([folder / 'quiet'], workers=workers)
        print(f'fleet without a change: {len(calm.recordings)} identified, changes: {calm.changes}; '
              f'{time.monotonic() - started:.0f} s in all')


if __name__ == '__main__':
    main(int(sys.argv[1]) if len(sys.argv) > 1 else None)
