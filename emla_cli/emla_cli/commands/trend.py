"""`emla trend`: parses the options and calls emla_identification.fleet.trend (every recording identified on
Dask, time order, changes), then writes the JSON, the table and the plot through the suite's output checks."""
import math
import os
import sys
from pathlib import Path

from emla_core.errors import InputError

from .inputs import DATA_HELP, add_data_arguments, warn
from .numbers import add_number
from .output import add_force_argument, check_outputs, emit_json, write_output

HELP = 'Identify many recordings (a fleet, a long run) in parallel on Dask: parameter trends and their changes.'
COPPER = 0.00393   # 1/K: copper's temperature coefficient of resistance near 20 degC
CHECKPOINT_INTERVAL = 60.0   # s between the table's rewrites during a run (with --table)


def description():
    return """\
Identify every recording given (files, bag directories, directories of them at any depth, glob patterns) as
`emla identify` does, in parallel on a dask.distributed cluster, and follow each parameter across them in time
order; recordings without a time come last, by path. --start/--end take the same part of every record (s, on
its own time axis), and a record with missing samples is identified in segments, as by `emla identify`.

A recording's time (--time-from; the plot's abscissa and the JSON's "start", in s):
  start            its first sample's (default): its bag's stamps (the wall clock), or its time column
  mtime            its file's modification time (a bag directory's own)
  column:NAME      the first value of the CSV column NAME, an absolute time in s (e.g. column:unix_time)
  pattern:FORMAT   a date in its file name: FORMAT is a regular expression searched in the name, with %Y (4
                   digits), %m %d %H %M %S (2 each), %f (a fraction's digits) or %s (s since 1970) where the
                   name has them, read as UTC; e.g. 'pattern:run_%Y%m%dT%H%M%S' for run_20240131T120000.csv
CSV files' time columns often all begin at 0: when every recording has the same time, a warning says so
(they are then ordered by path and plotted at one time) and names --time-from.

Runs on an embedded local cluster of --workers processes (default: the cores), or sends the same work to a
running cluster with --scheduler tcp://HOST:PORT (`dask scheduler`, `dask worker`, or dask-jobqueue on
Slurm/PBS): the answer is the same. A recording that fails is listed under "failed" with its one-line error;
a worker that dies has its recordings redone by the others. A scheduler lost mid-run, or no worker for 60 s,
ends the run in one line (exit 2) with every recording identified so far in --table: --resume goes on from there.

Changes: a parameter that departs from its trend beyond its uncertainty for at least three recordings in a row
(a two-sided CUSUM), with where, the level before and after and the step in standard deviations.

The JSON (stdout unless --json): {"recordings": [{"path", "start", "duration", "parameters", "std", "fit",
"warnings"}], "changes": [{"parameter", "path", "index", "before", "after", "sigma"}], "failed": [{"path",
"error"}], "scheduler", "workers", "seconds"}. --table writes one row per recording (Parquet, or CSV by the
name), rewritten every minute during the run; --resume then skips the recordings already in it. --plot draws
each parameter against time with its band and the changes; with --reference R0@T0 (ohm@degC) the resistance
also as the coil's temperature (copper's 0.00393/K unless --alpha).

""" + DATA_HELP


def add_arguments(parser):
    parser.add_argument('paths', nargs='+', metavar='PATH',
                        help='recording, bag directory, directory of recordings, or glob pattern (quoted)')
    parser.add_argument('--actuator', default='moving_coil', metavar='FAMILY',
                        help='moving_coil (default) or solenoid (R, L0, a, g0, m, B, k, F0 as identify --actuator '
                        'solenoid)')
    parser.add_argument('--model', metavar='MODEL',
                        help='electrical, mechanical or full (default: from the signals, as identify)')
    parser.add_argument('--model-file', metavar='M.yaml',
                        help="identify this model file's structure (its effects too) on every recording")
    where = parser.add_mutually_exclusive_group()
    add_number(where, '--workers', low=1, high=4096, integer=True, metavar='N',
               help='processes of the embedded local Dask cluster (default: the cores)')
    where.add_argument('--scheduler', metavar='tcp://HOST:PORT',
                       help='send the work to this running dask.distributed scheduler instead')
    parser.add_argument('--time-from', default='start', metavar='HOW',
                        help="each recording's time: start (default: its first sample's), mtime (its file's), "
                             'column:NAME (a CSV column of absolute time in s) or pattern:FORMAT (a date in the '
                             'file name, as run_%%Y%%m%%dT%%H%%M%%S: see above)')
    parser.add_argument('--resume', action='store_true',
                        help='skip the recordings already in --table (from an earlier run) and keep their rows')
    parser.add_argument('--json', metavar='FILE', help='write the result here instead of stdout')
    parser.add_argument('--table', metavar='FILE.parquet|FILE.csv', help='one row per recording')
    parser.add_argument('--plot', metavar='FILE.png', help='each parameter against time, its band, the changes')
    parser.add_argument('--reference', metavar='R0@T0',
                        help='a resistance (ohm) at a known temperature (degC): plot R as the coil temperature')
    add_number(parser, '--alpha', low=1e-6, high=1.0, unit='1/K', metavar='A',
               help=f'temperature coefficient of the resistance (default {COPPER}, copper)')
    add_force_argument(parser)
    add_data_arguments(parser)


