"""Print the messages of a topic as YAML documents, like `ros2 topic echo` (arrays shortened unless -f).

The type and the QoS come from the topic's publishers (reliable / transient local when all of them are).
Ends after --count messages, or with status 1 when no message came for --timeout seconds.
"""
import array
import os
import re
import sys
import time

import numpy as np
import yaml

from emla_core.errors import InputError

from .numbers import add_number

HELP = 'Print the messages of a topic as YAML.'
MAX_COUNT = 10**9       # messages, and elements shown
MAX_TIMEOUT = 86400.0   # s: a day
MAX_SHOWN = 60          # characters of a refused topic name shown


def description():
    return """\
Print the messages of a topic as YAML documents, like `ros2 topic echo` (long arrays shortened unless -f).

The message type and QoS are taken from the topic's publishers. Ends after --count messages, or with exit
status 1 when no message came for --timeout seconds.
"""


def add_arguments(parser):
    parser.add_argument('topic', help='topic name, e.g. /emla/parameters')
    add_number(parser, '--count', '-n', low=0, high=MAX_COUNT, integer=True, default=0, metavar='N',
               help='exit after N messages (default: until interrupted)')
    add_number(parser, '--timeout', low=0, high=MAX_TIMEOUT, open_low=True, unit='s', default=10.0, metavar='S',
               help='give up when no message came for S seconds (default 10)')
    add_number(parser, '--truncate-length', '-l', low=0, high=MAX_COUNT, integer=True, default=128, metavar='K',
               help='show the first K elements of longer arrays and strings (default 128)')
    parser.add_argument('--full-length', '-f', action='store_true', help='print arrays and strings in full')


def to_plain(value, limit=None):
    """A message as nested dicts/lists of Python scalars; sequences and strings cut after `limit` items."""
    if hasattr(value, 'get_fields_and_field_types'):
        return {name: to_plain(getattr(value, name), limit) for name in value.get_fields_and_field_types()}
    if isinstance(value, (list, tuple, array.array, np.ndarray, bytes)):
        cut = limit is not None and len(value) > limit
        items = [to_plain(v, limit) for v in (value[:limit] if cut else value)]
        return items + ['...'] if cut else items
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, str) and limit is not None and len(value) > limit:
        return value[:limit] + '...'
    return value


def check_topic(name, node='emla_echo'):
    """InputError (one line) unless `name` is a valid ROS topic name, as written and as expanded for the
    `node` (in the root namespace): the full name's rules too, such as its length."""
    from rclpy.exceptions import InvalidTopicNameException
    from rclpy.expand_topic_name import expand_topic_name
    from rclpy.validate_full_topic_name import validate_full_topic_name
    from rclpy.validate_topic_name import validate_topic_name
    try:
        validate_topic_name(name)
        validate_full_topic_name(expand_topic_name(name, node, '/'))
    except (InvalidTopicNameException, ValueError) as exc:
        reason = str(exc).splitlines()[0].removeprefix('Invalid topic name: ').rstrip(':')
        reason = re.sub(r"'(\d+)U - (\d+)U'", lambda m: f'{int(m[1]) - int(m[2])} characters', reason)
        shown = repr(name) if len(name) <= MAX_SHOWN else f'{name[:MAX_SHOWN]!r}... ({len(name)} characters)'
        raise InputError(f'{shown} is not a topic name: {reason}') from None


def subscriber_qos(publishers):
    """A QoS that matches every publisher: reliable / transient local only if all of them are."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    profiles = [p.qos_profile for p in publishers]
    reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in profiles)
    latched = all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in profiles)
    return QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def run(args):
    from emla_core.messages import message_class
    from emla_core.nodes.run import ros_node

    check_topic(args.topic)
    limit = None if args.full_length else args.truncate_length
    received = 0
    with ros_node('emla_echo') as (node, executor):
        deadline = time.monotonic() + args.timeout
        while not (publishers := node.get_publishers_info_by_topic(args.topic)):
            if time.monotonic() > deadline:
                print(f'emla echo: no publisher of {args.topic} within {args.timeout:g} s '
                      f'(ROS_DOMAIN_ID={os.environ.get("ROS_DOMAIN_ID", "0")})', file=sys.stderr)
                return 1
            time.sleep(0.05)

        def show(msg):
            nonlocal received
            if args.count and received >= args.count:   # one spin may hand over several: --count N prints N
                return
            received += 1
            sys.stdout.write(yaml.safe_dump(to_plain(msg, limit), default_flow_style=False, sort_keys=False))
            sys.stdout.write('---\n')
            sys.stdout.flush()

        node.create_subscription(message_class(publishers[0].topic_type), args.topic, show,
                                 subscriber_qos(publishers))
        deadline = time.monotonic() + args.timeout
        while not args.count or received < args.count:
            seen = received
            executor.spin_once(timeout_sec=0.1)
            if received != seen:
                deadline = time.monotonic() + args.timeout
            elif time.monotonic() > deadline:
                print(f'emla echo: no message on {args.topic} for {args.timeout:g} s '
                      f'({received} received)', file=sys.stderr)
                return 1
    return 0
