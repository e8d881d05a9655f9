"""Run the plant, sensor, identifier and controller nodes as a ROS 2 graph and record a bag."""
import sys

HELP = 'Run the plant, sensor, identifier and controller nodes as a ROS 2 graph and record a bag.'


def add_arguments(parser):
    parser.add_argument('scenario', nargs='?', default='default')


def run(args):
    print('emla: this command arrives with issue #4 and is not available yet', file=sys.stderr)
    return 3
