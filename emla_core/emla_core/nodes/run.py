"""Running nodes: one node as a process until it finishes or a signal stops it (exit status, the ready
line, one-line errors), and helper nodes of the commands in their own context."""
import contextlib
import os
import signal
import sys

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.experimental import EventsExecutor
from rclpy.signals import SignalHandlerOptions

from emla_core.errors import InputError
from emla_core.nodes.fastdds import use_fastdds_profiles
from emla_core.nodes.params_file import check_params, read_params_files


def run(node_class, args=None):
    """Run one node (an EmlaNode class) until it finishes or SIGINT/SIGTERM arrives, then its stop()
    (by default: wait for the acknowledgements of what it published); the exit status. Once the node is
    constructed (warmed up, subscribed) it prints 'NAME: ready (its ready())' on stderr.

    args: the command line with ROS arguments (default sys.argv)."""
    stopping = []
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stopping.append(True))
    use_fastdds_profiles()
    args = sys.argv if args is None else args
    try:
        files = read_params_files(args)
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except (InputError, RuntimeError) as error:   # RuntimeError: rcl cannot parse a params file or ROS argument
        print(f'{node_class.NAME}: error: {" ".join(str(error).split())}', file=sys.stderr)
        return 2
    try:
        node = node_class()
        check_params(node, files)
    except (InputError, ValueError, ParameterException) as error:
        print(f'{node_class.NAME}: error: {error}', file=sys.stderr)
        rclpy.shutdown()
        return 2
    executor = EventsExecutor()  # its spin_once() loop (not spin_until_future_complete) fires timers too
    executor.add_node(node)
    print(f'{node_class.NAME}: ready ({node.ready()})', file=sys.stderr)
    try:
        while not stopping and not node.finished:
            node.spin(executor)
        node.stop(executor)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    if node.error:
        print(f'{node_class.NAME}: error: {node.error}', file=sys.stderr)
        return 2
    return 0


@contextlib.contextmanager
def ros_node(name, domain=None):
    """(node, executor) of a helper rclpy node (`emla echo`, `play`, a launch's monitor) in its own context:
    in the environment's domain, or in `domain` with discovery on this host only (like the launched nodes).

    rclpy's signal handlers are not installed: SIGINT raises KeyboardInterrupt between spin_once() calls.
    """
    if domain is not None:
        os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'   # read by rclpy.init
    context = rclpy.Context()
    use_fastdds_profiles()
    rclpy.init(context=context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node(name, context=context, start_parameter_services=False)
    executor = EventsExecutor(context=context)
    executor.add_node(node)
    try:
        yield node, executor
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
