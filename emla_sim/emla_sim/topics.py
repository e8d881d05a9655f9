"""Topic names and stamp arithmetic shared by the bag files and the nodes (no heavy imports: every node
process loads this)."""

NAMESPACE = '/emla/'
PARAMETERS_TOPIC = '/emla/parameters'        # online estimates of the identifier
TRUTH_TOPIC = '/emla/plant/parameters'        # the simulated plant's true parameters as they change


def signal_topic(name):
    return NAMESPACE + name


def stamp_to_ns(stamp):
    """Nanoseconds of a builtin_interfaces/Time (rclpy or rosbags message)."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
