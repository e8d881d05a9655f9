"""`python -m benchmarks [NAME ...] [--json FILE]`: run the benchmarks, print a table, write JSON."""
import argparse
import importlib
import sys

from benchmarks.harness import print_table, write_json

SUITES = ['rls', 'offline', 'loop', 'graph', 'discrepancy', 'trend', 'observer']


def main():
    parser = argparse.ArgumentParser(prog='python -m benchmarks', description=__doc__)
    parser.add_argument('names', nargs='*', metavar='NAME', help=f'suites to run: {", ".join(SUITES)} (default: all)')
    parser.add_argument('--json', default='bench-results.json', help='where to write the results')
    args = parser.parse_args()
    unknown = set(args.names) - set(SUITES)
    if unknown:
        parser.error(f'unknown suite(s) {", ".join(sorted(unknown))}; choose from {", ".join(SUITES)}')
    rows = []
    for name in args.names or SUITES:
        print(f'[bench] {name} ...', file=sys.stderr, flush=True)
        rows += importlib.import_module(f'benchmarks.bench_{name}').run()
    print_table(rows)
    write_json(rows, args.json)
    print(f'\nwritten: {args.json}')


if __name__ == '__main__':
    main()
