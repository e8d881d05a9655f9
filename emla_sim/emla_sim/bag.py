"""rosbag2 directories (metadata.yaml + zstd-chunked MCAP) of the suite's topics: writing and reading.

The writer splits a bag into several MCAP files. Each split is finished (summary and footer written)
before metadata.yaml is rewritten atomically to list it, so a recorder killed at any moment leaves a bag
that rosbags, mcap-ros2-support and `emla` read up to the last finished split.
"""
import copy
import os
import struct
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from emla_sim.errors import InputError
from emla_sim.recording import Recording

SAMPLE_FRAME = 'emla_msgs/msg/SampleFrame'
PARAMETER_ESTIMATE = 'emla_msgs/msg/ParameterEstimate'
ARX_MODEL = 'emla_msgs/msg/ArxModel'
NAMESPACE = '/emla/'
PARAMETERS_TOPIC = '/emla/parameters'        # online estimates of the identifier
TRUTH_TOPIC = '/emla/plant/parameters'        # the simulated plant's true parameters as they change
ESTIMATE_FIELDS = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping', 'load_force')

# QoS offered by the suite's publishers, as rosbag2 stores it (REP-2012 v9 layout).
_QOS = {'history': 'keep_last', 'depth': 100, 'reliability': 'reliable', 'durability': 'volatile',
        'deadline': {'sec': 0, 'nsec': 0}, 'lifespan': {'sec': 0, 'nsec': 0}, 'liveliness': 'automatic',
        'liveliness_lease_duration': {'sec': 0, 'nsec': 0}, 'avoid_ros_namespace_conventions': False}


def signal_topic(name):
    return NAMESPACE + name


def msg_directory():
    """Where emla_msgs' .msg files are installed (the ament prefixes, then this Python's prefix)."""
    prefixes = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p] + [sys.prefix]
    for prefix in prefixes:
        candidate = Path(prefix) / 'share' / 'emla_msgs' / 'msg'
        if candidate.is_dir():
            return candidate
    raise InputError('emla_msgs is not installed (no share/emla_msgs/msg); run `make setup`')


_TYPESTORE = None


def typestore():
    """A rosbags typestore (Jazzy) with the emla_msgs types registered from their installed .msg files."""
    global _TYPESTORE
    if _TYPESTORE is None:
        store = get_typestore(Stores.ROS2_JAZZY)
        types = {}
        for msg in sorted(msg_directory().glob('*.msg')):
            types.update(get_types_from_msg(msg.read_text(), f'emla_msgs/msg/{msg.stem}'))
        store.register(types)
        _TYPESTORE = store
    return _TYPESTORE


def stamp_to_ns(stamp):
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def ns_to_stamp(ns):
    store = typestore()
    return store.types['builtin_interfaces/msg/Time'](sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000))


def sample_frame(stamp_ns, sample_period, data, frame_id=''):
    """A SampleFrame message object (rosbags type) for serialisation."""
    store = typestore()
    header = store.types['std_msgs/msg/Header'](stamp=ns_to_stamp(stamp_ns), frame_id=frame_id)
    return store.types[SAMPLE_FRAME](header=header, sample_period=float(sample_period),
                                     data=np.ascontiguousarray(data, dtype=np.float64))


@dataclass
class _Split:
    path: Path
    stream: object
    writer: Writer
    channels: dict = field(default_factory=dict)   # topic -> MCAP channel id
    counts: dict = field(default_factory=dict)     # topic -> messages
    start: int = 2**63 - 1
    end: int = 0
    count: int = 0
    size: int = 0


