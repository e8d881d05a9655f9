"""What the suite's nodes share: the graph (topics, QoS), the lockstep, frames <-> numpy, parameters, spinning.

Graph (namespace /emla, SI units). A SampleFrame holds consecutive samples of one signal, stamped with the
simulated time of its first sample; the frames of control period k (Tc = n Ts, k = 0, 1, ...) are:
  voltage frames (/emla/voltage, /emla/voltage_command): the n values over [k Tc + j Ts, k Tc + (j+1) Ts),
    j = 0..n-1, stamp k Tc;
  state frames (/emla/{current,position}): the n samples the period's voltage intervals end on, at
    k Tc + (j+1) Ts, stamp k Tc + Ts; so the state at (k+1) Tc is the last sample of period k's frame. Before
    period 0 the plant publishes one state frame of a single sample: the state at t = 0, stamp 0.
Frames only a recorder reads (the plant's truth /emla/plant/{voltage,current,position}, /emla/reference) span
10 periods alike (the plant's parameters_period, the controller's REFERENCE_FRAME): fewer, longer messages cost
every process less (a delivery costs a process a wake-up, some 0.1 ms here). The plant's truth of each period
goes to the sensor in one message, a SignalFrames on /emla/plant/frames.
Aligned by stamp (as emla_core.bag.read_bag does), the state samples at t_j pair with the voltage held over
[t_j, t_j + Ts), the Recording convention; `AlignedSamples` does this for a node.

| topic                                  | type                            | publisher  | QoS     |
|----------------------------------------|---------------------------------|------------|---------|
| /emla/plant/frames                     | emla_msgs/SignalFrames (truth)  | plant      | FRAME   |
| /emla/plant/{voltage,current,position} | emla_msgs/SampleFrame (truth)   | plant      | FRAME   |
| /emla/plant/parameters                 | emla_msgs/ParameterEstimate     | plant      | LATCHED |
| /emla/plant/done                       | builtin_interfaces/Time         | plant      | LATCHED |
| /clock                                 | rosgraph_msgs/Clock             | plant      | CLOCK   |
| /emla/{voltage,current,position}       | emla_msgs/SampleFrame (measured)| sensor     | FRAME   |
| /emla/voltage_command, /emla/reference | emla_msgs/SampleFrame           | controller | FRAME   |
| /emla/parameters                       | emla_msgs/ParameterEstimate     | identifier | LATCHED |
| /emla/arx_model (instead, model arx)   | emla_msgs/ArxModel              | identifier | LATCHED |
| /diagnostics                           | diagnostic_msgs/DiagnosticArray | identifier*| DIAGNOSTICS |
FRAME: reliable, transient local, keep last 1000 (1 s of default frames: a reader outside the loop, such as a
non-adaptive controller's identifier or a recorder, may lag that much without losing frames);
LATCHED: reliable, transient local, keep last 1 (a late subscriber gets the latest);
CLOCK: best effort, volatile, keep last 1 (as rclpy's time source subscribes); DIAGNOSTICS: reliable, 10.
*and the sensor's and controller's input faults (see Bad frames).
The nodes publish and read frames as serialised bytes (emla_core.messages.frame_cdr, read_frame_cdr: no rclpy
message built), and run with the suite's Fast DDS profile (fastdds.xml beside this module: writers send no
heartbeat with every sample nor fire a timer per sample and reader, participants announce themselves often
while the graph starts), which spares each process wake-ups and a launch seconds of discovery.

Deterministic lockstep in simulated time, the controller one period ahead of the plant:
1. Start: once /emla/position has `start_subscribers` subscriptions (the plant's parameter: controller,
   identifier, recorders: whoever must see every frame), /emla/plant/done has `done_subscribers` (identifier,
   recorders, a launcher: whoever must learn the end) and, with start_subscribers > 0, the plant's frames
   and its commands are matched (the sensor, the controller), the plant publishes the state at t = 0. The
   controller and identifier subscribe to /emla/position only once their other frame topics have a matched
   publisher (subscribe_frames), so the loop's first frames do not wait for a late discovery.
2. Sensor: measures the state frames of each plant message and publishes them with the same stamp; the
   voltage frame passes unchanged to /emla/voltage.
3. Controller: from the last sample of each measured state frame (time t = stamp + (size - 1) Ts) it computes
   the command for the period starting at t + Tc (n equal values, stamp t + Tc), predicting the state there
   from its model under the command of the period from t, which it published a period earlier: one period
   of computational delay, as any digital controller has, so that it computes while the plant runs. From the
   first state (t = 0) it commands the period from t = 0 too, with the law's voltage there. Its commands for
   the two periods after the end go unused.
4. Plant: advances period k only with the command stamped k Tc in hand; publishes its frames (to the sensor),
   then /clock = (k+1) Tc. It holds the command for period k+1 by the end of period k unless the loop
   (plant -> sensor -> controller -> plant, three deliveries) takes longer than a period of the plant's.
5. Identifier: feeds the aligned samples in time order to the estimator and publishes /emla/parameters (in
   ARX mode /emla/arx_model) at every multiple of `publish_period` that ends a period, stamped with the END of
   the data it covers: the estimate stamped t has used every voltage interval before t. An adaptive controller
   (its `adaptation_period` Ta is a multiple of that publish_period) takes the estimate stamped t at the next
   adaptation instant, before the command it computes at t + Ta (waiting for it if need be): the identifier
   has a whole adaptation period to deliver it, so the loop does not wait for its computation. Lag: the
   command held from t + Ta + Tc on uses the estimate from all the data before t, so a plant change reaches
   the model up to two adaptation periods later (plus the estimator's own memory; the in-process loop,
   emla_control.loop, has neither the computational delay nor this adaptation period of lag).
Every message travels on a reliable, in-order topic and each node computes from its inputs alone, so a run's
samples do not depend on scheduling. Frames are transient local so that a reader that matches a publisher
late (start-up) still gets them; in the loop, at most two periods' messages are in flight.

Done signal: with duration > 0 the plant advances round(duration / Tc) periods, publishes the final frames,
the final true parameters and /emla/plant/done (builtin_interfaces/Time: the end time, latched), and exits 0
once every reader acknowledged its messages (see wait_for_acknowledgements). The identifier then publishes its
final estimate stamped with that end time (if that was not a publishing instant anyway): the last
/emla/parameters message covers every sample the plant produced. A launcher waits for it, then stops the
other nodes with SIGTERM.

Bad frames (a real sensor stream loses some): the sensor, controller and identifier keep running through lost,
empty, non-finite and wrong-period frames and stamps that jump back; each such fault is a warning in the log
and a count on /diagnostics (`Faults`; `FrameSets` and `AlignedSamples` find them and resynchronise). The
sensor publishes empty frames for a period whose plant frames it cannot use (non-finite samples it measures
as they are); the controller holds its last voltage over the period after a state it lacks and publishes it,
so the lockstep goes on (it does not wait for an estimate then); the identifier skips the instants it lacks
usable samples for, and none of its regression rows spans them. A frame lost outright inside the lockstep
stalls it: the next one needs the command it would have led to.

Standard topics: the identifier can read a real drive's topics of standard message types instead of the
measured frames (its input_topics; StandardTopics): each message becomes a frame on the sample grid (by its
header stamp, else its receive time), so the same faults are found and survived.

Each node: parameters declared read-only with descriptors (range, units in the description), defaults in the
package's config/<node>.yaml; once constructed (warmed up, subscribed) it says 'NAME: ready (its topics)' on
stderr; SIGINT/SIGTERM end it cleanly with exit status 0 (after the acknowledgements of what it published, at
most ACK_TIMEOUT); bad parameters (out of range, of another type, or not the node's: a params file's typo, see
params_file) end it with one line on stderr and exit status 2, as does bad input found later (EmlaNode.fail: an
input topic of a type it cannot read).
"""
import collections
import contextlib
import dataclasses
import itertools
import os
import signal
import sys
import time
import types
from pathlib import Path

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.exceptions import ParameterException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from emla_core.errors import InputError
from emla_core.messages import message_class, read_frame_cdr, read_signal_frames_cdr
from emla_core.nodes.params_file import check_params, read_params_files
from emla_core.parameters import PARAMETER_UNITS, TABLE1
from emla_core.topics import DIAGNOSTICS_TOPIC, QOS, SAMPLE_FRAME, START_TOPIC, to_ns
from emla_msgs.msg import SampleFrame, SignalFrames


