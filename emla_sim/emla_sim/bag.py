"""rosbag2 directories (metadata.yaml + zstd-chunked MCAP) of the suite's topics: writing and reading.

The writer splits a bag into several MCAP files. Each split is finished (summary and footer written)
before metadata.yaml is rewritten atomically to list it, so a recorder killed at any moment leaves a bag
that rosbags, mcap-ros2-support and `emla` read up to the last finished split.

read_bag assembles whole signals; iter_chunks yields the same signals in parts without holding the record,
decoding the SampleFrames of each MCAP chunk in one compiled pass (the per-message deserialisation read_bag
uses would take longer than the identification of the samples).
"""
import collections
import copy
import os
import struct
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np
import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from emla_sim.errors import InputError
from emla_sim.recording import Recording
from emla_sim.topics import NAMESPACE, PARAMETERS_TOPIC, TRUTH_TOPIC, signal_topic, stamp_to_ns

SAMPLE_FRAME = 'emla_msgs/msg/SampleFrame'
PARAMETER_ESTIMATE = 'emla_msgs/msg/ParameterEstimate'
ARX_MODEL = 'emla_msgs/msg/ArxModel'
ESTIMATE_FIELDS = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping', 'load_force')

# QoS offered by the suite's publishers, as rosbag2 stores it (REP-2012 v9 layout).
_QOS = {'history': 'keep_last', 'depth': 100, 'reliability': 'reliable', 'durability': 'volatile',
        'deadline': {'sec': 0, 'nsec': 0}, 'lifespan': {'sec': 0, 'nsec': 0}, 'liveliness': 'automatic',
        'liveliness_lease_duration': {'sec': 0, 'nsec': 0}, 'avoid_ros_namespace_conventions': False}


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


_MCAP_ERRORS = (McapError, OSError, ValueError, KeyError, EOFError, IndexError, struct.error)  # unreadable files


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
        except _MCAP_ERRORS as exc:
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


# ---- reading a record in parts: iter_chunks ----

_MCAP_MESSAGE = 0x05      # the opcode of an MCAP Message record
_DECODE_BYTES = 1 << 20   # uncompressed chunk data decoded at a time


def iter_chunks(path, signals=None, chunk_samples=1 << 14):
    """read_bag(path).recording as consecutive Recordings of `chunk_samples` samples (the last one shorter),
    decoded and aligned as the MCAP chunks are read: memory holds a part, not the record.

    signals: the names the parts carry (default: all); all of the bag's signals are aligned, as read_bag does.
    Each signal's frames must be stored in time order (the suite stores frames at their stamps), where read_bag
    also accepts them shuffled. A file without a summary and chunk index (e.g. a bare .mcap whose writer was
    killed) is read whole by read_bag and comes as one part.
    """
    if isinstance(chunk_samples, bool) or not isinstance(chunk_samples, int) or chunk_samples < 1:
        raise ValueError(f'chunk_samples must be a positive integer, got {chunk_samples!r}')
    path = Path(path)
    if not path.exists():
        raise InputError(f'{path}: no such file or directory')
    files, custom = _mcap_files(path)
    layouts = _signal_channels(files)
    if layouts is None:
        recording = read_bag(path).recording
        recording.signals = {k: v for k, v in recording.signals.items() if signals is None or k in signals}
        yield recording
        return
    names = sorted({topic[len(NAMESPACE):] for _, channels in layouts for topic in channels.values()})
    aligner = _Aligner(path, names, names if signals is None else [n for n in names if n in signals],
                       chunk_samples, custom)
    for file, channels in layouts:
        slot_of_channel = np.full(max(channels, default=0) + 1, -1, dtype=np.int64)
        for channel, topic in channels.items():
            slot_of_channel[channel] = names.index(topic[len(NAMESPACE):])
        for frames in _decoded_chunks(file, slot_of_channel, len(names)):
            yield from aligner.add(*frames)
    yield from aligner.finish()


