"""The QoS profiles of the suite's topics (emla_core.topics.QOS as rclpy profiles) and the reader QoS
that matches the publishers of a standard input topic."""
import math

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from emla_core.topics import QOS


def qos_profile(kind):
    """The rclpy QoSProfile of a QoS kind of emla_core.topics.QOS."""
    qos = QOS[kind]
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=qos['depth'],
                      reliability=ReliabilityPolicy[qos['reliability'].upper()],
                      durability=DurabilityPolicy[qos['durability'].upper()])


FRAME_QOS, LATCHED_QOS, CLOCK_QOS, DIAGNOSTICS_QOS = map(qos_profile, ('frame', 'latched', 'clock', 'diagnostics'))
INPUT_DEPTH = 1000  # messages a reader of a standard input topic keeps (1 s at 1 kHz)
FRAME_HISTORY = 1.0  # s of frames a frame publisher keeps: a reader outside the loop (a recorder) may lag that much


def frame_qos(frame_period):
    """FRAME_QOS keeping FRAME_HISTORY s of frames `frame_period` s long (its own depth at least: 1 ms frames)."""
    profile = qos_profile('frame')
    profile.depth = max(profile.depth, math.ceil(FRAME_HISTORY / frame_period - 1e-9))
    return profile


def matching_qos(publishers):
    """A reader QoS the publishers (TopicEndpointInfo) all match, as `ros2 bag record` picks it: reliable and
    transient local only where every one of them is; keep last INPUT_DEPTH."""
    def offered(policy, strong, weak):
        return strong if all(getattr(p.qos_profile, policy) == strong for p in publishers) else weak
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=INPUT_DEPTH,
                      reliability=offered('reliability', ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT),
                      durability=offered('durability', DurabilityPolicy.TRANSIENT_LOCAL, DurabilityPolicy.VOLATILE))
