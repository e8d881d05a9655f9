"""Run one node of the suite in this process: `emla run NODE [--params-file FILE]`.

The node gets `--ros-args --params-file FILE` (a ROS 2 YAML params file; defaults in each package's
config/<node>.yaml). SIGINT/SIGTERM stop it cleanly (exit status 0).
"""
import importlib
import signal
import sys
from pathlib import Path

from emla_core.errors import InputError

HELP = 'Run one node of the suite (plant, sensor, identifier, controller, recorder).'
NODES = {
    'plant': 'emla_sim.nodes.plant_node',
    'sensor': 'emla_sim.nodes.sensor_node',
    'identifier': 'emla_identification.nodes.identifier_node',
    'controller': 'emla_control.nodes.controller_node',
    'recorder': 'emla_core.nodes.recorder_node',
}


def add_arguments(parser):
    parser.add_argument('node', metavar='NODE', help=f'one of {", ".join(NODES)}')
    parser.add_argument('--params-file', metavar='FILE', help='ROS 2 YAML parameters file')


def run(args):
    if args.node not in NODES:
        raise InputError(f'unknown node {args.node!r}; choose one of {", ".join(NODES)}')
    ros_args = []
    if args.params_file is not None:
        if not Path(args.params_file).is_file():
            raise InputError(f'{args.params_file}: no such params file')
        ros_args = ['--ros-args', '--params-file', args.params_file]
    for signum in (signal.SIGINT, signal.SIGTERM):  # until the node takes over: stop at once, cleanly
        signal.signal(signum, lambda *_: sys.exit(0))
    return importlib.import_module(NODES[args.node]).main([f'emla-{args.node}', *ros_args])
