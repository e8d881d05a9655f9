"""Simulate a scenario in-process and record it as a bag."""
import sys

HELP = 'Simulate a scenario in-process and record it as a bag.'


def add_arguments(parser):
    parser.add_argument('scenario', nargs='?', default='default')


def run(args):
    print('emla: this command arrives with issue #4 and is not available yet', file=sys.stderr)
    return 3
