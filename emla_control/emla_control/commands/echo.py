"""Print the messages of a topic as YAML."""
import sys

HELP = 'Print the messages of a topic as YAML.'


def add_arguments(parser):
    parser.add_argument('topic')


def run(args):
    print('emla: this command arrives with issue #4 and is not available yet', file=sys.stderr)
    return 3