def qos_profile(kind):
    """The rclpy QoSProfile of a QoS kind of emla_core.topics.QOS."""
    qos = QOS[kind]
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=qos['depth'],
                      reliability=ReliabilityPolicy[qos['reliability'].upper()],
                      durability=DurabilityPolicy[qos['durability'].upper()])


FRAME_QOS, LATCHED_QOS, CLOCK_QOS, DIAGNOSTICS_QOS = map(qos_profile, ('frame', 'latched', 'clock', 'diagnostics'))
ACK_TIMEOUT = 4.0  # s a stopping node waits for its readers' acknowledgements
FASTDDS_PROFILES = Path(__file__).with_name('fastdds.xml')  # the suite's Fast DDS defaults (why: see there)
INPUT_DEPTH = 1000  # messages a reader of a standard input topic keeps (1 s at 1 kHz)
DISCOVERY_PERIOD = 0.1  # s between looks at the graph (publishers of standard input topics, matched frame topics)
STEADY_CLOCK = Clock(clock_type=ClockType.STEADY_TIME)  # of those looks: simulated time may stand still meanwhile


def period_samples(sample_period, control_period):
    """Samples per control period; the control period must be a whole number of samples of whole ns."""
    n = round(control_period / sample_period)
    if n < 1 or abs(n * sample_period - control_period) > 1e-9 * control_period \
            or abs(sample_period * 1e9 - to_ns(sample_period)) > 1e-6:
        raise InputError(f'control_period ({control_period} s) must be a whole multiple of sample_period '
                         f'({sample_period} s, a whole number of ns)')
    return n


