"""Identify actuator parameters (grey-box) or an ARX model from a CSV file or a bag."""
import sys

HELP = 'Identify actuator parameters (grey-box) or an ARX model from a CSV file or a bag.'


def add_arguments(parser):
    parser.add_argument('data')


def run(args):
    print('emla: this command arrives with issue #3 and is not available yet', file=sys.stderr)
    return 3
