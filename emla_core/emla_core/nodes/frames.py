"""Frame topics of the graph: subscribing to them as bytes (the plant's start topic last), SignalFrames
fed to the frame readers, publishers, and FrameSets (the frames of one stamp from every topic, bad
frames reported and survived)."""
import numpy as np
from rclpy.clock import Clock, ClockType

from emla_core.messages import read_frame_cdr, read_signal_frames_cdr
from emla_core.nodes.qos import FRAME_QOS, frame_qos
from emla_core.topics import START_TOPIC, to_ns
from emla_msgs.msg import SampleFrame, SignalFrames

DISCOVERY_PERIOD = 0.1  # s between looks at the graph (publishers of standard input topics, matched frame topics)
STEADY_CLOCK = Clock(clock_type=ClockType.STEADY_TIME)  # of those looks: simulated time may stand still meanwhile


def subscribe_frames(node, topics, receive):
    """Subscribe to the frame topics {name: topic}, calling receive(name, cdr) with each frame as bytes (no rclpy
    message built). The plant's start topic (/emla/position) last, once the others have a matched publisher:
    the plant starts when that topic has its readers, and frames to a reader whose participant had not yet
    discovered the sensor's would wait for the next discovery announcement (seconds)."""
    def subscribe(name, topic):
        return node.create_subscription(SampleFrame, topic, lambda cdr: receive(name, cdr), FRAME_QOS, raw=True)

    held = {name: topic for name, topic in topics.items() if topic == START_TOPIC and len(topics) > 1}
    others = [subscribe(name, topic) for name, topic in topics.items() if name not in held]

    def join():
        if all(subscription.get_publisher_count() for subscription in others):
            node.destroy_timer(timer)
            for name, topic in held.items():
                subscribe(name, topic)
    if held:
        timer = node.create_timer(DISCOVERY_PERIOD, join, clock=STEADY_CLOCK)


def subscribe_signal_frames(node, topic, inputs):
    """Subscribe to a SignalFrames topic (raw), feeding each of its frames to `inputs` (a FrameSets or an
    AlignedSamples made with subscribe=False) by receive(): one delivery for the signals it needs, where their
    own topics would take one each. The empty voltage frame of the first message (stamped as its state frames:
    the state at t = 0 alone) is not a frame."""
    def receive(cdr):
        frames = read_signal_frames_cdr(cdr)
        for name in inputs.names:
            stamp, period, samples = frames[name]
            if len(samples) or stamp != frames['current'][0]:
                inputs.receive(name, stamp, samples, period)
    return node.create_subscription(SignalFrames, topic, receive, FRAME_QOS, raw=True)


class FrameSets:
    """Subscribes to frame topics {name: topic}; calls on_set(stamp_ns, sample_period, {name: array}) once
    every topic has delivered its frame with that stamp (in stamp order: each topic is in order). With
    subscribe=False it is fed by receive() instead (StandardTopics), `topics` naming the inputs in warnings.

    Bad input is reported to `faults` (a Faults) and survived: a frame stamped before the end of its topic's
    previous one (a duplicate, a jump back) is dropped ('stamp_back'); a gap in a topic ('missing': a lost
    frame) leaves its set incomplete, dropped once a later set completes; an 'empty' frame, one of another
    sample period ('wrong_period'; with `sample_period` given) or a set whose frames differ in length or
    period ('unmatched') gives on_set(stamp_ns, sample_period, None), so the node still learns of the
    period. 'non_finite' samples are passed on: the node knows which samples it needs."""

    def __init__(self, node, topics, on_set, faults, sample_period=None, subscribe=True):
        self._topics = topics
        self._on_set = on_set
        self._faults = faults
        self._step = None if sample_period is None else to_ns(sample_period)
        self._last = dict.fromkeys(topics)  # name -> (stamp, end) of its latest frame; end None if unknown
        self._pending = {}  # stamp -> {name: (samples, sample_period), or None if unusable}
        if subscribe:
            subscribe_frames(node, topics, self.receive_cdr)

    @property
    def names(self):
        """The inputs' names."""
        return tuple(self._topics)

    def receive_cdr(self, name, cdr):
        """A serialised frame of input `name`."""
        stamp, period, samples = read_frame_cdr(cdr)
        self.receive(name, stamp, samples, period)

    def receive(self, name, stamp, samples, period):
        """A frame of input `name`: `samples` (1-D array) from `stamp` (ns) on, `period` s apart."""
        step = to_ns(period) if 0.0 < period < 1e6 else 0  # (to_ns overflows on huge ones)
        where = f'{self._topics[name]} frame stamped {stamp} ns'
        last = self._last[name]
        if last and (stamp <= last[0] or last[1] is not None and stamp < last[1]):
            self._faults.report('stamp_back', f'dropped a {where}: its topic was at '
                                              f'{last[0] if last[1] is None else last[1]} ns')
            return
        if last and last[1] is not None and stamp > last[1]:
            self._faults.report('missing', f'{self._topics[name]} frames missing from {last[1]} to {stamp} ns')
        fault = 'empty' if not len(samples) else \
            'wrong_period' if step <= 0 or self._step not in (None, step) else None
        if fault:
            self._faults.report(fault, f'{where} ({len(samples)} samples of {period} s) is unusable: {fault}')
        elif not np.isfinite(samples).all():
            self._faults.report('non_finite', f'{where} has non-finite samples')
        self._last[name] = (stamp, None if fault else stamp + len(samples) * step)  # after a bad one: any later
        frames = self._pending.setdefault(stamp, {})
        frames[name] = None if fault else (samples, period)
        if len(frames) == len(self._topics):
            # each topic is in order: the sets before this one cannot complete any more (a frame was lost)
            self._pending = {later: sets for later, sets in self._pending.items() if later > stamp}
            self._complete(stamp, period, frames)

    def _complete(self, stamp, period, frames):
        usable = None not in frames.values()
        if usable and len({(len(samples), frame_period) for samples, frame_period in frames.values()}) > 1:
            self._faults.report('unmatched', f'the frames stamped {stamp} ns differ in length or sample period')
            usable = False
        self._on_set(stamp, period, {name: samples for name, (samples, _) in frames.items()} if usable else None)


def frame_publishers(node, topics, frame_period=None):
    """SampleFrame publishers {name: publisher} of {name: topic}, keeping FRAME_HISTORY of frames `frame_period` s
    long (None: FRAME_QOS, 1 ms frames)."""
    qos = FRAME_QOS if frame_period is None else frame_qos(frame_period)
    return {name: node.create_publisher(SampleFrame, topic, qos) for name, topic in topics.items()}
