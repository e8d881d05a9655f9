"""The recorder node: every /emla topic, as received (CDR bytes), into a crash-safe rosbag2 directory.

Messages are stored at their header stamp (simulated time), so two runs of the same scenario give the same
bag. Splits of `split_size` bytes are finished and listed in metadata.yaml as they fill, so a SIGKILL loses
at most the split being written. SIGINT/SIGTERM: keep receiving until the topics are quiet for
`drain_time`, then finish the split and exit 0. Custom data of the bag: `scenario` and `true_<name>` (the
latest /emla/plant/parameters values, as strings).
"""
import signal
import struct
import sys
import threading
import time

import rclpy
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rclpy.signals import SignalHandlerOptions

from emla_sim.bag import ESTIMATE_FIELDS, PARAMETER_ESTIMATE, SAMPLE_FRAME, TRUTH_TOPIC, BagWriter
from emla_sim.errors import InputError

# Recorded topics: name -> (type). All are published reliably; 1 ms frames at 10 kHz are 1000 messages/s
# per topic, so the queue holds seconds of them while the writer finishes a split.
TOPICS = {
    '/emla/plant/voltage': SAMPLE_FRAME,
    '/emla/plant/current': SAMPLE_FRAME,
    '/emla/plant/position': SAMPLE_FRAME,
    '/emla/plant/parameters': PARAMETER_ESTIMATE,
    '/emla/voltage': SAMPLE_FRAME,
    '/emla/current': SAMPLE_FRAME,
    '/emla/position': SAMPLE_FRAME,
    '/emla/reference': SAMPLE_FRAME,
    '/emla/voltage_command': SAMPLE_FRAME,
    '/emla/parameters': PARAMETER_ESTIMATE,
}
LATCHED = {'/emla/parameters', '/emla/plant/parameters'}   # published transient_local
QUEUE_DEPTH = 10000


def message_class(msgtype):
    package, _, name = msgtype.split('/')
    return getattr(__import__(f'{package}.msg', fromlist=[name]), name)


def header_stamp_ns(cdr):
    """header.stamp of a serialised message that starts with a std_msgs/Header (after the 4-byte CDR header)."""
    sec, nanosec = struct.unpack_from('<iI' if cdr[1] == 1 else '>iI', cdr, 4)
    return sec * 1_000_000_000 + nanosec


class Recorder(Node):
    def __init__(self):
        super().__init__('recorder')
        bag = self.declare_parameter('bag', '', ParameterDescriptor(
            description='output rosbag2 directory (must not exist or be empty)', read_only=True)).value
        scenario = self.declare_parameter('scenario', '', ParameterDescriptor(
            description='scenario name stored in the bag custom data', read_only=True)).value
        split_size = self.declare_parameter('split_size', 256 * 1024, ParameterDescriptor(
            description='bytes of messages per MCAP split; a SIGKILL loses at most one split (B)', read_only=True,
            integer_range=[IntegerRange(from_value=4096, to_value=1 << 30, step=1)])).value
        self.drain_time = self.declare_parameter('drain_time', 0.3, ParameterDescriptor(
            description='after a stop signal, record until no message arrived for this long (s)', read_only=True,
            floating_point_range=[FloatingPointRange(from_value=0.0, to_value=10.0, step=0.0)])).value
        if not bag:
            raise InputError('recorder: parameter `bag` (output directory) is required')
        self.bag = BagWriter(bag, split_size=split_size, custom_data={'scenario': scenario})
        self.received = 0
        for topic, msgtype in TOPICS.items():
            qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=QUEUE_DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL if topic in LATCHED
                             else DurabilityPolicy.VOLATILE)
            self.create_subscription(message_class(msgtype), topic, self._receiver(topic, msgtype), qos, raw=True)
        self.get_logger().info(f'recording {len(TOPICS)} topics into {bag}')

    def _receiver(self, topic, msgtype):
        def receive(cdr):
            self.received += 1
            self.bag.add_topic(topic, msgtype)
            self.bag.write(topic, header_stamp_ns(cdr), cdr)
            if topic == TRUTH_TOPIC:
                truth = deserialize_message(cdr, message_class(msgtype))
                self.bag.custom_data.update({f'true_{k}': repr(float(getattr(truth, k))) for k in ESTIMATE_FIELDS})
        return receive

    def drain(self, executor, limit=10.0):
        """Spin until no message arrived for drain_time (at most `limit` s)."""
        quiet_since = start = time.monotonic()
        count = self.received
        while time.monotonic() - quiet_since < self.drain_time and time.monotonic() - start < limit:
            executor.spin_once(timeout_sec=0.05)
            if self.received != count:
                count, quiet_since = self.received, time.monotonic()

    def close(self):
        self.bag.close()
        total = sum(self.bag.counts.values())
        self.get_logger().info(f'{total} messages in {len(self.bag.finished)} splits: {self.bag.path}')


def main(args=None):
    # rclpy's own handlers would shut the context down at once; the recorder drains its queues first.
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    try:
        recorder = Recorder()
    except InputError as exc:
        print(exc, file=sys.stderr)
        return 2
    executor = EventsExecutor()
    executor.add_node(recorder)
    try:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.1)
        recorder.drain(executor)
    finally:
        recorder.close()
        executor.shutdown()
        recorder.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
