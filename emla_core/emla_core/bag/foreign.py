"""Signals from any ROS 2 bag (MCAP or sqlite3 storage, or a bare .mcap file): the suite's own layout, or
topics of standard message types that the user maps to signals.

A mapping 'NAME=TOPIC[:FIELD[INDEX]]' takes signal NAME from:
  std_msgs/Float64, Float32            one sample per message (field `data`)
  std_msgs/Float64MultiArray, Float32MultiArray
                                       all values as consecutive samples, or one element by index: data[2]
  sensor_msgs/JointState               position, velocity or effort of a joint by index or by name:
                                       position[0], position[slider]
  emla_msgs/SampleFrame                its samples at its sample period
Time comes from each message's header stamp where it has one, else from the time it was logged. The
signals are then put on one grid (emla_core.sampling.align). The identifier node reads live topics with the
same mapping (its input_topics; emla_core.nodes.standard_topics.StandardTopics), message by message: message_values.
"""
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from emla_core.errors import InputError
from emla_core.files import path_kind, regular_file
from emla_core.recording import Recording
from emla_core.sampling import align
from emla_core.topics import NAMESPACE, SAMPLE_FRAME, SIGNALS, stamp_to_ns
from emla_core.units import SIGNAL_NAMES, parse_assignments, parse_unit

from .schema import typestore

SCALARS = ('std_msgs/msg/Float64', 'std_msgs/msg/Float32')
ARRAYS = ('std_msgs/msg/Float64MultiArray', 'std_msgs/msg/Float32MultiArray')
JOINT_STATE = 'sensor_msgs/msg/JointState'
SUPPORTED = (*SCALARS, *ARRAYS, JOINT_STATE, SAMPLE_FRAME)
_FIELD = re.compile(r'^(\w+)(?:\[([^\]]+)\])?$')


@dataclass(frozen=True)
class TopicSignal:
    """Where one signal comes from: a topic, a field of its messages and an element of that field."""
    topic: str
    field: str | None = None
    index: str | None = None      # an element number or a joint name

    def describe(self):
        return self.topic + (f':{self.field}' if self.field else '') + (f'[{self.index}]' if self.index else '')


def parse_topics(text, flag='--topics'):
    """{signal: TopicSignal} of a --topics value 'NAME=TOPIC[:FIELD[INDEX]][,...]' (`flag` names it in errors)."""
    specs = {}
    for name, value in parse_assignments(flag, text, SIGNAL_NAMES, 'TOPIC[:FIELD[INDEX]]').items():
        topic, _, field = value.partition(':')
        if not topic.startswith('/'):
            raise InputError(f'{flag} {name}={value}: a topic name starts with /')
        match = _FIELD.match(field) if field else None
        if field and not match:
            raise InputError(f'{flag} {name}={value}: expected TOPIC:FIELD or TOPIC:FIELD[INDEX]')
        specs[name] = TopicSignal(topic, *(match.groups() if match else (None, None)))
    return specs


def _reader(path):
    from rosbags.highlevel import AnyReader

    from .reader import bag_info
    if path_kind(path) == 'dir':
        bag_info(Path(path))  # its metadata and the files it names checked before rosbags opens them
    else:
        regular_file(path, 'bag file', limit=None)
    try:
        reader = AnyReader([Path(path)], default_typestore=typestore())
        reader.open()
    except Exception as exc:  # rosbags raises many kinds on a damaged bag; the user needs one line
        raise InputError(f'{path}: unreadable bag: {" ".join(str(exc).split()) or type(exc).__name__}') from None
    return reader


def suite_layout(path):
    """Whether `path` is a bag the suite's fast readers take (emla_core.bag.read_bag, iter_chunks): MCAP
    storage with SampleFrames under /emla/. A directory's metadata.yaml that cannot be read is an InputError."""
    from .reader import MCAP_ERRORS, bag_info
    path = Path(path)
    kind = path_kind(path)
    if kind == 'dir':
        info = bag_info(path)
        return info['storage_identifier'] == 'mcap' and any(
            t['topic_metadata']['name'].startswith(NAMESPACE) and t['topic_metadata']['type'] == SAMPLE_FRAME
            for t in info.get('topics_with_message_count') or ())
    if path.suffix != '.mcap':
        return False
    from mcap.reader import make_reader
    try:
        with regular_file(path, 'MCAP file', limit=None).open('rb') as f:
            summary = make_reader(f).get_summary()
    except MCAP_ERRORS:
        return False
    return summary is not None and any(
        c.topic.startswith(NAMESPACE) and summary.schemas.get(c.schema_id) is not None
        and summary.schemas[c.schema_id].name == SAMPLE_FRAME for c in summary.channels.values())