def run(args):
    reference = _reference(args.reference, args.alpha)
    if args.resume and not args.table:
        raise InputError('--resume needs --table FILE: the table of the earlier run, whose recordings are skipped')
    from emla_identification import fleet
    # Every input after the globs' expansion (their matches and the recordings in them: what the run reads), so
    # that no output lands on one; the run then takes exactly these recordings.
    recordings = fleet.find_recordings(args.paths)
    matches = [match for _, found in fleet.expand_paths(args.paths) for match in found]
    inputs = [*dict.fromkeys([*matches, *recordings]), args.model_file]
    resumed = args.resume and os.path.exists(args.table)
    check_outputs({'--json': args.json, '--plot': args.plot}, inputs, args.force)
    check_outputs({'--table': args.table}, inputs, args.force or resumed)
    if args.table and Path(args.table).suffix.lower() not in ('.parquet', '.csv'):
        raise InputError(f'--table {args.table}: name it .parquet (Parquet) or .csv (CSV)')
    structure = None
    if args.model_file:
        from emla_core.model_file import read
        structure = read(args.model_file).require('moving_coil', args.model_file)
    done = fleet.table_recordings(fleet.read_table(args.table)) if resumed else ()
    try:
        with _progress() as progress:
            result = fleet.trend(recordings, actuator=args.actuator, model=args.model, structure=structure,
                                 model_file=args.model_file,
                                 columns=args.columns, units=args.units, topics=args.topics,
                                 sample_period=args.sample_period, delimiter=args.delimiter, decimal=args.decimal,
                                 start=args.start, end=args.end, time_from=args.time_from,
                                 workers=args.workers, scheduler=args.scheduler, done=done, progress=progress,
                                 checkpoint=_checkpoint(args.table), checkpoint_interval=CHECKPOINT_INTERVAL)
    except fleet.ClusterLost as exc:   # the table holds every recording identified (trend's last checkpoint)
        kept = (f'the {len(exc.recordings)} identified are in --table {args.table}: run again with --resume to go '
                f'on from there' if args.table else 'give --table FILE to keep the recordings done and --resume')
        raise InputError(f'{exc}; {kept}') from None
    _summary(result)
    warn(result.warnings, 'trend')
    files = []
    if args.table:
        from emla_identification.fleet import write_table
        files.append((args.table, lambda temporary: write_table(result.table, temporary)))
    if args.plot:
        from emla_cli.trend_plot import save_trend_plot
        files.append((args.plot, lambda temporary: save_trend_plot(temporary, result, reference)))
    emit_json(result.to_dict(), args.json, files)
    return 0


def _reference(text, alpha):
    """(R0 ohm, T0 degC, alpha 1/K) of --reference R0@T0, or None; InputError in one line otherwise."""
    if text is None:
        if alpha is not None:
            raise InputError('--alpha goes with --reference R0@T0')
        return None
    try:
        r0, t0 = (float(v) for v in text.split('@'))
    except ValueError:
        raise InputError(f'--reference {text}: give a resistance and its temperature as R0@T0 (ohm@degC), '
                         f'e.g. 4.0@20') from None
    if not (math.isfinite(r0) and r0 > 0 and math.isfinite(t0) and -273.15 < t0 < 1000):
        raise InputError(f'--reference {text}: need R0 > 0 ohm and -273.15 < T0 < 1000 degC')
    return r0, t0, COPPER if alpha is None else alpha


class _progress:
    """progress(done, total, failed) as a bar on stderr when it is a terminal (tqdm: done/total, rate, failures)."""

    def __enter__(self):
        from tqdm import tqdm
        self.bar = tqdm(total=None, unit=' recordings', desc='trend', file=sys.stderr, leave=False,
                        disable=not sys.stderr.isatty())
        return self

    def __call__(self, done, total, failed):
        if self.bar.total != total:
            self.bar.total = total
        self.bar.set_postfix(failed=failed, refresh=False)
        self.bar.update(done - self.bar.n)

    def __exit__(self, *exc):
        self.bar.close()


def _checkpoint(table):
    """checkpoint(recordings): the table of the recordings so far, written in place (complete, by rename)."""
    if not table:
        return None

    def write(recordings):
        from emla_identification.fleet import recordings_table, write_table
        write_output(table, lambda temporary: write_table(recordings_table(recordings), temporary))
    return write


def _summary(result):
    """One line on stderr: how many, how fast, where, what failed."""
    new = len(result.recordings) - result.skipped + len(result.failed)
    rate = new / result.seconds if result.seconds > 0 else 0.0
    skipped = f', {result.skipped} from the table (--resume)' if result.skipped else ''
    print(f'emla trend: {len(result.recordings)} recordings identified, {len(result.failed)} failed{skipped}; '
          f'{new} in {result.seconds:.1f} s ({rate:.2f}/s) on {result.workers} workers ({result.scheduler}); '
          f'{len(result.changes)} changes', file=sys.stderr)