class _Aligner:
    """Frames of each signal, checked for gaps and overlaps as read_bag checks them, cut to the time span all
    signals share (read_bag's first and last) and handed out in parts as soon as every signal has them."""

    def __init__(self, path, names, wanted, chunk_samples, metadata):
        self.path, self.names, self.chunk_samples, self.metadata = path, names, chunk_samples, metadata
        self.period = None
        self.start, self.end = {}, {}                   # ns: first stamp, stamp the next frame must have
        self.received = dict.fromkeys(names, 0)          # samples
        self.queues = {name: _Queue() for name in wanted}
        self.first = None                                # the shared start, once every signal has begun
        self.offsets = {}                                # samples of each signal before it
        self.emitted = 0

    def add(self, slot_of, stamps, periods, lengths, values, starts):
        """The parts complete after one decoded MCAP chunk."""
        for slot, name in enumerate(self.names):
            mine = slot_of == slot
            if mine.any():
                self._frames(name, stamps[mine], periods[mine], lengths[mine])
                if name in self.queues:
                    self.queues[name].push(values[starts[slot]:starts[slot + 1]])
        return self._parts(final=False)

    def finish(self):
        if len(self.start) < len(self.names):  # summaries that count frames the chunks do not hold
            raise InputError(f'{self.path}: no frames of {", ".join(n for n in self.names if n not in self.start)}')
        return self._parts(final=True)

    def _frames(self, name, stamps, periods, lengths):
        if self.period is None:
            self.period = float(periods[0])
            if not self.period > 0:
                raise InputError(f'{self.path}: sample period {self.period} is not positive')
        if np.any(periods != self.period):
            different = sorted({self.period, *periods.tolist()})
            raise InputError(f'{self.path}: frames have different sample periods {different}')
        durations = np.rint(lengths * self.period * 1e9).astype(np.int64)  # round(len(data) * period * 1e9)
        expected = np.concatenate(([self.end.get(name, stamps[0])], stamps[:-1] + durations[:-1]))
        bad = np.abs(stamps - expected) > 0.5 * self.period * 1e9
        if bad.any():
            stamp = stamps[np.argmax(bad)]
            raise InputError(f'{self.path}: /emla/{name} has a gap or overlap at t = {stamp * 1e-9:.6f} s')
        self.start.setdefault(name, int(stamps[0]))
        self.end[name] = int(stamps[-1] + durations[-1])
        self.received[name] += int(lengths.sum())

    def _parts(self, final):
        if self.first is None:
            if len(self.start) < len(self.names):
                return
            self.first = max(self.start.values())
            self.offsets = {n: round((self.first - self.start[n]) * 1e-9 / self.period) for n in self.names}
            for name, queue in self.queues.items():
                queue.drop(self.offsets[name])
        last = min(self.end.values())
        if final and last <= self.first:
            raise InputError(f'{self.path}: the signal topics share no time span')
        total = max(0, round((last - self.first) * 1e-9 / self.period))  # read_bag's n, or a lower bound of it
        if not final:
            total = min([total] + [self.received[n] - self.offsets[n] for n in self.names])
        while total - self.emitted >= self.chunk_samples:
            yield self._part(self.chunk_samples)
        if final and (total > self.emitted or not self.emitted):  # the rest; an empty record as one empty part
            yield self._part(total - self.emitted)

    def _part(self, size):
        part = Recording(sample_period=self.period, signals={name: q.take(size) for name, q in self.queues.items()},
                         start_time=self.first * 1e-9 + self.emitted * self.period, source=str(self.path),
                         metadata=self.metadata)
        self.emitted += size
        return part


class _Queue:
    """Samples of one signal waiting to be handed out: arrays in arrival order."""

    def __init__(self):
        self._arrays, self._skip = collections.deque(), 0

    def push(self, values):
        self._arrays.append(values)

    def drop(self, n):
        self._skip += n

    def take(self, n):
        parts = []
        while n > 0 and self._arrays:
            head = self._arrays[0]
            if self._skip >= len(head):
                self._skip -= len(head)
                self._arrays.popleft()
                continue
            piece = head[self._skip:self._skip + n]
            parts.append(piece)
            n -= len(piece)
            self._skip += len(piece)
        return parts[0] if len(parts) == 1 else np.concatenate(parts) if parts else np.empty(0)


def _signal_channels(files):
    """[(file, {channel id: signal topic})] from the MCAP summaries; None if a file has none, or has messages
    outside chunks or on signal channels that are not CDR."""
    layouts = []
    for file in files:
        summary = _summary(file)
        statistics = summary and summary.statistics
        if statistics is None or len(summary.chunk_indexes) != statistics.chunk_count \
                or (statistics.message_count and not statistics.chunk_count):
            return None
        channels = {}
        for channel in summary.channels.values():
            schema = summary.schemas.get(channel.schema_id)
            if schema is not None and schema.name == SAMPLE_FRAME and channel.topic.startswith(NAMESPACE) \
                    and statistics.channel_message_counts.get(channel.id, 0):
                if channel.message_encoding != 'cdr':
                    return None
                channels[channel.id] = channel.topic
        layouts.append((file, channels))
    return layouts


def _summary(file):
    """The summary section of an MCAP file, None if it has none or cannot be read."""
    try:
        with file.open('rb') as f:
            return make_reader(f).get_summary()
    except _MCAP_ERRORS:
        return None


