"""Run a closed-loop adaptive-control comparison (nominal / changed fixed / changed adaptive)."""
import sys

HELP = 'Run a closed-loop adaptive-control comparison (nominal / changed fixed / changed adaptive).'


def add_arguments(parser):
    parser.add_argument('name')


def run(args):
    print('emla: this command arrives with issue #5 and is not available yet', file=sys.stderr)
    return 3
