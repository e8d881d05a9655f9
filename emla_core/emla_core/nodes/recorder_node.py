"""The recorder node: every /emla topic, as received (CDR bytes), into a crash-safe rosbag2 directory.

Messages are stored at their header stamp (simulated time), so two runs of the same scenario give the same
bag. Splits of `split_size` bytes are finished and listed in metadata.yaml as they fill, so a SIGKILL loses
at most the split being written. SIGINT/SIGTERM: keep receiving until the topics are quiet for
`drain_time`, then finish the split and exit 0. Custom data of the bag: `scenario` and `true_<name>` (the
latest /emla/plant/parameters values that are numbers, as strings).

Outside the loop, the recorder need not handle each message as it comes: it takes what came every 10 ms
(its POLL_PERIOD, see EmlaNode), which spares it a wake-up per message.

With `hold_start` (as `emla launch` runs it) the recorder subscribes to the plant's start topic
(/emla/position, see emla_core.nodes) only once each of its other topics (but those emla_core.topics.OPTIONAL
has for its `actuator`) has a matched publisher: the lockstep plant cannot start before the recorder hears every
node, so the bag begins at t = 0.
"""
import math
import sys
import time

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message

from emla_core import messages, topics
from emla_core.bag import BagWriter
from emla_core.errors import InputError
from emla_core.nodes.node import EmlaNode
from emla_core.nodes.param_specs import Spec, declare, family
from emla_core.nodes.run import run
from emla_core.parameters import FAMILIES

# Recorded topics -> message class (emla_core.topics.RECORDED). Every one is published reliable and
# transient local (see emla_core.nodes).
TOPICS = {topic: messages.message_class(msgtype) for topic, (msgtype, _) in topics.RECORDED.items()}
# Unbounded queues: the writer may fall behind the frames (some 5000 messages/s at real time) for a while.
QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
SPECS = [
    Spec('bag', '', 'output rosbag2 directory (must not exist or be empty)'),
    Spec('scenario', '', 'scenario name stored in the bag custom data'),
    Spec('split_size', 128 * 1024, 'bytes of messages per MCAP split; a SIGKILL loses at most one, B',
                4096, 2**30),
    Spec('hold_start', False, 'join the plant start barrier only once every other topic has a publisher'),
    Spec('actuator', 'moving_coil', f'the family of the run\'s actuator, of {list(FAMILIES)}: which topics '
                                    'hold_start does not wait for'),
    Spec('drain_time', 0.3, 'after SIGINT/SIGTERM, record until no message came for this long, s',
                0.0, 10.0),
]


class Recorder(EmlaNode):
    NAME = 'recorder'
    POLL_PERIOD = 0.01  # s (see the module doc)

    def __init__(self):
        super().__init__()
        self.config = declare(self, SPECS)
        if not self.config.bag:
            raise InputError('parameter `bag` (output directory) is required')
        family(self.config.actuator)
        self.bag = BagWriter(self.config.bag, split_size=self.config.split_size,
                             custom_data={'scenario': self.config.scenario})
        self.topic_subscriptions = {topic: self._subscribe(topic) for topic in TOPICS
                                    if topic != topics.START_TOPIC or not self.config.hold_start}
        if self.config.hold_start:
            self.holding = self.create_timer(0.02, self._join_start)
        self.get_logger().info(f'recording {len(TOPICS)} topics into {self.config.bag}')

    def _subscribe(self, topic):
        return self.create_subscription(TOPICS[topic], topic, self._receiver(topic, TOPICS[topic]), QOS, raw=True)

    def _join_start(self):
        # (an optional topic's publisher, if any, is the identifier's, matched with its other one)
        if all(s.get_publisher_count() for topic, s in self.topic_subscriptions.items()
               if topic not in topics.OPTIONAL[self.config.actuator]):
            self.holding.cancel()
            self._subscribe(topics.START_TOPIC)
            self.get_logger().info(f'every publisher matched; subscribed to {topics.START_TOPIC}')

    def _receiver(self, topic, message_class):
        name = topics.RECORDED[topic][0]

        def receive(cdr):
            self.bag.add_topic(topic, name)
            self.bag.write(topic, messages.header_stamp_ns(cdr), cdr)
            if topic == topics.TRUE_PARAMETERS_TOPIC:
                truth = messages.estimate_values(deserialize_message(cdr, message_class))
                self.bag.custom_data.update({f'true_{k}': repr(v) for k, v in truth.items() if math.isfinite(v)})
        return receive

    def drain(self, executor, limit=10.0):
        """Spin until no message arrived for drain_time (at most `limit` s)."""
        quiet_since = start = time.monotonic()
        count = self.handled
        while time.monotonic() - quiet_since < self.config.drain_time and time.monotonic() - start < limit:
            executor.spin_once(timeout_sec=0.05)
            if self.handled != count:
                count, quiet_since = self.handled, time.monotonic()

    def stop(self, executor):
        """Record what is still in flight, then finish the bag (also when draining is interrupted)."""
        try:
            self.drain(executor)
        finally:
            self.close()

    def close(self):
        self.bag.close()
        self.get_logger().info(f'{sum(self.bag.counts.values())} messages in {len(self.bag.finished)} splits: '
                               f'{self.bag.path}')


def main(args=None):
    return run(Recorder, args)


if __name__ == '__main__':
    sys.exit(main())