def _decoded_chunks(file, slot_of_channel, slots):
    """_decode_frames of the chunks of an MCAP file, in file order, a few together (the records of consecutive
    chunks, uncompressed, are one valid sequence of records). The chunk index is read here, file by file: over
    thousands of files it would take memory in proportion to the record."""
    from mcap.data_stream import ReadDataStream
    from mcap.records import Chunk
    from mcap.stream_reader import get_chunk_data_stream
    try:
        with file.open('rb') as f:
            summary = make_reader(f).get_summary()
            if summary is None:  # it had one when iter_chunks began
                raise ValueError('the summary section is gone')
            chunk_indexes = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
            batch, size = [], 0
            for j, index in enumerate(chunk_indexes):
                f.seek(index.chunk_start_offset + 1 + 8)  # past the record's opcode and length
                stream, length = get_chunk_data_stream(Chunk.read(ReadDataStream(f)))
                batch.append(stream.read(length))
                size += length
                if size >= _DECODE_BYTES or j == len(chunk_indexes) - 1:
                    *frames, bad = _decode_frames(np.frombuffer(b''.join(batch), np.uint8), slot_of_channel, slots)
                    if bad >= 0:
                        raise ValueError(f'malformed record or SampleFrame in the chunks before byte '
                                         f'{index.chunk_start_offset + index.chunk_length}')
                    yield frames
                    batch, size = [], 0
    except _MCAP_ERRORS as exc:
        raise InputError(f'{file}: unreadable MCAP: {" ".join(str(exc).split()) or type(exc).__name__}') from None


@numba.njit(cache=True)
def _little_endian(buf, at, size):
    value = 0
    for b in range(size - 1, -1, -1):
        value = (value << 8) | buf[at + b]
    return value


@numba.njit(cache=True)
def _frame_layout(buf, body, end):
    """(stamp ns, sample-period bits, samples, first data byte) of the little-endian CDR SampleFrame in the
    Message record body [body, end); samples -1 if it is not one."""
    cdr = body + 22  # channel id, sequence, log and publish time come first
    if cdr + 16 > end or buf[cdr] != 0 or buf[cdr + 1] != 1:
        return 0, 0, -1, 0
    sec = _little_endian(buf, cdr + 4, 4)
    stamp = (sec - (sec >> 31 << 32)) * 1_000_000_000 + _little_endian(buf, cdr + 8, 4)
    period = (12 + _little_endian(buf, cdr + 12, 4) + 7) // 8 * 8  # after the frame_id; 8-aligned in the body
    if cdr + 4 + period + 12 > end:
        return 0, 0, -1, 0
    samples = _little_endian(buf, cdr + 4 + period + 8, 4)
    data = cdr + 4 + (period + 12 + 7) // 8 * 8
    if data + 8 * samples > end:
        return 0, 0, -1, 0
    return stamp, _little_endian(buf, cdr + 4 + period, 8), samples, data


@numba.njit(cache=True)
def _decode_frames(buf, slot_of_channel, slots):
    """The SampleFrames on channels with a slot (>= 0) among the records of uncompressed MCAP chunk data.

    Returns per frame (in record order) its slot, stamp (ns), sample period and length; the values of each slot
    concatenated in record order, slot s's from starts[s] to starts[s + 1]; and the byte offset of the first
    malformed record or frame (-1: none; the frames before it are returned)."""
    capacity = buf.size // 63 + 1  # a record with a SampleFrame takes at least 9 + 22 + 32 bytes
    slot_of = np.empty(capacity, dtype=np.int64)
    stamps = np.empty(capacity, dtype=np.int64)
    bits = np.empty(capacity, dtype=np.int64)
    lengths = np.empty(capacity, dtype=np.int64)
    data = np.empty(capacity, dtype=np.int64)
    starts = np.zeros(slots + 1, dtype=np.int64)
    frames, pos, bad = 0, 0, -1
    while pos < buf.size:
        length = _little_endian(buf, pos + 1, 8) if pos + 9 <= buf.size else -1
        body, end = pos + 9, pos + 9 + length
        if length < 0 or end > buf.size:
            bad = pos
            break
        if buf[pos] == _MCAP_MESSAGE and end >= body + 2:
            channel = _little_endian(buf, body, 2)
            slot = slot_of_channel[channel] if channel < slot_of_channel.size else -1
            if slot >= 0:
                stamps[frames], bits[frames], lengths[frames], data[frames] = _frame_layout(buf, body, end)
                if lengths[frames] < 0:
                    bad = pos
                    break
                slot_of[frames] = slot
                starts[slot + 1] += lengths[frames]
                frames += 1
        pos = end
    starts = np.cumsum(starts)
    values = np.empty(starts[slots])
    filled = starts[:slots].copy()
    for f in range(frames):
        at, size = filled[slot_of[f]], lengths[f]
        values[at:at + size] = buf[data[f]:data[f] + 8 * size].view(np.float64)  # little-endian host; unaligned ok
        filled[slot_of[f]] += size
    return slot_of[:frames], stamps[:frames], bits[:frames].view(np.float64), lengths[:frames], values, starts, bad
