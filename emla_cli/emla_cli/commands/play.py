"""Republish a bag's SampleFrame and ParameterEstimate topics with their recorded timing, and /clock.

Messages go out in stamp order (simulated time), paced by their stamps scaled by --rate. --rate 0: as fast
as a live identifier takes them: at most 50 ms of bag time ahead of its latest estimate (/emla/parameters,
/emla/arx_model in ARX mode, /emla/effects; stamped with the end of the data it has used), so its frame queues never
overflow; the bag's own /emla/parameters is then not played. Without an identifier, --rate 0 sends everything
at once.
/clock follows the stamps, so nodes with use_sim_time run on the bag's time. At the end /emla/plant/done
carries the end of the played data, as the plant sends it, so a live identifier publishes its final estimate
(see emla_core.nodes). The bag is read by emla_core.bag (MCAP, or sqlite3 through rosbags): a corrupt
MCAP chunk is skipped with a warning.
"""
import itertools
import sys
import time

from emla_core import topics
from emla_core.errors import InputError
from emla_core.topics import PARAMETER_ESTIMATE, SAMPLE_FRAME, stamp_to_ns

from .numbers import add_number

HELP = 'Republish a recorded bag with its timing (or faster).'


def description():
    return """\
Republish a bag's SampleFrame and ParameterEstimate topics with their recorded timing, and /clock.

Messages go out in time order, paced by their stamps scaled by --rate. With --rate 0 they go as fast as a
live identifier node takes them (at most 50 ms of bag time ahead of its latest estimate; the bag's own
/emla/parameters is then not played), or all at once without one. /clock follows the stamps, so nodes with
use_sim_time run on the bag's time. At the end /emla/plant/done carries the end of the data, so a live
identifier publishes its final estimate. A corrupt chunk of the bag is skipped with a warning.
"""
PLAYED_TYPES = (SAMPLE_FRAME, PARAMETER_ESTIMATE)
LEAD = 50_000_000        # ns of bag time --rate 0 runs ahead of the identifier (well within the 1000-frame queues)
STALL_TIMEOUT = 10.0     # s without progress of the identifier before --rate 0 gives up
ACK_TIMEOUT = 10.0       # s for the subscribers to acknowledge the last messages
# The identifier's estimates (grey box, ARX; a solenoid's R on /emla/effects), each stamped with the end of the data
# it has used
ESTIMATES = {topics.PARAMETERS_TOPIC: PARAMETER_ESTIMATE, topics.ARX_MODEL_TOPIC: topics.ARX_MODEL,
             topics.EFFECTS_TOPIC: topics.EFFECT_ESTIMATE}


def add_arguments(parser):
    parser.add_argument('bag', help='rosbag2 directory (MCAP or sqlite3 storage) or .mcap file')
    add_number(parser, '--rate', low=0.01, high=1000, zero=True, default=1.0, metavar='R',
               help='speed factor of the recorded timing, 0.01 to 1000; 0 = as fast as a live identifier takes '
                    'it (default 1)')
    parser.add_argument('--topics', nargs='+', metavar='TOPIC',
                        help='play only these topics (default: every SampleFrame and ParameterEstimate topic)')
    add_number(parser, '--wait', low=0, high=3600, unit='s', default=1.0, metavar='S',
               help='wait up to S seconds for a subscriber on every played topic (default 1)')


def _open(args):
    """The played topics {topic: message type} of the bag, the stamp of the first message (ns) and the messages
    (topic, type, stamp ns, CDR bytes) in time order. A bag without any fails here, before ROS starts."""
    from emla_core.bag import bag_topics, iter_serialized
    from emla_core.files import path_kind
    path_kind(args.bag)   # a path that cannot be looked up at all (a name too long, a symlink loop): one line
    played = {topic: msgtype for topic, msgtype in bag_topics(args.bag).items()
              if msgtype in PLAYED_TYPES and (not args.topics or topic in args.topics)}
    messages = iter_serialized(args.bag, list(played)) if played else iter(())
    first = next(messages, None)
    if first is None:
        raise InputError(f'{args.bag}: no SampleFrame or ParameterEstimate messages on '
                         f'{", ".join(args.topics) if args.topics else "any topic"}')
    return played, first[2], itertools.chain([first], messages)


def _frame_end(bag, topic, stamp, raw):
    """The end of a SampleFrame's samples (stamp + n * period), in ns; an InputError if the frame is malformed."""
    from emla_core.bag.reader import check_period, read_frame
    _, period, samples = read_frame(bag, topic, stamp, raw)
    check_period(bag, period)
    return stamp + round(len(samples) * period * 1e9)