# ---- frames ----

class Faults:
    """A node's input faults (a lost frame, an empty one, ...) counted by kind: each is logged as a warning (at
    most one line per WARNING_INTERVAL s: a burst does not flood the log), and within a second of a new one
    the counts go to /diagnostics, one status 'emla/<node>/input' of level WARN with a KeyValue per kind."""

    WARNING_INTERVAL = 5.0  # s

    def __init__(self, node):
        self._node = node
        self.counts = collections.Counter()
        self._published = 0  # total of the counts on /diagnostics
        self._diagnostics = node.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, DIAGNOSTICS_QOS)
        node.create_timer(1.0, self._publish)

    def report(self, kind, message):
        self.counts[kind] += 1
        self._node.get_logger().warning(f'{message} (input faults so far: {self._summary()})',
                                        throttle_duration_sec=self.WARNING_INTERVAL)

    def _summary(self):
        return ', '.join(f'{count} {kind}' for kind, count in sorted(self.counts.items()))

    def _publish(self):
        if self.counts.total() == self._published:
            return
        self._published = self.counts.total()
        status = DiagnosticStatus(level=DiagnosticStatus.WARN, name=f'emla/{self._node.get_name()}/input',
                                  hardware_id='emla', message=f'input faults: {self._summary()}',
                                  values=[KeyValue(key=kind, value=str(count))
                                          for kind, count in sorted(self.counts.items())])
        array = DiagnosticArray(status=[status])
        array.header.stamp = self._node.get_clock().now().to_msg()
        self._diagnostics.publish(array)


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


