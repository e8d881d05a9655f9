"""What the suite's nodes share: the graph (topics, QoS), the lockstep, frames <-> numpy, parameters, spinning.

Graph (namespace /emla, SI units). A SampleFrame holds consecutive samples of one signal, stamped with the
simulated time of its first sample; the frames of control period k (Tc = n Ts, k = 0, 1, ...) are:
  voltage frames (/emla/plant/voltage, /emla/voltage, /emla/voltage_command, /emla/reference): the n values
    over [k Tc + j Ts, k Tc + (j+1) Ts), j = 0..n-1, stamp k Tc;
  state frames (/emla/plant/{current,position}, /emla/{current,position}): the n samples the period's voltage
    intervals end on, at k Tc + (j+1) Ts, stamp k Tc + Ts; so the state at (k+1) Tc, the one the command for
    period k+1 must start from, is the last sample of period k's frame. Before period 0 the plant publishes
    one state frame of a single sample: the state at t = 0, stamp 0.
Aligned by stamp (as emla_core.bag.read_bag does), the state samples at t_j pair with the voltage held over
[t_j, t_j + Ts), the Recording convention; `AlignedSamples` does this for a node.

| topic                                  | type                            | publisher  | QoS     |
|----------------------------------------|---------------------------------|------------|---------|
| /emla/plant/{voltage,current,position} | emla_msgs/SampleFrame (truth)   | plant      | FRAME   |
| /emla/plant/parameters                 | emla_msgs/ParameterEstimate     | plant      | LATCHED |
| /emla/plant/done                       | builtin_interfaces/Time         | plant      | LATCHED |
| /clock                                 | rosgraph_msgs/Clock             | plant      | CLOCK   |
| /emla/{voltage,current,position}       | emla_msgs/SampleFrame (measured)| sensor     | FRAME   |
| /emla/voltage_command, /emla/reference | emla_msgs/SampleFrame           | controller | FRAME   |
| /emla/parameters                       | emla_msgs/ParameterEstimate     | identifier | LATCHED |
| /diagnostics                           | diagnostic_msgs/DiagnosticArray | identifier | DIAGNOSTICS |
FRAME: reliable, transient local, keep last 1000 (1 s of default frames: a reader outside the loop, such as a
non-adaptive controller's identifier or a recorder, may lag that much without losing frames);
LATCHED: reliable, transient local, keep last 1 (a late subscriber gets the latest);
CLOCK: best effort, volatile, keep last 1 (as rclpy's time source subscribes); DIAGNOSTICS: reliable, 10.

Deterministic lockstep in simulated time:
1. Start: once /emla/position has `start_subscribers` subscriptions (the plant's parameter: controller,
   identifier, recorders: whoever must see every frame) and /emla/plant/done has `done_subscribers` (identifier,
   recorders, a launcher: whoever must learn the end), the plant publishes the state at t = 0.
2. Sensor: measures each state frame (pairs /emla/plant/current and /position by stamp) and publishes it with
   the same stamp; voltage frames pass unchanged to /emla/voltage.
3. Controller: from the last sample of each measured state frame (time t = stamp + (size - 1) Ts) it computes
   the command for the period starting at t (n equal values, stamp t) and the reference it tracks (also
   after the final frame: that command, for the period after the end, goes unused).
4. Plant: advances period k only with the command stamped k Tc in hand; publishes its voltage and state
   frames, then /clock = (k+1) Tc.
5. Identifier: feeds the aligned samples in time order to the estimator and publishes /emla/parameters at
   every multiple of `publish_period` that ends a period, stamped with the END of the data it covers: the
   estimate stamped t has used every voltage interval before t. An adaptive controller (its
   `adaptation_period` is a multiple of that publish_period) waits before the command for each period
   starting at t = j adaptation_period (j >= 1) for exactly the estimate stamped t. Lag: the command held from
   t on uses the estimate from all the data before t (as the in-process loop, emla_control.loop, does), so a
   plant change reaches the model at the next adaptation instant, up to adaptation_period later (plus the
   estimator's own memory).
Every message travels on a reliable, in-order topic and each node computes from its inputs alone, so a run's
samples do not depend on scheduling. Frames are transient local so that a reader that matches a publisher
late (start-up) still gets them; nothing is in flight in the loop beyond one period.

Done signal: with duration > 0 the plant advances round(duration / Tc) periods, publishes the final frames,
the final true parameters and /emla/plant/done (builtin_interfaces/Time: the end time, latched), and exits 0
once every reader acknowledged its messages (see wait_for_acknowledgements). The identifier then publishes its
final estimate stamped with that end time (if that was not a publishing instant anyway): the last
/emla/parameters message covers every sample the plant produced. A launcher waits for it, then stops the
other nodes with SIGTERM.

Each node: parameters declared read-only with descriptors (range, units in the description), defaults in the
package's config/<node>.yaml; SIGINT/SIGTERM end it cleanly with exit status 0 (after the acknowledgements
of what it published, at most ACK_TIMEOUT); bad parameters end it with one line on stderr and exit status 2.
"""
import contextlib
import dataclasses
import os
import signal
import sys
import time
import types