class BagWriter:
    """Writes a rosbag2 directory; use as a context manager or call close()."""

    def __init__(self, path, *, split_size=2 * 2**20, chunk_size=256 * 2**10, custom_data=None):
        self.path = Path(path)
        if self.path.exists() and any(self.path.iterdir()):
            raise InputError(f'{self.path}: exists and is not empty; choose a new bag directory')
        self.path.mkdir(parents=True, exist_ok=True)
        self.split_size = split_size
        self.chunk_size = chunk_size
        self.custom_data = {str(k): str(v) for k, v in (custom_data or {}).items()}
        self.topics = {}          # topic -> msgtype
        self.counts = {}          # topic -> messages in finished splits
        self.finished = []        # metadata of finished splits
        self._split = None

    def add_topic(self, topic, msgtype):
        if topic not in self.topics:
            self.topics[topic] = msgtype
            self.counts[topic] = 0

    def write_message(self, topic, stamp_ns, message):
        self.write(topic, stamp_ns, typestore().serialize_cdr(message, self.topics[topic]))

    def write(self, topic, stamp_ns, data):
        """Store serialised (CDR) `data` on `topic` at time `stamp_ns`."""
        split = self._split or self._open_split()
        channel = split.channels.get(topic)
        if channel is None:
            channel = split.channels[topic] = self._register(split.writer, topic)
        split.writer.add_message(channel, log_time=stamp_ns, data=bytes(data), publish_time=stamp_ns)
        split.start = min(split.start, stamp_ns)
        split.end = max(split.end, stamp_ns)
        split.count += 1
        split.size += len(data)
        split.counts[topic] = split.counts.get(topic, 0) + 1
        if split.size >= self.split_size:
            self._finish_split()

    def _register(self, writer, topic):
        msgtype = self.topics[topic]
        msgdef, _ = typestore().generate_msgdef(msgtype, ros_version=2)
        schema = writer.register_schema(name=msgtype, encoding='ros2msg', data=msgdef.encode())
        qos = yaml.safe_dump([_QOS], default_flow_style=False)
        return writer.register_channel(topic=topic, message_encoding='cdr', schema_id=schema,
                                       metadata={'offered_qos_profiles': qos})

    def _open_split(self):
        path = self.path / f'{self.path.name}_{len(self.finished)}.mcap'
        stream = path.open('wb')
        writer = Writer(stream, chunk_size=self.chunk_size, compression=CompressionType.ZSTD)
        writer.start(profile='ros2', library='emla')
        self._split = _Split(path=path, stream=stream, writer=writer)
        return self._split

    def _finish_split(self):
        split, self._split = self._split, None
        split.writer.finish()
        split.stream.flush()
        os.fsync(split.stream.fileno())
        split.stream.close()
        for topic, n in split.counts.items():
            self.counts[topic] += n
        self.finished.append({'path': split.path.name, 'starting_time': {'nanoseconds_since_epoch': split.start},
                              'duration': {'nanoseconds': split.end - split.start}, 'message_count': split.count})
        self._write_metadata()

    def _write_metadata(self):
        store = typestore()
        start = min((f['starting_time']['nanoseconds_since_epoch'] for f in self.finished), default=0)
        end = max((f['starting_time']['nanoseconds_since_epoch'] + f['duration']['nanoseconds']
                   for f in self.finished), default=0)
        info = {
            'version': 9,
            'storage_identifier': 'mcap',
            'relative_file_paths': [f['path'] for f in self.finished],
            'duration': {'nanoseconds': end - start},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': sum(f['message_count'] for f in self.finished),
            'topics_with_message_count': [
                {'topic_metadata': {'name': topic, 'type': msgtype, 'serialization_format': 'cdr',
                                    'offered_qos_profiles': [copy.deepcopy(_QOS)],
                                    'type_description_hash': store.hash_rihs01(msgtype)},
                 'message_count': self.counts[topic]}
                for topic, msgtype in self.topics.items()],
            'compression_format': '',
            'compression_mode': '',
            'files': self.finished,
            'custom_data': self.custom_data or None,
            'ros_distro': 'jazzy',
        }
        tmp = self.path / 'metadata.yaml.tmp'
        with tmp.open('w') as f:
            yaml.safe_dump({'rosbag2_bagfile_information': info}, f, default_flow_style=False, sort_keys=False)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.path / 'metadata.yaml')

    def close(self):
        if self._split is not None:
            self._finish_split()
        elif not self.finished:
            self._write_metadata()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def write_recording(recording, path, *, frame_size=100, estimates=(), custom_data=None):
    """Write a Recording as SampleFrames of `frame_size` samples per signal topic, plus parameter estimates.

    `estimates` is a sequence of (time_s, {name: value}) written as ParameterEstimate messages.
    """
    period = recording.sample_period
    start_ns = round(recording.start_time * 1e9)
    data = dict(recording.metadata)
    data.update(custom_data or {})
    with BagWriter(path, custom_data=data) as bag:
        for name in recording.signals:
            bag.add_topic(signal_topic(name), SAMPLE_FRAME)
        if len(estimates):
            bag.add_topic(PARAMETERS_TOPIC, PARAMETER_ESTIMATE)
        pending = sorted(estimates, key=lambda e: e[0])
        for first in range(0, len(recording), frame_size):
            stamp = start_ns + round(first * period * 1e9)
            for name, values in recording.signals.items():
                bag.write_message(signal_topic(name), stamp,
                                  sample_frame(stamp, period, values[first:first + frame_size]))
            frame_end = recording.start_time + (first + frame_size) * period
            while pending and pending[0][0] < frame_end:
                t, values = pending.pop(0)
                bag.write_message(PARAMETERS_TOPIC, round(t * 1e9), parameter_estimate(round(t * 1e9), values))


def parameter_estimate(stamp_ns, values, std=None, samples_used=0, residual_rms=float('nan')):
    """A ParameterEstimate (rosbags type); names missing from `values` are NaN."""
    store = typestore()
    header = store.types['std_msgs/msg/Header'](stamp=ns_to_stamp(stamp_ns), frame_id='')
    std = std or {}
    nan = float('nan')
    cov = np.full(36, nan)
    sd = np.array([std.get(k, nan) for k in ESTIMATE_FIELDS], dtype=float)
    cov[::7] = sd ** 2
    return store.types[PARAMETER_ESTIMATE](
        header=header, **{k: float(values.get(k, nan)) for k in ESTIMATE_FIELDS}, std=sd, covariance=cov,
        samples_used=int(samples_used), residual_rms=float(residual_rms))


