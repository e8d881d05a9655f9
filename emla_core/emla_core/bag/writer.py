"""Writing rosbag2 directories: BagWriter (crash-safe splits) and write_recording.

The writer splits a bag into several MCAP files. Each split is finished (summary and footer written) before
metadata.yaml is rewritten atomically to list it, so a recorder killed at any moment leaves a bag that
rosbags, mcap-ros2-support and `emla` read up to the last finished split. Each topic's metadata carries the
QoS the suite publishes it with (emla_core.topics), as `ros2 bag record` stores the offered QoS.
"""
import os
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from mcap.writer import CompressionType, Writer

from emla_core.errors import InputError
from emla_core.messages import estimate_message, frame_message, serialize
from emla_core.topics import PARAMETER_ESTIMATE, PARAMETERS_TOPIC, QOS, SAMPLE_FRAME, qos_kind, signal_topic, to_ns

from .schema import typestore

_ZERO = {'sec': 0, 'nsec': 0}


def offered_qos(topic, msgtype):
    """The QoS profile of `topic` as rosbag2 stores it (metadata version 9)."""
    qos = QOS[qos_kind(topic, msgtype)]
    return {'history': 'keep_last', 'depth': qos['depth'], 'reliability': qos['reliability'],
            'durability': qos['durability'], 'deadline': dict(_ZERO), 'lifespan': dict(_ZERO),
            'liveliness': 'automatic', 'liveliness_lease_duration': dict(_ZERO),
            'avoid_ros_namespace_conventions': False}


def split_name(bag, index):
    """The name of split `index` of the bag directory `bag`: `<bag>_<index>.mcap` as rosbag2 names it, the bag's
    name shortened where that would pass the 255 bytes a file name may have (metadata.yaml lists each split)."""
    tail = f'_{index}.mcap'
    stem = os.fsencode(bag)[:255 - len(tail)].decode(errors='ignore')
    return stem + tail


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
        self._channels = {}       # topic -> (message definition, offered QoS as YAML): what each split registers
        self._split = None

    def add_topic(self, topic, msgtype):
        if topic not in self.topics:
            self.topics[topic] = msgtype
            self.counts[topic] = 0
            msgdef, _ = typestore().generate_msgdef(msgtype, ros_version=2)
            self._channels[topic] = (msgdef.encode(),
                                     yaml.safe_dump([offered_qos(topic, msgtype)], default_flow_style=False))

    def write_message(self, topic, stamp_ns, message):
        """Store an rclpy message (built by emla_core.messages) on `topic` at time `stamp_ns`."""
        self.write(topic, stamp_ns, serialize(message))

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
        msgdef, qos = self._channels[topic]
        schema = writer.register_schema(name=msgtype, encoding='ros2msg', data=msgdef)
        return writer.register_channel(topic=topic, message_encoding='cdr', schema_id=schema,
                                       metadata={'offered_qos_profiles': qos})

    def _open_split(self):
        path = self.path / split_name(self.path.name, len(self.finished))
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
                                    'offered_qos_profiles': [offered_qos(topic, msgtype)],
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
            # libyaml's dumper: this runs at every split, in the recorder's process, where pure-Python YAML costs
            # more than writing the split's messages
            yaml.dump({'rosbag2_bagfile_information': info}, f, Dumper=yaml.CSafeDumper, default_flow_style=False,
                      sort_keys=False)
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
    end = recording.start_time + len(recording) * period
    if not (-0.5e-9 < recording.start_time and end < 2**64 * 1e-9):   # MCAP log times: unsigned 64-bit ns
        raise InputError(f'{recording.source or path}: the data run from t = {recording.start_time:.6g} s to '
                         f'{end:.6g} s; a bag stamps them in nanoseconds from 0 to 584 years: give a time column '
                         f'that starts at 0 or later')
    from emla_core.limits import MAX_STAMP_NS, STAMP_LIMIT
    last = recording.start_time + max(len(recording) - 1, 0) * period
    latest = max([last, *(t for t, _ in estimates)])
    if to_ns(latest) > MAX_STAMP_NS:   # a header's sec is int32: it would wrap to a negative second
        raise InputError(f'{recording.source or path}: the data run to t = {latest:.10g} s; a ROS time stamp holds 0 '
                         f'to {STAMP_LIMIT}: give a time column that ends before, e.g. from 0')
    start_ns = to_ns(recording.start_time)
    data = dict(recording.metadata)
    data.update(custom_data or {})
    with BagWriter(path, custom_data=data) as bag:
        for name in recording.signals:
            bag.add_topic(signal_topic(name), SAMPLE_FRAME)
        if len(estimates):
            bag.add_topic(PARAMETERS_TOPIC, PARAMETER_ESTIMATE)
        pending = sorted(estimates, key=lambda e: e[0])
        for first in range(0, len(recording), frame_size):
            stamp = start_ns + to_ns(first * period)
            for name, values in recording.signals.items():
                bag.write_message(signal_topic(name), stamp,
                                  frame_message(stamp, period, values[first:first + frame_size]))
            frame_end = recording.start_time + (first + frame_size) * period
            while pending and pending[0][0] < frame_end:
                t, values = pending.pop(0)
                bag.write_message(PARAMETERS_TOPIC, to_ns(t), estimate_message(to_ns(t), values))
