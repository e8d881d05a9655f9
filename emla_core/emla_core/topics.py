"""The suite's topics: names, message types and the QoS each is published with (plain data, no rclpy, so
every process, and the bag writer, can load it cheaply).

Graph (namespace /emla, SI units). A SampleFrame holds consecutive samples of one signal, stamped with the
time of its first sample. Which node publishes what, and the lockstep between them, is described in
emla_core.nodes.
"""

NAMESPACE = '/emla/'
SIGNALS = ('voltage', 'current', 'position')   # the signals of the graph's frames

SAMPLE_FRAME = 'emla_msgs/msg/SampleFrame'
PARAMETER_ESTIMATE = 'emla_msgs/msg/ParameterEstimate'
ARX_MODEL = 'emla_msgs/msg/ArxModel'
EFFECT_ESTIMATE = 'emla_msgs/msg/EffectEstimate'
SIGNAL_FRAMES = 'emla_msgs/msg/SignalFrames'
TIME = 'builtin_interfaces/msg/Time'


def signal_topic(name):
    """The measured signal `name`'s topic, e.g. /emla/current."""
    return NAMESPACE + name


PLANT_TOPICS = {name: f'{NAMESPACE}plant/{name}' for name in SIGNALS}      # true values (plant), recorded
PLANT_FRAMES_TOPIC = f'{NAMESPACE}plant/frames'                           # the same per period in one message (sensor)
MEASURED_TOPICS = {name: signal_topic(name) for name in SIGNALS}          # sampled values (sensor)
MEASURED_FRAMES_TOPIC = signal_topic('frames')                            # the same per period in one message
COMMAND_TOPIC = signal_topic('voltage_command')                           # controller -> plant
REFERENCE_TOPIC = signal_topic('reference')                               # the position the controller tracks
PARAMETERS_TOPIC = signal_topic('parameters')                             # the identifier's online estimates
ARX_MODEL_TOPIC = signal_topic('arx_model')                               # its online ARX model (model arx)
EFFECTS_TOPIC = signal_topic('effects')                                   # its effects' parameters (with effects)
POSITION_ESTIMATE_TOPIC = signal_topic('position_estimate')               # a solenoid's position from its coil
TRUE_PARAMETERS_TOPIC = f'{NAMESPACE}plant/parameters'                    # the simulated plant's true parameters
DONE_TOPIC = f'{NAMESPACE}plant/done'                                     # the end time of a run
START_TOPIC = MEASURED_TOPICS['position']   # the plant's start barrier counts this topic's subscriptions
CLOCK_TOPIC = '/clock'
DIAGNOSTICS_TOPIC = '/diagnostics'

# The graph's rhythm (the nodes' defaults; `emla simulate` writes its bags in the same frames): one
# SampleFrame per signal per control period, one parameter estimate per estimate period; the plant's true
# frames, which only a recorder reads, one per estimate period.
CONTROL_PERIOD = 1e-3   # s
ESTIMATE_PERIOD = 0.01  # s

# QoS of the suite's publishers (see emla_core.nodes for why):
# frame: reliable, transient local, keep last 1000 (1 s of 1 ms frames: a reader outside the loop may lag
#   that much without losing frames); latched: reliable, transient local, keep last 1 (a late subscriber gets
#   the latest); clock: best effort, volatile, keep last 1 (as rclpy's time source subscribes);
# diagnostics: reliable, volatile, keep last 10.
QOS = {
    'frame': {'reliability': 'reliable', 'durability': 'transient_local', 'depth': 1000},
    'latched': {'reliability': 'reliable', 'durability': 'transient_local', 'depth': 1},
    'clock': {'reliability': 'best_effort', 'durability': 'volatile', 'depth': 1},
    'diagnostics': {'reliability': 'reliable', 'durability': 'volatile', 'depth': 10},
}

# What a run records: topic -> (message type, QoS kind). `emla launch` (the recorder node) and
# `emla simulate` write exactly these.
RECORDED = {
    **{topic: (SAMPLE_FRAME, 'frame') for topic in PLANT_TOPICS.values()},
    **{topic: (SAMPLE_FRAME, 'frame') for topic in MEASURED_TOPICS.values()},
    COMMAND_TOPIC: (SAMPLE_FRAME, 'frame'),
    REFERENCE_TOPIC: (SAMPLE_FRAME, 'frame'),
    TRUE_PARAMETERS_TOPIC: (PARAMETER_ESTIMATE, 'frame'),  # the record's truth: every change kept
    PARAMETERS_TOPIC: (PARAMETER_ESTIMATE, 'latched'),
    EFFECTS_TOPIC: (EFFECT_ESTIMATE, 'latched'),
    DONE_TOPIC: (TIME, 'latched'),
}
# Recorded topics only some runs publish, by actuator family: a recorder does not wait for them (a moving coil's
# identifier publishes /emla/effects only with effects; a solenoid's follows the coil's R there, and not on
# /emla/parameters, whose fields are the moving coil's).
OPTIONAL = {'moving_coil': (EFFECTS_TOPIC,), 'solenoid': (PARAMETERS_TOPIC,)}
# The suite's topics a run does not record, as above: the identifier's in ARX mode (a run's identifier is a
# grey-box one, for the controller; the recorder's start barrier waits for a publisher of each recorded topic)
# or a solenoid's observer's, and the frames of each period in one message, for the loop's nodes (recorded as
# PLANT_TOPICS, MEASURED_TOPICS).
UNRECORDED = {ARX_MODEL_TOPIC: (ARX_MODEL, 'latched'), POSITION_ESTIMATE_TOPIC: (SAMPLE_FRAME, 'frame'),
              PLANT_FRAMES_TOPIC: (SIGNAL_FRAMES, 'frame'), MEASURED_FRAMES_TOPIC: (SIGNAL_FRAMES, 'frame')}


def qos_kind(topic, msgtype):
    """The QoS kind a topic is published with: its own if the suite knows it, else by message type."""
    known = RECORDED.get(topic) or UNRECORDED.get(topic)
    if known:
        return known[1]
    return 'frame' if msgtype == SAMPLE_FRAME else 'latched' if msgtype == PARAMETER_ESTIMATE else 'diagnostics'


def stamp_to_ns(stamp):
    """Nanoseconds of a builtin_interfaces/Time (rclpy or rosbags message)."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def to_ns(seconds):
    """Whole nanoseconds of a time in s (stamps of consecutive periods stay exact in integers)."""
    return int(round(seconds * 1e9))