import numpy as np
import rclpy
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.duration import Duration
from rclpy.exceptions import ParameterException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from emla_core.errors import InputError
from emla_core.messages import frame_data
from emla_core.parameters import PARAMETER_UNITS, TABLE1
from emla_core.topics import QOS, stamp_to_ns, to_ns
from emla_msgs.msg import SampleFrame


def qos_profile(kind):
    """The rclpy QoSProfile of a QoS kind of emla_core.topics.QOS."""
    qos = QOS[kind]
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=qos['depth'],
                      reliability=ReliabilityPolicy[qos['reliability'].upper()],
                      durability=DurabilityPolicy[qos['durability'].upper()])


FRAME_QOS, LATCHED_QOS, CLOCK_QOS, DIAGNOSTICS_QOS = map(qos_profile, ('frame', 'latched', 'clock', 'diagnostics'))
ACK_TIMEOUT = 4.0  # s a stopping node waits for its readers' acknowledgements


def period_samples(sample_period, control_period):
    """Samples per control period; the control period must be a whole number of samples of whole ns."""
    n = round(control_period / sample_period)
    if n < 1 or abs(n * sample_period - control_period) > 1e-9 * control_period \
            or abs(sample_period * 1e9 - to_ns(sample_period)) > 1e-6:
        raise InputError(f'control_period ({control_period} s) must be a whole multiple of sample_period '
                         f'({sample_period} s, a whole number of ns)')
    return n


# ---- frames ----

class FrameSets:
    """Subscribes to frame topics {name: topic}; calls on_set(stamp_ns, sample_period, {name: array}) once
    every topic has delivered its frame with that stamp (in stamp order: each topic is in order). With
    `sample_period` given, frames of another sample period are dropped; drops and gaps (lost frames: the
    run is no longer deterministic) are logged as errors."""

    def __init__(self, node, topics, on_set, sample_period=None):
        self._log = node.get_logger()
        self._on_set = on_set
        self._step = None if sample_period is None else to_ns(sample_period)
        self._next = dict.fromkeys(topics)  # name -> the stamp its next frame must have
        self._pending = {}
        for name, topic in topics.items():
            node.create_subscription(SampleFrame, topic, lambda msg, name=name: self._receive(name, msg), FRAME_QOS)

    def _receive(self, name, msg):
        step = to_ns(msg.sample_period)
        if self._step not in (None, step):
            self._log.error(f'dropped {name} frames of sample period {msg.sample_period} s (the sample_period '
                            f'parameter is {self._step * 1e-9} s)', throttle_duration_sec=5.0)
            return
        stamp = stamp_to_ns(msg.header.stamp)
        if self._next[name] not in (None, stamp):
            self._log.error(f'{name} frames missing from {self._next[name]} to {stamp} ns')
        self._next[name] = stamp + len(msg.data) * step
        frames = self._pending.setdefault(stamp, {})
        frames[name] = frame_data(msg)
        if len(frames) == len(self._next):
            del self._pending[stamp]
            self._on_set(stamp, msg.sample_period, frames)