def load_bag(path, topics=None, units=None):
    """A Recording of a bag: the suite's /emla/ SampleFrames when no `topics` are given (MCAP: the fast
    path of read_bag), else the signals the --topics mapping names; `units` as for emla_core.data.load."""
    path = Path(path)
    if topics is None and units is None and suite_layout(path):
        from .reader import read_bag
        return read_bag(path).recording
    reader = _reader(path)
    try:
        connections = {c.topic: c for c in reader.connections}
        specs = parse_topics(topics) if topics is not None else _suite_topics(path, connections)
        for name, spec in specs.items():
            if spec.topic not in connections:
                raise InputError(f'{path}: --topics {name}: no topic {spec.topic}; {_listing(connections)}')
            if connections[spec.topic].msgtype not in SUPPORTED:
                raise InputError(f'{path}: {spec.topic} is {connections[spec.topic].msgtype}; --topics reads '
                                 f'{", ".join(t.split("/")[-1] for t in SUPPORTED)}')
        series, origin, timing = _read(reader, path, specs, connections)
    finally:
        reader.close()
    given_units = parse_assignments('--units', units, SIGNAL_NAMES, 'UNIT')
    inputs = {}
    for name, spec in specs.items():
        scale, unit = parse_unit(name, given_units[name]) if name in given_units else (1.0, None)
        t, values = series[name]
        series[name] = (t, values * scale)
        inputs[name] = {'topic': spec.topic, 'type': connections[spec.topic].msgtype, 'field': spec.describe(),
                        'time': timing[name], **({'unit': unit, 'scale': scale} if unit else {})}
    period, start, values, sampling = align(series, str(path))
    return Recording(sample_period=period, signals=values, start_time=origin + start, source=str(path),
                     inputs=inputs, sampling=sampling)


def _suite_topics(path, connections):
    """The suite's measured signals as a mapping (a bag of the suite's layout in sqlite3 storage), or an
    InputError that lists the bag's topics and shows the flag to use."""
    specs = {name: TopicSignal(NAMESPACE + name) for name in SIGNALS
             if NAMESPACE + name in connections and connections[NAMESPACE + name].msgtype == SAMPLE_FRAME}
    if not specs and not any(c.msgcount for c in connections.values()):   # nothing to map
        raise InputError(f'{path}: {_listing(connections)}; nothing to read')
    if not specs:
        raise InputError(f'{path}: no SampleFrame topics under {NAMESPACE}; {_listing(connections)}; map '
                         f'them with --topics, e.g. --topics voltage=/drive/voltage,current=/drive/current,'
                         f'position=/joint_states:position[0]')
    return specs


def _listing(connections):
    """'its topics: ...' of a bag's connections; that it holds no topics, or no messages on any."""
    if not connections:
        return 'the bag holds no topics (and no messages)'
    listed = ', '.join(f'{c.topic} ({c.msgtype}, {c.msgcount} messages)' for c in connections.values())
    if not any(c.msgcount for c in connections.values()):
        return f'the bag holds no messages (its topics, all empty: {listed})'
    return f'its topics: {listed}'


