"""The sweep's command: run one case, or many on dask workers, and write the full report and the headline page."""
import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from .cases import DURATION, ROOT, make_case
from .classify import outcome, success
from .report import COMMAND, format_effects, write_headline, write_report
from .run import read_results, run_case, summary, sweep
from .snapshot import commit, use_code

RESULTS = ROOT / 'sweep-results'   # ignored by git: the results and the full reports, one pair per commit
HEADLINE = ROOT / 'docs' / 'discrepancy-sweep.md'
USAGE = f"""\
Every case comes from one integer seed (nothing else): the actuator (one of ACTUATORS, each parameter drawn
+-30 %), the sample rate (RATES), the kind (a clean record, one library effect, a random pair of them, or an
effect the library lacks), the effects' strengths (log-uniform over LEVELS, from below the noise floor to
strong) and the record's noise. Each record is made by tests/independent_plant.py (an RK4 plant written apart
from the suite) and diagnosed by emla_identification.discrepancy.diagnose; the verdicts, the names and the
parameters are judged against the truth. From the repository's root:

    {COMMAND} --case SEED [--code COMMIT]        # one case alone, its full JSON
    {COMMAND} --cases 240 --workers 2            # the sweep (make discrepancy-sweep)
    {COMMAND} --cases 240 --resume               # go on after an interruption
    {COMMAND} --report-only                      # rewrite the pages from the results

The cases run on dask.distributed (a LocalCluster of --workers processes, one thread each); each result is
appended to the JSON-lines file --out as it finishes (a case that raises is a result too: its one-line error),
the progress shown on stderr. The full report goes to --doc, beside the results; the headline page to
--headline (docs/discrepancy-sweep.md). The suite measured is the one committed at --code (default HEAD),
exported to out/sweep-code/COMMIT, so that others reinstalling .venv or editing the work tree meanwhile change
nothing; `--code installed` measures the suite this Python imports.
"""


def seed_list(text):
    """--seeds: whole numbers separated by commas."""
    try:
        return [int(s) for s in text.split(',') if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r} is not whole numbers separated by commas') from None


def _shown(path):
    """A path as the pages show it: from the repository's root when inside it."""
    path = Path(path).resolve()
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def main(argv=None):
    """Run the command.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: the command line's).

    Returns
    -------
    int
        The exit status: 0, or 1 when the case run alone (--case) raised.
    """
    parser = argparse.ArgumentParser(prog='python -m scripts.discrepancy_sweep', description=__doc__, epilog=USAGE,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--cases', type=int, default=240, help='number of cases (default 240)')
    parser.add_argument('--first-seed', type=int, default=1, help='the cases are seeds FIRST..FIRST+CASES-1')
    parser.add_argument('--workers', type=int, default=os.cpu_count() or 1,
                        help='dask worker processes (default: the core count)')
    parser.add_argument('--out', type=Path, help=f'JSON-lines results (default {_shown(RESULTS)}/COMMIT.jsonl, '
                        'COMMIT the --code measured, 7 characters, or "installed")')
    parser.add_argument('--doc', type=Path, help='the full report (default: --out with the suffix .md)')
    parser.add_argument('--headline', type=Path, default=HEADLINE,
                        help=f'the headline page (default {_shown(HEADLINE)})')
    parser.add_argument('--no-headline', action='store_true', help='write the full report alone, not --headline')
    parser.add_argument('--resume', action='store_true', help='keep the results in --out and run only the rest '
                        '(without it --out is started afresh)')
    parser.add_argument('--report-only', action='store_true', help='write the pages from --out, run nothing')
    parser.add_argument('--case', type=int, metavar='SEED', help='run the case of SEED alone, print its result')
    parser.add_argument('--seeds', type=seed_list, metavar='S,S,...',
                        help='the cases of these seeds instead of --first-seed/--cases (a rerun of some)')
    parser.add_argument('--duration', type=float, default=DURATION, help=f'record length in s (default {DURATION:g})')
    parser.add_argument('--code', default='HEAD', metavar='REVISION',
                        help='the suite\'s code to measure: a git revision (default HEAD: its committed packages and '
                        'tests/independent_plant.py, exported to out/sweep-code/), or "installed" for the suite '
                        'this Python imports')
    parser.add_argument('--no-report-text', action='store_true',
                        help='check only the JSON for NaN/inf and percentages, not the Markdown report text')
    args = parser.parse_args(argv)
    if not args.report_only:
        code = use_code(args.code)
        print(f'measuring the code at {code}', file=sys.stderr)
    elif args.out is None:   # the results of the code --code names
        try:
            code = args.code if args.code == 'installed' else commit(args.code)
        except subprocess.CalledProcessError:
            parser.error(f'--code {args.code} is not a commit of the repository: give --out')
    if args.case is not None:
        case = make_case(args.case, duration=args.duration)
        r = run_case(case, report=not args.no_report_text)
        print(json.dumps(r, indent=1))
        print(f'seed {args.case}: {case["kind"]} {format_effects(case["effects"])} on {case["actuator"]} at '
              f'{case["rate"] / 1000:g} kHz -> {summary(r)}; outcome: {outcome(r)}; '
              f'{"right" if success(r) else "MISS"}', file=sys.stderr)
        return 0 if not r.get('error') else 1
    out = args.out or RESULTS / f'{code if code == "installed" else code[:7]}.jsonl'
    doc = args.doc or out.with_suffix('.md')
    seeds = args.seeds or list(range(args.first_seed, args.first_seed + args.cases))
    if args.report_only:
        results = read_results(out)
    else:
        results = sweep(seeds, out, args.workers, resume=args.resume, duration=args.duration,
                        report=not args.no_report_text)
    command = (f'{COMMAND} ' + ' '.join(a for a in (argv if argv is not None else sys.argv[1:])
                                        if a != '--report-only')).strip()
    path = write_report(results, doc, command=command)
    print(f'{len(results)} cases; report written to {path}', file=sys.stderr)
    if not args.no_headline:
        headline = write_headline(results, args.headline, command=command, full=_shown(path))
        print(f'headline written to {headline}', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
