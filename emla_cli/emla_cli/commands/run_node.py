"""Run one node of the suite in this process, as `ros2 run PACKAGE NODE` does on a full ROS 2 install.

The node gets `--ros-args --params-file FILE` (a ROS 2 YAML params file; the defaults are in each package's
config/NODE.yaml). SIGINT/SIGTERM stop it cleanly (exit status 0).
"""
import re
import signal
import sys
from importlib.metadata import entry_points

from emla_core.errors import InputError

# The packages whose executables are nodes; each declares them once, in its setup.py (what `ros2 run` runs).
NODE_PACKAGES = ('emla_core', 'emla_sim', 'emla_identification', 'emla_control')
HELP = 'Run one node of the suite in this process.'


def description():
    return """\
Run one node of the suite in this process, as `ros2 run PACKAGE NODE` does on a full ROS 2 install.

The node reads a ROS 2 YAML params file (--params-file; each package's config/NODE.yaml holds the
defaults). SIGINT/SIGTERM stop it cleanly with exit status 0; bad parameters or an invalid params file give
one line and status 2, as does a section for no node of the suite or a parameter the node does not have (a
typo: the line names the closest known name).
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
        ros_args = ['--ros-args', '--params-file', args.params_file]
        _check_params_file(args.params_file, ros_args)
    for signum in (signal.SIGINT, signal.SIGTERM):  # until the node takes over: stop at once, cleanly
        signal.signal(signum, lambda *_: sys.exit(0))
    return known[args.node].load()([f'emla-{args.node}', *ros_args])


def _check_params_file(path, ros_args):
    """One line naming the file and its problem if it is not YAML or not a ROS 2 params file, where rclpy.init
    would fail with a traceback. Its structure is checked by rcl's own parser, without a ROS context."""
    import yaml
    from rclpy.utilities import remove_ros_args

    from emla_core.limits import read_document
    text = read_document(path, 'params file')   # bounded: a file of gigabytes is one line, not minutes
    try:
        list(yaml.compose_all(text, Loader=yaml.SafeLoader))  # the syntax only, as rcl reads it
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark
        raise InputError(f'{path}: not YAML: {exc.problem} (line {mark.line + 1}, column {mark.column + 1})') from None
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise InputError(f'{path}: unreadable params file: {" ".join(str(exc).split())}') from None
    except RecursionError:
        raise InputError(f'{path}: nested too deeply to be a params file') from None
    try:
        remove_ros_args(['emla', *ros_args])
    except RuntimeError as exc:  # rcl: "... Error: PROBLEM at line N, at SOURCE:LINE, at SOURCE:LINE"
        problem = re.search(r'Error: (.*?)\s*(, at /|$)', ' '.join(str(exc).split()))
        raise InputError(f'{path}: not a ROS 2 params file ({{NODE: {{ros__parameters: {{NAME: VALUE}}}}}}): '
                         f'{problem.group(1) if problem else str(exc)}') from None