class AlignedSamples:
    """Subscribes to frame topics {name: topic} of one sample period and calls on_samples(start_ns, {name:
    array}) with the samples all of them have at the same instants, in time order, in chunks that end at the
    multiples of `boundary` (ns): a chunk is passed on once all have the samples up to the next multiple, or
    up to a gap, or up to the end of the input (finish()). Few long chunks: an estimator's update costs about
    as much per call as for a hundred samples. The graph's frames (state frames one sample later than voltage
    frames) come out in the Recording convention, the estimator's input: the state samples where each voltage
    interval starts. Frames aligned already (a bag of `emla simulate` played) pass as they are.

    Instants some topic has no samples for (lost or unusable frames, see FrameSets; faults reported there)
    are skipped: the next chunk starts later than the last one ended, at the first instant all have again.
    Non-finite samples are passed on, in place. With subscribe=False the frames come through receive()
    (see FrameSets)."""

    def __init__(self, node, topics, on_samples, faults, sample_period, boundary, subscribe=True):
        self._on_samples = on_samples
        self._step = to_ns(sample_period)
        self._boundary = boundary
        self._finish = None  # the end of the input, once known
        self._cursor = None  # the first instant not passed on (or skipped) yet
        self._queues = {name: [] for name in topics}  # name -> [(stamp, samples)] not passed on yet
        self._frames = {name: FrameSets(node, {name: topic}, self._on_set, faults, sample_period, subscribe=False)
                        for name, topic in topics.items()}
        if subscribe:
            subscribe_frames(node, topics, lambda name, cdr: self._frames[name].receive_cdr(name, cdr))

    @property
    def names(self):
        """The inputs' names."""
        return tuple(self._queues)

    def receive(self, name, stamp, samples, period):
        """A frame of input `name` (see FrameSets.receive)."""
        self._frames[name].receive(name, stamp, samples, period)

    def finish(self, end):
        """The input ends at `end` (ns): pass on the samples up to it without waiting for a multiple of boundary."""
        self._finish = end
        self._pass_on()

    def _on_set(self, stamp, sample_period, frames):
        if frames is None:
            return  # an unusable frame: its instants will be skipped
        ((name, samples),) = frames.items()
        self._queues[name].append((stamp, samples))
        self._pass_on()

    def _pass_on(self):
        while True:
            if self._cursor is not None:
                for queue in self._queues.values():  # drop what the cursor skipped
                    while queue and self._end(queue[0]) <= self._cursor:
                        queue.pop(0)
            if not all(self._queues.values()):
                return
            resume = max(queue[0][0] for queue in self._queues.values())
            if self._cursor is None or resume > self._cursor:
                self._cursor = resume  # the start, or a skip over instants some topic lacks
                continue
            boundary = (self._cursor // self._boundary + 1) * self._boundary
            ends = {name: self._contiguous_end(queue) for name, queue in self._queues.items()}
            end = min(boundary, *ends.values())
            if end < boundary and end != self._finish and \
                    all(self._end(self._queues[name][-1]) == ends[name] for name in ends if ends[name] == end):
                return  # the samples after `end` are still to come (no gap there)
            chunk = {name: self._take(queue, end) for name, queue in self._queues.items()}
            start, self._cursor = self._cursor, end
            self._on_samples(start, chunk)

    def _end(self, frame):
        stamp, samples = frame
        return stamp + len(samples) * self._step

    def _contiguous_end(self, queue):
        """The end of the queued samples that follow on from the first frame without a gap."""
        end = self._end(queue[0])
        for stamp, samples in itertools.islice(queue, 1, None):  # (_end inline: called for every frame queued)
            if stamp != end:
                break
            end = stamp + len(samples) * self._step
        return end

    def _take(self, queue, end):
        """The queued samples at the instants [cursor, end); later ones stay queued."""
        parts = []
        while queue and queue[0][0] < end:
            stamp, samples = queue[0]
            first, last = max(0, (self._cursor - stamp) // self._step), (end - stamp) // self._step
            parts.append(samples[first:last])
            if last < len(samples):
                queue[0] = (stamp + last * self._step, samples[last:])
                break
            queue.pop(0)
        return parts[0] if len(parts) == 1 else np.concatenate(parts)


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


def matching_qos(publishers):
    """A reader QoS the publishers (TopicEndpointInfo) all match, as `ros2 bag record` picks it: reliable and
    transient local only where every one of them is; keep last INPUT_DEPTH."""
    def offered(policy, strong, weak):
        return strong if all(getattr(p.qos_profile, policy) == strong for p in publishers) else weak
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=INPUT_DEPTH,
                      reliability=offered('reliability', ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT),
                      durability=offered('durability', DurabilityPolicy.TRANSIENT_LOCAL, DurabilityPolicy.VOLATILE))


def frame_publishers(node, topics):
    return {name: node.create_publisher(SampleFrame, topic, FRAME_QOS) for name, topic in topics.items()}


# ---- parameters ----

@dataclasses.dataclass(frozen=True)
class Spec:
    """A node parameter: default (float, int, bool, str, or an array Parameter.Type meaning empty),
    description with units, and for numbers the inclusive range [low, high]."""
    name: str
    default: object
    description: str
    low: float = None
    high: float = None

    def descriptor(self):
        descriptor = ParameterDescriptor(description=self.description, read_only=True)
        if isinstance(self.default, bool) or self.low is None:
            return descriptor
        if isinstance(self.default, int):
            descriptor.integer_range = [IntegerRange(from_value=int(self.low), to_value=int(self.high), step=0)]
        else:
            descriptor.floating_point_range = [FloatingPointRange(from_value=float(self.low),
                                                                  to_value=float(self.high), step=0.0)]
        return descriptor


_RANGES = {'resistance': (1e-3, 1e3), 'inductance': (1e-6, 10.0), 'emf_constant': (1e-3, 1e3),
           'mass': (1e-4, 1e3), 'damping': (0.0, 1e4), 'load_force': (-1e4, 1e4), 'supply_voltage': (0.1, 1e4)}
ACTUATOR_FIELDS = tuple(_RANGES)  # the ActuatorParameters fields


def actuator_specs(what):
    """Specs of the actuator parameters (Table 1 defaults); `what` starts their descriptions."""
    return [Spec(name, getattr(TABLE1, name), f'{what} {name.replace("_", " ")}, {PARAMETER_UNITS[name]}', *_RANGES[name])
            for name in _RANGES]


def declare(node, specs):
    """Declare `specs` on `node`; their values (arrays as lists, empty when unset) as a namespace. A value of
    the wrong type is a ParameterException (rclpy's check), or an InputError for an empty list where a single
    value is declared (rclpy takes that as unset)."""
    values = {}
    for spec in specs:
        parameter = node.declare_parameter(spec.name, spec.default, spec.descriptor())
        if parameter.type_ == Parameter.Type.NOT_SET and not isinstance(spec.default, Parameter.Type):
            raise InputError(f'parameter {spec.name!r} is an empty list, expecting type '
                             f'{Parameter.Type.from_parameter_value(spec.default).name!r}')
        values[spec.name] = parameter.value if parameter.type_ != Parameter.Type.NOT_SET else []
    return types.SimpleNamespace(**values)


# ---- running ----

class EmlaNode(Node):
    """A node of the suite (namespace /emla); it ends the process when `finished` becomes true (with exit
    status 2 after fail()).

    POLL_PERIOD: None for a node that handles each message as it comes (the loop's); for one outside the loop,
    a period (s): it handles every POLL_PERIOD what came meanwhile, its readers keeping the messages until
    then. A wake-up costs a process more than handling a message, and that way it wakes 1/POLL_PERIOD times a
    second, not once per message."""

    NAME = ''
    POLL_PERIOD = None

    def __init__(self):
        super().__init__(self.NAME, namespace='/emla')
        self.finished = False
        self.error = None
        self.handled = 0  # messages its subscriptions handled

    def create_subscription(self, msg_type, topic, callback, *args, **kwargs):
        """Node.create_subscription, counting the messages handled in `handled`."""
        def counted(msg):
            self.handled += 1
            callback(msg)
        return super().create_subscription(msg_type, topic, counted, *args, **kwargs)

    def ready(self):
        """What `run` says once the node is constructed: the topics it subscribed to and publishes."""
        subscribed = ', '.join(dict.fromkeys(s.topic_name for s in self.subscriptions)) or 'nothing'
        published = ', '.join(dict.fromkeys(p.topic_name for p in self.publishers
                                            if p.topic_name != '/parameter_events')) or 'nothing'
        return f'subscribed to {subscribed}; publishing {published}'

    def fail(self, message):
        """End the node for bad input found while it runs: `message` as its one line, exit status 2."""
        self.error, self.finished = message, True

    def spin(self, executor):
        """One turn of the spin loop of `run`: handle the next event (waiting for one at most 0.05 s); with a
        POLL_PERIOD, wait that long, then handle the messages that came."""
        if self.POLL_PERIOD is None:
            executor.spin_once(timeout_sec=0.05)
            return
        time.sleep(self.POLL_PERIOD)
        handled = None
        while handled != self.handled:  # one event (a subscription's messages, a timer) per spin_once
            handled = self.handled
            executor.spin_once(timeout_sec=0)

    def stop(self, executor):
        """Called once the spin loop of `run` ends: wait until readers acknowledged what was published."""
        wait_for_acknowledgements(self)


def wait_for_acknowledgements(node, timeout=ACK_TIMEOUT):
    """Wait (at most `timeout` s) until every reader acknowledged what `node` published: a reader that must
    have a message resent (a recorder behind) would lose it once the node is gone. Fast DDS learns of the
    acknowledgements at its next heartbeat, so this takes up to ~3 s."""
    deadline = time.monotonic() + timeout
    for publisher in node.publishers:
        publisher.wait_for_all_acked(Duration(seconds=max(0.0, deadline - time.monotonic())))


def use_fastdds_profiles():
    """Give the Fast DDS participants this process creates the suite's defaults (FASTDDS_PROFILES), unless a
    profiles file is set already; before rclpy.init."""
    if not (os.environ.get('FASTRTPS_DEFAULT_PROFILES_FILE') or os.environ.get('FASTDDS_DEFAULT_PROFILES_FILE')):
        os.environ['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(FASTDDS_PROFILES)


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