def _data_end(bag, last_frames):
    """The end of the time every played signal covers (as emla_core.bag.read_bag cuts them): the end of the
    last voltage interval for a launched graph's bag, i.e. the time the plant reports as done."""
    return min((_frame_end(bag, topic, *frame) for topic, frame in last_frames.items()), default=None)


def _wait_for_subscribers(publishers, seconds):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and not all(p.get_subscription_count() for p in publishers.values()):
        time.sleep(0.02)
    return sorted(topic for topic, p in publishers.items() if not p.get_subscription_count())


class IdentifierPace:
    """--rate 0 flow control: how far a live identifier has got (its latest estimate's stamp)."""

    def __init__(self, node, executor, start):
        from emla_core.messages import message_class
        from emla_core.nodes.qos import LATCHED_QOS
        self.executor = executor
        self.covered = start
        for topic, msgtype in ESTIMATES.items():
            node.create_subscription(message_class(msgtype), topic, self._on_estimate, LATCHED_QOS)

    def _on_estimate(self, msg):
        self.covered = max(self.covered, stamp_to_ns(msg.header.stamp))

    def wait_for(self, stamp):
        """Spin until the identifier has used the data up to `stamp` - LEAD."""
        seen, progress_at = self.covered, time.monotonic()
        while stamp - self.covered > LEAD:
            self.executor.spin_once(timeout_sec=0.01)
            if self.covered != seen:
                seen, progress_at = self.covered, time.monotonic()
            elif time.monotonic() - progress_at > STALL_TIMEOUT:
                raise InputError(f'the identifier took no frames for {STALL_TIMEOUT:g} s '
                                 f'(its last estimate is stamped {self.covered * 1e-9:.4f} s)')


def _live_identifier(node):
    return any(info.node_name != node.get_name()
               for topic in ESTIMATES for info in node.get_publishers_info_by_topic(topic))


def run(args):
    from rclpy.duration import Duration
    from rosgraph_msgs.msg import Clock

    from emla_core import messages
    from emla_core.messages import message_class
    from emla_core.nodes.qos import CLOCK_QOS, FRAME_QOS, LATCHED_QOS
    from emla_core.nodes.run import ros_node

    played, start, bag = _open(args)
    with ros_node('emla_play') as (node, executor):
        publishers = {topic: node.create_publisher(
            message_class(msgtype), topic,
            FRAME_QOS if msgtype == SAMPLE_FRAME else LATCHED_QOS) for topic, msgtype in played.items()}
        clock = node.create_publisher(Clock, topics.CLOCK_TOPIC, CLOCK_QOS)
        done = node.create_publisher(message_class('builtin_interfaces/msg/Time'), topics.DONE_TOPIC,
                                     LATCHED_QOS)
        unheard = _wait_for_subscribers(publishers, args.wait)
        if unheard:
            print(f'emla play: no subscriber (yet) of {", ".join(unheard)}', file=sys.stderr)
        pace = None
        if args.rate == 0 and _live_identifier(node):
            pace = IdentifierPace(node, executor, start)
            if topics.PARAMETERS_TOPIC in publishers:
                node.destroy_publisher(publishers.pop(topics.PARAMETERS_TOPIC))
            print('emla play: paced by the live identifier', file=sys.stderr)
        count, now, last_frames = 0, -1, {}
        wall = time.monotonic()
        for topic, msgtype, stamp, raw in bag:
            if topic not in publishers:
                continue
            if args.rate > 0:
                time.sleep(max(0.0, wall + (stamp - start) * 1e-9 / args.rate - time.monotonic()))
            elif pace:
                pace.wait_for(stamp)
            if stamp > now:
                now = stamp
                clock.publish(Clock(clock=messages.time_msg(now)))
            publishers[topic].publish(raw)
            if msgtype == SAMPLE_FRAME:
                last_frames[topic] = (stamp, raw)
            count += 1
        end = _data_end(args.bag, last_frames)
        if end is not None:
            clock.publish(Clock(clock=messages.time_msg(end)))
            done.publish(messages.time_msg(end))
        for publisher in (*publishers.values(), done):
            publisher.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT))
        print(f'emla play: {count} messages on {len(publishers)} topics, {(now - start) * 1e-9:.3f} s '
              f'of bag time in {time.monotonic() - wall:.2f} s', file=sys.stderr)
    return 0
