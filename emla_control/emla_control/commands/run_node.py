"""Run one node of the suite (plant, sensor, identifier, controller)."""
import sys

HELP = 'Run one node of the suite (plant, sensor, identifier, controller).'


def add_arguments(parser):
    parser.add_argument('node')


def run(args):
    print('emla: this command arrives with issue #4 and is not available yet', file=sys.stderr)
    return 3
