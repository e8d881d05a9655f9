"""Run one node of the suite in this process, as `ros2 run PACKAGE NODE` does on a full ROS 2 install.

The node gets `--ros-args --params-file FILE` (a ROS 2 YAML params file; the defaults are in each package's
config/NODE.yaml). SIGINT/SIGTERM stop it cleanly (exit status 0).
"""
import signal
import sys
from importlib.metadata import entry_points
from pathlib import Path

from emla_core.errors import InputError

# The packages whose executables are nodes; each declares them once, in its setup.py (what `ros2 run` runs).
NODE_PACKAGES = ('emla_core', 'emla_sim', 'emla_identification', 'emla_control')
HELP = 'Run one node of the suite in this process.'


def description():
    return """\
Run one node of the suite in this process, as `ros2 run PACKAGE NODE` does on a full ROS 2 install.

The node reads a ROS 2 YAML params file (--params-file; each package's config/NODE.yaml holds the
defaults). SIGINT/SIGTERM stop it cleanly with exit status 0; bad parameters give one line and status 2.
"""


def nodes():
    """{node name: console-script entry point} of the installed node packages."""
    return {ep.name: ep for ep in entry_points(group='console_scripts')
            if ep.dist is not None and ep.dist.name.replace('-', '_') in NODE_PACKAGES}


def add_arguments(parser):
    parser.add_argument('node', metavar='NODE', help=f'one of {", ".join(sorted(nodes()))}')
    parser.add_argument('--params-file', metavar='FILE',
                        help='ROS 2 YAML parameters file (defaults: config/NODE.yaml of the node\'s package)')


def run(args):
    known = nodes()
    if args.node not in known:
        raise InputError(f'unknown node {args.node!r}; choose one of {", ".join(sorted(known))}')
    ros_args = []
    if args.params_file is not None:
        if not Path(args.params_file).is_file():
            raise InputError(f'{args.params_file}: no such params file')
        ros_args = ['--ros-args', '--params-file', args.params_file]
    for signum in (signal.SIGINT, signal.SIGTERM):  # until the node takes over: stop at once, cleanly
        signal.signal(signum, lambda *_: sys.exit(0))
    return known[args.node].load()([f'emla-{args.node}', *ros_args])
