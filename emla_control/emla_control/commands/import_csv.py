"""Convert a CSV recording into a rosbag2 directory (MCAP) with the suite topics."""
import sys

HELP = 'Convert a CSV recording into a rosbag2 directory (MCAP) with the suite topics.'


def add_arguments(parser):
    parser.add_argument('csv')
    parser.add_argument('bagdir')


def run(args):
    print('emla: this command arrives with issue #3 and is not available yet', file=sys.stderr)
    return 3
