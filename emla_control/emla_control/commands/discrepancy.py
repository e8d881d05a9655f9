"""Find what the model is missing: name the effect, add it, show the gap shrink."""
import sys

HELP = 'Find what the model is missing: name the effect, add it, show the gap shrink.'


def add_arguments(parser):
    parser.add_argument('data')


def run(args):
    print('emla: this command arrives with issue #6 and is not available yet', file=sys.stderr)
    return 3