@dataclass
class BagContents:
    recording: Recording
    estimates: list        # [(time_s, {name: value}, {name: std})] from /emla/parameters, in time order
    truth: list            # [(time_s, {name: value})] from /emla/plant/parameters (simulated runs only)
    metadata: dict         # custom_data of the bag


def _mcap_files(path):
    if path.is_file():
        return [path], {}
    meta_path = path / 'metadata.yaml'
    if not meta_path.exists():
        raise InputError(f'{path}: not a rosbag2 directory (no metadata.yaml)')
    try:
        info = yaml.safe_load(meta_path.read_text())['rosbag2_bagfile_information']
    except (yaml.YAMLError, KeyError, TypeError) as exc:
        problem = ' '.join(str(exc).split())   # YAML errors span several lines
        raise InputError(f'{meta_path}: unreadable metadata: {problem}') from None
    if info.get('storage_identifier') != 'mcap':
        raise InputError(f'{path}: storage {info.get("storage_identifier")!r} is not supported (mcap only)')
    return [path / p for p in info.get('relative_file_paths', [])], dict(info.get('custom_data') or {})


def iter_messages(path, topics=None):
    """(topic, msgtype, stamp_ns, message) of a bag directory or .mcap file, file by file."""
    path = Path(path)
    if not path.exists():
        raise InputError(f'{path}: no such file or directory')
    store = typestore()
    files, _ = _mcap_files(path)
    for file in files:
        try:
            with file.open('rb') as f:
                for schema, channel, message in make_reader(f).iter_messages(topics=topics):
                    yield channel.topic, schema.name, message.log_time, store.deserialize_cdr(message.data,
                                                                                               schema.name)
        except (McapError, OSError, ValueError, KeyError, EOFError, IndexError, struct.error) as exc:
            raise InputError(f'{file}: unreadable MCAP: {" ".join(str(exc).split()) or type(exc).__name__}') from None


def read_bag(path):
    """The signals (assembled from SampleFrames), parameter estimates and custom metadata of a bag."""
    path = Path(path)
    if not path.exists():
        raise InputError(f'{path}: no such file or directory')
    _, custom = _mcap_files(path)
    frames, estimates, truth = {}, [], []
    for topic, msgtype, stamp, msg in iter_messages(path):
        if msgtype == SAMPLE_FRAME and topic.startswith(NAMESPACE):
            frames.setdefault(topic[len(NAMESPACE):], []).append(
                (stamp_to_ns(msg.header.stamp), msg.sample_period, np.asarray(msg.data, dtype=float)))
        elif msgtype == PARAMETER_ESTIMATE and topic in (PARAMETERS_TOPIC, TRUTH_TOPIC):
            stamp_s = stamp_to_ns(msg.header.stamp) * 1e-9
            values = {k: getattr(msg, k) for k in ESTIMATE_FIELDS if np.isfinite(getattr(msg, k))}
            if topic == TRUTH_TOPIC:
                truth.append((stamp_s, values))
            else:
                estimates.append((stamp_s, values, {k: s for k, s in zip(ESTIMATE_FIELDS, msg.std) if np.isfinite(s)}))
    if not frames:
        raise InputError(f'{path}: no SampleFrame topics under {NAMESPACE}')
    estimates.sort(key=lambda e: e[0])
    truth.sort(key=lambda e: e[0])
    return BagContents(recording=_assemble(frames, path, custom), estimates=estimates, truth=truth,
                       metadata=custom)


def _assemble(frames, path, custom):
    """Concatenate each signal's frames and cut all signals to the time span they share."""
    periods = {p for fs in frames.values() for _, p, _ in fs}
    if len(periods) != 1:
        raise InputError(f'{path}: frames have different sample periods {sorted(periods)}')
    period = periods.pop()
    if not period > 0:
        raise InputError(f'{path}: sample period {period} is not positive')
    series = {}
    for name, fs in frames.items():
        fs.sort(key=lambda f: f[0])
        start = fs[0][0]
        expected = start
        for stamp, _, data in fs:
            if abs(stamp - expected) > 0.5 * period * 1e9:
                raise InputError(f'{path}: /emla/{name} has a gap or overlap at t = {stamp * 1e-9:.6f} s')
            expected = stamp + round(len(data) * period * 1e9)
        series[name] = (start, np.concatenate([d for _, _, d in fs]))
    first = max(s for s, _ in series.values())
    last = min(s + round(len(d) * period * 1e9) for s, d in series.values())
    if last <= first:
        raise InputError(f'{path}: the signal topics share no time span')
    n = round((last - first) * 1e-9 / period)
    signals = {}
    for name, (start, data) in series.items():
        offset = round((first - start) * 1e-9 / period)
        signals[name] = data[offset:offset + n]
    return Recording(sample_period=period, signals=signals, start_time=first * 1e-9, source=str(path),
                     metadata=custom)