def _read(reader, path, specs, connections):
    """({signal: (times s since the origin, values)}, origin s, {signal: 'header stamps' | 'log time'}) of the
    mapped topics."""
    wanted = [connections[t] for t in {spec.topic for spec in specs.values()}]
    by_topic = {}
    for name, spec in specs.items():
        by_topic.setdefault(spec.topic, []).append((name, spec))
    samples = {name: ([], [], []) for name in specs}   # message times (ns), values, frame periods
    stamped = {name: True for name in specs}
    try:
        for connection, log_time, raw in reader.messages(connections=wanted):
            msg = reader.deserialize(raw, connection.msgtype)
            stamp = header_stamp(msg)
            for name, spec in by_topic[connection.topic]:
                times, values, periods = samples[name]
                if not stamp:
                    stamped[name] = False
                times.append(stamp if stamp else log_time)
                values.append(message_values(msg, connection.msgtype, spec, path))
                periods.append(getattr(msg, 'sample_period', 0.0))
    except InputError:
        raise
    except Exception as exc:  # a damaged bag: one line
        raise InputError(f'{path}: unreadable bag: {" ".join(str(exc).split()) or type(exc).__name__}') from None
    empty = [specs[name].topic for name, (times, _, _) in samples.items() if not times]
    if empty:
        raise InputError(f'{path}: no messages on {", ".join(empty)}')
    origin = min(times[0] for times, _, _ in samples.values())  # times since it, so seconds keep their precision
    series = {name: _spread(np.array(times, dtype=np.int64) - origin, values, periods, path, specs[name])
              for name, (times, values, periods) in samples.items()}
    return series, origin * 1e-9, {name: 'header stamps' if ok else 'log time' for name, ok in stamped.items()}


def header_stamp(msg):
    """The header stamp (ns) of a message (rclpy or rosbags), 0 if it has none or an unset one."""
    header = getattr(msg, 'header', None)
    return stamp_to_ns(header.stamp) if header is not None else 0


def message_values(msg, msgtype, spec, where):
    """The samples (1-D array) one message (rclpy or rosbags) of a SUPPORTED type carries for the signal
    `spec` (a TopicSignal); errors start with `where` (the bag, ...)."""
    if msgtype in SCALARS or msgtype == SAMPLE_FRAME:
        if spec.field not in (None, 'data') or spec.index is not None:
            raise InputError(f'{where}: {spec.describe()}: a {msgtype.split("/")[-1]} has only the field data')
        return np.atleast_1d(np.asarray(msg.data, dtype=float))
    if msgtype in ARRAYS:
        if spec.field not in (None, 'data'):
            raise InputError(f'{where}: {spec.describe()}: a {msgtype.split("/")[-1]} has only the field data')
        data = np.asarray(msg.data, dtype=float)
        if spec.index is None:
            return data
        return np.array([data[_element(spec, len(data), where)]])
    # JointState
    if spec.field not in ('position', 'velocity', 'effort'):
        raise InputError(f'{where}: {spec.describe()}: give the JointState field: position, velocity or effort')
    data = np.asarray(getattr(msg, spec.field), dtype=float)
    names = list(msg.name)
    if spec.index is None:
        if len(data) != 1:
            raise InputError(f'{where}: {spec.describe()}: {len(data)} joints ({", ".join(names)}); name one: '
                             f'{spec.topic}:{spec.field}[0] or [{names[0] if names else 0}]')
        return data
    if spec.index not in names:
        return np.array([data[_element(spec, len(data), where)]])
    index = names.index(spec.index)
    if index >= len(data):   # a joint without this field (an empty effort, ...)
        raise InputError(f'{where}: {spec.describe()}: {len(data)} {spec.field} values for {len(names)} joints')
    return np.array([data[index]])


def _element(spec, size, where):
    try:
        index = int(spec.index)
    except ValueError:
        raise InputError(f'{where}: {spec.describe()}: no joint or element {spec.index!r}') from None
    if not -size <= index < size:
        raise InputError(f'{where}: {spec.describe()}: element {index} of {size}')
    return index


def _spread(times, values, periods, path, spec):
    """(sample times s, samples) of a signal whose messages carry one or more consecutive samples each."""
    counts = np.array([len(v) for v in values])
    flat = np.concatenate(values)
    if np.all(counts == 1):
        return times * 1e-9, flat
    if any(periods):          # SampleFrames say their sample period
        step = np.repeat(np.asarray(periods) * 1e9, counts)
    else:                     # arrays: spread each message's samples over the steady message interval
        if len(times) < 2:
            raise InputError(f'{path}: {spec.topic}: one message of several samples carries no sample period')
        step = np.repeat(np.median(np.diff(times)) / counts, counts)
    within = np.arange(len(flat)) - np.repeat(np.cumsum(counts) - counts, counts)
    return (np.repeat(times, counts) + within * step) * 1e-9, flat
