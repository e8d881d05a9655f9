"""What the suite's four nodes share: the graph (topics, QoS), the lockstep, frames <-> numpy, parameters, spinning.

Graph (namespace /emla, SI units; every SampleFrame carries the samples of one control period, stamped with
the simulated time of its first sample):

| topic                           | type                             | publisher  | QoS                                  |
|---------------------------------|----------------------------------|------------|--------------------------------------|
| /emla/plant/{voltage,current,position} | emla_msgs/SampleFrame     | plant      | FRAME: reliable, transient local, 100 |
| /emla/plant/parameters          | emla_msgs/ParameterEstimate      | plant      | LATCHED: reliable, transient local, 1 |
| /emla/plant/done                | builtin_interfaces/Time          | plant      | LATCHED                              |
| /clock                          | rosgraph_msgs/Clock              | plant      | CLOCK: best effort, volatile, 1      |
| /emla/{voltage,current,position}| emla_msgs/SampleFrame            | sensor     | FRAME                                |
| /emla/voltage_command           | emla_msgs/SampleFrame            | controller | FRAME                                |
| /emla/reference                 | emla_msgs/SampleFrame            | controller | FRAME                                |
| /emla/parameters                | emla_msgs/ParameterEstimate      | identifier | LATCHED                              |
| /diagnostics                    | diagnostic_msgs/DiagnosticArray  | identifier | reliable, volatile, 10               |

Deterministic lockstep (control period Tc = n sample periods Ts, period k covers [k Tc, (k+1) Tc)):
1. The controller publishes /emla/voltage_command for period 0 at start (from the reference and the
   initial position), then command k+1 once it has the measured frames of period k (and, when adapting,
   the estimate due at (k+1) Tc, see 4).
2. The plant advances period k only when it holds command k (stamp k Tc, n samples) and, before period 0,
   once /emla/position has `start_subscribers` subscriptions (controller, identifier, recorders: whoever
   must see every frame). It publishes /emla/plant/* frames of period k: the applied (clipped) voltage and
   the true current and position at k Tc + j Ts, j = 0..n-1 (the state at the start of each ZOH interval,
   aligned with the voltage held over it), then /clock = (k+1) Tc.
3. The sensor turns each complete set of plant frames into /emla/* frames (same stamp; the voltage passes
   unchanged, the current and position are measured).
4. The identifier feeds every measured sample to the estimator in order and publishes /emla/parameters after
   every `publish_period` (a multiple of Tc), stamped with the END of the data it covers: the estimate stamped
   t has used every sample before t. An adaptive controller with `adaptation_period` (a multiple of the
   identifier's publish_period) waits, before computing the command for the period starting at t = j *
   adaptation_period, for exactly the estimate stamped t and takes it. Lag: the command applied from t on
   uses the samples up to t - Ts (one control period of computation delay, as on a DSP).
Every message crosses a reliable, in-order topic and each node computes from its inputs alone, so the
samples of a run do not depend on scheduling. Frames are transient local (depth 100) so a node that matches a
publisher late (start-up) still gets every frame.

Done signal: with duration > 0 the plant advances round(duration / Tc) periods, publishes the final frames,
the final true parameters and /emla/plant/done (builtin_interfaces/Time = the end time, latched), waits
(bounded) until every reader acknowledged its messages, and exits 0. The identifier publishes its final
estimate, stamped with that end time, once it has used every sample before it; a launcher waits for the
/emla/parameters message with that stamp, then stops the other nodes with SIGTERM.

Each node: parameters declared read-only with descriptors (range, units in the description), defaults in the
package's config/<node>.yaml; SIGINT/SIGTERM end it cleanly with exit status 0; bad parameters end it with one
line on stderr and exit status 2.
"""
import array
import dataclasses
import signal
import sys
import types

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from emla_msgs.msg import ParameterEstimate, SampleFrame
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import ParameterException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from emla_sim.bag import PARAMETERS_TOPIC, TRUTH_TOPIC, signal_topic
from emla_sim.errors import InputError
from emla_sim.parameters import PARAMETER_NAMES, TABLE1

SIGNALS = ('voltage', 'current', 'position')
PLANT_TOPICS = {name: f'/emla/plant/{name}' for name in SIGNALS}
MEASURED_TOPICS = {name: signal_topic(name) for name in SIGNALS}
COMMAND_TOPIC = signal_topic('voltage_command')
REFERENCE_TOPIC = signal_topic('reference')
ESTIMATE_TOPIC = PARAMETERS_TOPIC
TRUE_PARAMETERS_TOPIC = TRUTH_TOPIC
DONE_TOPIC = '/emla/plant/done'
START_TOPIC = MEASURED_TOPICS['position']  # the plant's start barrier counts this topic's subscriptions
CLOCK_TOPIC = '/clock'
DIAGNOSTICS_TOPIC = '/diagnostics'

FRAME_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
CLOCK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
DIAGNOSTICS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE)


# ---- time: integer nanoseconds, so that stamps of consecutive periods are exact ----

def to_ns(seconds):
    return int(round(seconds * 1e9))


