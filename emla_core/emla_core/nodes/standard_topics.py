"""StandardTopics: topics of standard message types (a real drive's) as frames on the sample grid."""
from emla_core.errors import InputError
from emla_core.messages import message_class
from emla_core.nodes.frames import DISCOVERY_PERIOD, STEADY_CLOCK
from emla_core.nodes.qos import matching_qos
from emla_core.topics import SAMPLE_FRAME, to_ns


class StandardTopics:
    """Feeds receive(name, stamp_ns, samples, sample_period) (AlignedSamples.receive with subscribe=False) from
    topics of standard message types that {name: TopicSignal} maps to signals (emla_core.bag.foreign, the syntax
    of `emla identify --topics`: std_msgs Float64/32 and their MultiArrays, sensor_msgs JointState, emla_msgs
    SampleFrame). Each message is a frame of the samples it carries for each signal, `sample_period` apart (a
    SampleFrame's own), the first at the message's time (its header stamp where it has one, else the time the
    node receives it) rounded to the nearest multiple of sample_period. FrameSets then finds the faults: a
    sample whose instant was passed already ('stamp_back'), instants without one ('missing'), ...; a message
    the mapping cannot read (no such joint or element) is 'unreadable'.

    The receive time is when the node handles the message (rclpy's EventsExecutor gives no reception stamp), so
    it jitters with the node's load by far more than a sample period of a fast drive: signals that must line up
    sample by sample need header stamps (JointState, SampleFrame) above a few Hz.

    A topic is subscribed once the graph shows a publisher of it, with their message type (another than those
    ends the node: EmlaNode.fail) and a QoS all of them match (matching_qos). rclpy takes about 6-10k
    messages/s at most, so one sample per message suits rates up to about 1-2 kHz; faster ones need frames."""

    def __init__(self, node, signals, receive, faults, sample_period):
        from emla_core.bag import foreign  # with rosbags: loaded only by a node that reads such topics
        self._supported, self._stamp, self._values = foreign.SUPPORTED, foreign.header_stamp, foreign.message_values
        self._node, self._receive, self._faults = node, receive, faults
        self._sample_period, self._step = sample_period, to_ns(sample_period)
        self._waiting = {}  # topic -> [(name, TopicSignal)], until it is subscribed
        for name, spec in signals.items():
            self._waiting.setdefault(spec.topic, []).append((name, spec))
        self._timer = node.create_timer(DISCOVERY_PERIOD, self._discover, clock=STEADY_CLOCK)

    def _discover(self):
        for topic, signals in list(self._waiting.items()):
            publishers = self._node.get_publishers_info_by_topic(topic)
            msgtypes = sorted({publisher.topic_type for publisher in publishers})
            if not msgtypes:
                continue
            if len(msgtypes) > 1 or msgtypes[0] not in self._supported:
                self._node.fail(f'{topic} is {" and ".join(msgtypes)}; an input topic is one of '
                                f'{", ".join(msgtype.split("/")[-1] for msgtype in self._supported)}')
                return
            msgtype = msgtypes[0]
            self._node.create_subscription(message_class(msgtype), topic, lambda msg, msgtype=msgtype, signals=signals:
                                           self._on_message(msg, msgtype, signals), matching_qos(publishers))
            del self._waiting[topic]
        if not self._waiting:
            self._node.destroy_timer(self._timer)

    def _on_message(self, msg, msgtype, signals):
        time_ns = self._stamp(msg) or self._node.get_clock().now().nanoseconds
        stamp = (time_ns + self._step // 2) // self._step * self._step
        period = msg.sample_period if msgtype == SAMPLE_FRAME else self._sample_period
        for name, spec in signals:
            try:
                samples = self._values(msg, msgtype, spec, 'unreadable message')
            except InputError as error:
                self._faults.report('unreadable', str(error))
            else:
                self._receive(name, stamp, samples, period)