class AlignedSamples:
    """Subscribes to frame topics {name: topic} of one sample period and calls on_samples(start_ns, {name:
    array}) with the samples all of them have at the same instants, in time order, as soon as they have them,
    in chunks that never straddle a multiple of `boundary` (ns), so those instants are always chunk ends.
    The graph's frames (state frames one sample later than voltage frames) come out in the Recording
    convention, the estimator's input: the state samples where each voltage interval starts. Frames aligned
    already (a bag of `emla simulate` played) pass as they are."""

    def __init__(self, node, topics, on_samples, sample_period, boundary):
        self._on_samples = on_samples
        self._step = to_ns(sample_period)
        self._boundary = boundary
        self._cursor = None  # the first instant not passed on yet
        self._queues = {name: [] for name in topics}  # name -> [(stamp, samples)] not passed on yet
        self._frames = [FrameSets(node, {name: topic}, self._receive, sample_period)
                        for name, topic in topics.items()]

    def _receive(self, stamp, sample_period, frames):
        ((name, samples),) = frames.items()
        self._queues[name].append((stamp, samples))
        while all(self._queues.values()):
            if self._cursor is None:
                self._cursor = max(queue[0][0] for queue in self._queues.values())
            last_frames = (queue[-1] for queue in self._queues.values())
            covered = min(stamp + len(samples) * self._step for stamp, samples in last_frames)
            end = min(covered, (self._cursor // self._boundary + 1) * self._boundary)
            if end <= self._cursor:
                return
            chunk = {name: self._take(queue, end) for name, queue in self._queues.items()}
            start, self._cursor = self._cursor, end
            self._on_samples(start, chunk)

    def _take(self, queue, end):
        """The queued samples at the instants [cursor, end); later ones stay queued."""
        parts = []
        while queue:
            stamp, samples = queue[0]
            first, last = max(0, (self._cursor - stamp) // self._step), (end - stamp) // self._step
            parts.append(samples[first:last])
            if last < len(samples):
                queue[0] = (stamp + last * self._step, samples[last:])
                break
            queue.pop(0)
        return parts[0] if len(parts) == 1 else np.concatenate(parts)


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
    """Declare `specs` on `node`; their values (arrays as lists, empty when unset) as a namespace."""
    values = {}
    for spec in specs:
        parameter = node.declare_parameter(spec.name, spec.default, spec.descriptor())
        values[spec.name] = parameter.value if parameter.type_ != Parameter.Type.NOT_SET else []
    return types.SimpleNamespace(**values)


# ---- running ----

class EmlaNode(Node):
    """A node of the suite (namespace /emla); it ends the process when `finished` becomes true."""

    NAME = ''

    def __init__(self):
        super().__init__(self.NAME, namespace='/emla')
        self.finished = False

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


def run(node_class, args=None):
    """Run one node (an EmlaNode class) until it finishes or SIGINT/SIGTERM arrives, then its stop()
    (by default: wait for the acknowledgements of what it published); the exit status.

    args: the command line with ROS arguments (default sys.argv)."""
    stopping = []
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stopping.append(True))
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = node_class()
    except (InputError, ValueError, ParameterException) as error:
        print(f'{node_class.NAME}: error: {error}', file=sys.stderr)
        rclpy.shutdown()
        return 2
    executor = EventsExecutor()  # its spin_once() loop (not spin_until_future_complete) fires timers too
    executor.add_node(node)
    try:
        while not stopping and not node.finished:
            executor.spin_once(timeout_sec=0.05)
        node.stop(executor)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
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