def stamp_ns(stamp):
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def time_msg(ns):
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def period_samples(sample_period, control_period):
    """Samples per control period; the control period must be a whole number of samples of whole ns."""
    n = round(control_period / sample_period)
    if n < 1 or abs(n * sample_period - control_period) > 1e-9 * control_period \
            or abs(sample_period * 1e9 - to_ns(sample_period)) > 1e-6:
        raise InputError(f'control_period ({control_period} s) must be a whole multiple of sample_period '
                         f'({sample_period} s, a whole number of ns)')
    return n


# ---- frames ----

def frame_message(stamp, sample_period, data):
    """A SampleFrame of `data` (1-D float64) with its first sample at `stamp` (ns)."""
    msg = SampleFrame(sample_period=float(sample_period))
    msg.header.stamp = time_msg(stamp)
    msg.data = array.array('d', np.ascontiguousarray(data, dtype=np.float64).tobytes())
    return msg


def frame_data(msg):
    """The samples of a received SampleFrame as a read-only float64 array over the message's buffer."""
    return np.frombuffer(msg.data, dtype=np.float64)


class FrameSets:
    """Subscribes to several frame topics and calls on_set(stamp_ns, sample_period, {name: array}) once
    every topic has delivered its frame with that stamp (in stamp order, as the topics are in order)."""

    def __init__(self, node, topics, on_set):
        self._names = tuple(topics)
        self._on_set = on_set
        self._pending = {}
        for name, topic in topics.items():
            node.create_subscription(SampleFrame, topic, lambda msg, name=name: self._receive(name, msg), FRAME_QOS)

    def _receive(self, name, msg):
        stamp = stamp_ns(msg.header.stamp)
        frames = self._pending.setdefault(stamp, {})
        frames[name] = frame_data(msg)
        if len(frames) == len(self._names):
            del self._pending[stamp]
            self._on_set(stamp, msg.sample_period, frames)


def frame_publishers(node, topics):
    return {name: node.create_publisher(SampleFrame, topic, FRAME_QOS) for name, topic in topics.items()}


def publish_frames(publishers, stamp, sample_period, frames):
    for name, publisher in publishers.items():
        publisher.publish(frame_message(stamp, sample_period, frames[name]))


# ---- parameter estimates ----

def estimate_message(stamp, values, std=None, covariance=None, samples=0, residual_rms=float('nan')):
    """A ParameterEstimate; names missing from `values`/`std` are NaN, a missing covariance is NaN."""
    msg = ParameterEstimate(samples_used=int(samples), residual_rms=float(residual_rms))
    msg.header.stamp = time_msg(stamp)
    for name in PARAMETER_NAMES:
        setattr(msg, name, float(values.get(name, float('nan'))))
    std = std or {}
    msg.std = [float(std.get(name, float('nan'))) for name in PARAMETER_NAMES]
    msg.covariance = np.full(36, np.nan) if covariance is None else np.asarray(covariance, float).ravel()
    return msg


def estimate_values(msg):
    """{name: value} of a ParameterEstimate (NaN for what the estimator does not identify)."""
    return {name: getattr(msg, name) for name in PARAMETER_NAMES}


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


_UNITS = {'resistance': 'ohm', 'inductance': 'H', 'emf_constant': 'V s/m (= N/A)', 'mass': 'kg',
          'damping': 'N s/m', 'load_force': 'N (opposes +x)', 'supply_voltage': 'V'}
_RANGES = {'resistance': (1e-3, 1e3), 'inductance': (1e-6, 10.0), 'emf_constant': (1e-3, 1e3),
           'mass': (1e-4, 1e3), 'damping': (0.0, 1e4), 'load_force': (-1e4, 1e4), 'supply_voltage': (0.1, 1e4)}


def actuator_specs(what):
    """Specs of the actuator parameters (Table 1 defaults), e.g. what='true' or 'nominal (initial model)'."""
    return [Spec(name, getattr(TABLE1, name), f'{what} {name.replace("_", " ")}, {_UNITS[name]}', *_RANGES[name])
            for name in _UNITS]


def declare(node, specs):
    """Declare `specs` on `node`; their values (arrays as lists, empty when unset) as a namespace."""
    values = {}
    for spec in specs:
        parameter = node.declare_parameter(spec.name, spec.default, spec.descriptor())
        values[spec.name] = parameter.value if parameter.type_ != Parameter.Type.NOT_SET else []
    return types.SimpleNamespace(**values)


# ---- running ----

def run(node_class, args=None):
    """Run one node until it finishes or SIGINT/SIGTERM arrives; the process exit status."""
    stopping = []
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stopping.append(True))
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
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


class EmlaNode(Node):
    """A node of the suite (namespace /emla); it ends the process when `finished` becomes true."""

    NAME = ''

    def __init__(self):
        super().__init__(self.NAME, namespace='/emla')
        self.finished = False


def main(node_class):
    """A console_scripts entry point for `node_class`: its exit status (args from sys.argv)."""
    return run(node_class, sys.argv)
