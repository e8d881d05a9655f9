"""Reading rosbag2 directories (or bare .mcap files) of the suite's topics: read_bag (whole), iter_messages,
iter_serialized, bag_topics.

A file with a chunk index is read chunk by chunk, and a corrupt chunk (its record, decompression or CRC fails)
is skipped and described (CorruptChunk: its file, number and the time span of its messages). read_bag and
iter_chunks name it in the error its loss may cause, else in a warning once done (logging, one line), followed by
one that names the measured data it cost (data_cost). A signal whose samples begin later or end earlier than the
others' by more than a frame (its recorder stopped early, a topic's messages cut off) is warned of in the same way
(short_signals): the record is the span all signals share. Frames missing inside it (a message lost, a skipped
chunk's) leave the record in segments (Recording.gaps, emla_core.sampling): FrameAligner puts the signals' frames
together for both readers. A file without a chunk index is read straight through, and any damage refuses it. A
bag's metadata.yaml is checked before any file it names is opened (bag_info): hostile metadata, files outside the
bag, devices and FIFOs are refused in one line.
"""
import bisect
import collections
import contextlib
import heapq
import itertools
import logging
import math
import os
import struct
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path, PurePath

import numpy as np
import yaml
from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile, McapError
from mcap.opcode import Opcode
from mcap.reader import NonSeekingReader, make_reader
from mcap.records import Chunk, Message
from mcap.stream_reader import get_chunk_data_stream
from rosbags.serde import SerdeError
from zstandard import ZstdError

from emla_core.errors import InputError
from emla_core.files import regular_file
from emla_core.messages import effect_values, estimate_std, estimate_values, read_frame_cdr
from emla_core.recording import Recording
from emla_core.sampling import MAX_GAPS, check_gaps, gap_time, shared
from emla_core.topics import (
    EFFECT_ESTIMATE,
    EFFECTS_TOPIC,
    NAMESPACE,
    PARAMETER_ESTIMATE,
    PARAMETERS_TOPIC,
    SAMPLE_FRAME,
    TRUE_PARAMETERS_TOPIC,
    stamp_to_ns,
)

from .schema import typestore

log = logging.getLogger(__name__)
# What damaged MCAP data raise: the mcap library, the file, struct, zstd and lz4 (RuntimeError) decompression.
MCAP_ERRORS = (McapError, OSError, ValueError, KeyError, EOFError, IndexError, struct.error, ZstdError, RuntimeError)
MCAP_MAGIC = b'\x89MCAP0\r\n'
MAX_METADATA_BYTES = 8 << 20   # a metadata.yaml of some 50 000 splits; a larger one is refused, not parsed
MAX_NESTING = 16               # a bag's metadata nests 5 deep; deeper YAML is refused before it is built
MAX_CHUNK_BYTES = 1 << 30      # an MCAP chunk, uncompressed (writers use a few MiB)


def _finite(values):
    return {k: v for k, v in values.items() if np.isfinite(v)}


@dataclass
class BagContents:
    recording: Recording
    estimates: list        # [(time_s, {name: value}, {name: std})] from /emla/parameters, in time order
    truth: list            # [(time_s, {name: value})] from /emla/plant/parameters (simulated runs only)
    metadata: dict         # custom_data of the bag
    effects: list = field(default_factory=list)   # as estimates, from /emla/effects (the parameters
                                                              # of effects estimated online; a solenoid's R)


@dataclass(frozen=True)
class CorruptChunk:
    """A chunk of an MCAP file that could not be read: where it is and the time span of its messages (ns)."""
    file: Path
    number: int            # in file order, from 1
    count: int             # chunks in the file
    start: int
    end: int
    problem: str

    def __str__(self):
        return (f'corrupt chunk {self.number} of {self.count} of {self.file} (messages from t = '
                f'{self.start * 1e-9:.6f} to {self.end * 1e-9:.6f} s): {self.problem}')


def warn_skipped(chunk):
    """The default on_corrupt: one line (a logging warning) that names the skipped CorruptChunk."""
    log.warning('warning: skipped the %s', chunk)


def data_cost(path, spans, period, absent=(), gaps=(), start=0.0):
    """The warning (one line) of the measured data that skipped chunks cost a record cut to the time span all
    its signals share; None if they cost none.

    Parameters
    ----------
    path : Path
        The bag, to name.
    spans : dict
        {signal: (first stamp, end) in ns} of each signal's samples as read.
    period : float
        The sample period in s.
    absent : sequence of str, optional
        Signals of the bag of which no sample was read.
    gaps : sequence, optional
        The record's gaps (Recording.gaps) inside that span, of a record from `start` (s).

    Returns
    -------
    str or None
        Each signal's loss: where it has no samples that another one has ('lost'), and where it has samples
        outside the span all share ('cut'), from when to when and how many samples; the gaps left inside it.
    """
    first, last = max(s for s, _ in spans.values()), min(e for _, e in spans.values())
    low, high = min(s for s, _ in spans.values()), max(e for _, e in spans.values())
    losses = [f'{name} lost entirely' for name in absent]
    for name, (start, end) in spans.items():
        for a, b, how in ((low, start, 'lost'), (start, first, 'cut'), (last, end, 'cut'), (end, high, 'lost')):
            samples = round((b - a) * 1e-9 / period)
            if samples > 0:
                losses.append(f'{name} {how} from t = {a * 1e-9:.6f} to {b * 1e-9:.6f} s ({samples} samples)')
    terms = ' (lost: not read; cut: read, but outside the time span all signals share)' if losses else ''
    for j, (_, missing) in enumerate(gaps):
        after = gap_time(gaps, j, start, period)
        losses.append(f'a gap from t = {after + period:.6f} to {after + (missing + 1) * period:.6f} s ({missing} '
                      f'samples; the record is in segments)')
    if not losses:
        return None
    return f'{path}: the skipped chunks cost measured data: {"; ".join(losses)}{terms}'



def short_signals(path, spans, period, frame=1):
    """The warning (one line) of the signals whose samples begin later or end earlier than another signal's by
    more than `frame` samples (a frame: a recorder stopped between the topics of one period costs less), which
    cuts the record to the time span all share; None if none does.

    Parameters
    ----------
    path : Path
        The bag, to name.
    spans : dict
        {signal: (first stamp, end) in ns} of each signal's samples as read.
    period : float
        The sample period in s.
    frame : int, optional
        Samples a signal may lack at either end without a warning (the longest frame read).

    Returns
    -------
    str or None
        Which topic begins late or ends early, where and by how many samples, and how much of the record (from
        the first signal's start to the last one's end) is therefore not used.
    """
    first, last = max(s for s, _ in spans.values()), min(e for _, e in spans.values())
    low, high = min(s for s, _ in spans.values()), max(e for _, e in spans.values())
    notes = []
    for name, (start, end) in sorted(spans.items()):
        late, early = round((start - low) * 1e-9 / period), round((high - end) * 1e-9 / period)
        if late > frame:
            notes.append(f'{NAMESPACE}{name} begins at t = {start * 1e-9:.6f} s, {late} samples after the first '
                         f'signal (t = {low * 1e-9:.6f} s)')
        if early > frame:
            notes.append(f'{NAMESPACE}{name} ends at t = {end * 1e-9:.6f} s, {early} samples before the last '
                         f'signal (t = {high * 1e-9:.6f} s)')
    if not notes:
        return None
    total, used = round((high - low) * 1e-9 / period), max(0, round((last - first) * 1e-9 / period))
    return (f'{path}: {"; ".join(notes)}: the record is cut to the {used} samples all signals share (t = '
            f'{first * 1e-9:.6f} to {last * 1e-9:.6f} s); {total - used} of its {total} samples '
            f'({100 * (total - used) / total:.3g} %) are not used')


def one_line(exc):
    """The message of an exception on one line (YAML and MCAP errors span several)."""
    return ' '.join(str(exc).split()) or type(exc).__name__


def unreadable(file, exc):
    """The InputError of an MCAP file that cannot be read (never with the file's bytes, which mcap would show)."""
    head, tail = _magics(file)
    if head is not None and head != MCAP_MAGIC:
        problem = 'not an MCAP file (it does not begin with the MCAP magic)'
    elif tail is not None and tail != MCAP_MAGIC:
        problem = 'cut short (no MCAP magic at its end: its writer did not finish it)'
    elif isinstance(exc, EndOfFile):
        problem = 'cut short (it ends inside a record)'
    else:
        problem = one_line(exc)
    return InputError(f'{file}: unreadable MCAP: {problem}')


def _magics(file):
    """The first and the last bytes of a file, as many as the MCAP magic has; None where they cannot be read."""
    try:
        with file.open('rb') as f:
            head = f.read(len(MCAP_MAGIC))
            f.seek(-min(len(MCAP_MAGIC), os.fstat(f.fileno()).st_size), os.SEEK_END)
            return head, f.read(len(MCAP_MAGIC))
    except OSError:
        return None, None


def bag_info(path):
    """The rosbag2_bagfile_information of a bag directory (its metadata.yaml), checked before any file it names
    is opened.

    Parameters
    ----------
    path : Path
        The bag directory.

    Returns
    -------
    dict
        With storage_identifier (str), relative_file_paths (names of regular files inside the bag) and
        custom_data (a mapping or None) and topics_with_message_count (topic_metadata with name and type) where
        given.

    Raises
    ------
    InputError
        No metadata.yaml, or one that is too large, not UTF-8 text, not YAML, nested too deep or not of a bag's
        shape; a file it names outside the bag, missing or not a regular file.
    """
    meta_path = path / 'metadata.yaml'
    if not meta_path.exists():
        raise InputError(f'{path}: not a rosbag2 directory (no metadata.yaml)')
    document = _read_yaml(regular_file(meta_path, 'bag metadata file', MAX_METADATA_BYTES))
    info = document.get('rosbag2_bagfile_information') if isinstance(document, dict) else None
    problem = _shape_problem(info)
    if problem:
        raise InputError(f'{meta_path}: unreadable metadata: {problem}')
    for name in info['relative_file_paths']:
        if PurePath(name).is_absolute() or '..' in PurePath(name).parts:
            raise InputError(f'{meta_path}: relative_file_paths names {name[:80]!r}, outside the bag directory')
        regular_file(path / name, 'bag file', limit=None)
    return info


def _read_yaml(file):
    """The YAML document of a metadata file; an InputError, without the file's text, if it is not one."""
    try:
        text = file.read_bytes().decode()
        depth = 0
        for event in yaml.parse(text, Loader=yaml.CSafeLoader):  # libyaml's loader overflows the C stack when deep
            depth += isinstance(event, yaml.CollectionStartEvent) - isinstance(event, yaml.CollectionEndEvent)
            if depth > MAX_NESTING:
                raise InputError(f'{file}: unreadable metadata: nested more than {MAX_NESTING} levels deep')
        return yaml.load(text, Loader=yaml.CSafeLoader)
    except OSError as exc:
        raise InputError(f'{file}: cannot read: {exc.strerror or exc}') from None
    except UnicodeDecodeError as exc:
        raise InputError(f'{file}: unreadable metadata: not UTF-8 text (byte {exc.start})') from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f' (line {mark.line + 1}, column {mark.column + 1})' if mark else ''
        raise InputError(f'{file}: unreadable metadata: not YAML: {exc.problem or exc.context}{where}') from None
    except (yaml.YAMLError, ValueError) as exc:  # ValueError: a value YAML cannot build, e.g. a date 2024-13-01
        raise InputError(f'{file}: unreadable metadata: {one_line(exc)}') from None


def _shape_problem(info):
    """What keeps `info` from being a rosbag2_bagfile_information the readers can use, None if nothing."""
    if not isinstance(info, dict):
        return 'no rosbag2_bagfile_information mapping'
    if not isinstance(info.get('storage_identifier'), str):
        return 'storage_identifier is missing or not a name'
    names = info.get('relative_file_paths')
    if not isinstance(names, list) or not all(isinstance(n, str) and n and '\0' not in n for n in names):
        return 'relative_file_paths is missing or not a list of file names'
    custom = info.get('custom_data') or {}
    if not isinstance(custom, dict) or not all(   # rosbag2's custom_data maps strings to strings
            isinstance(v, (str, int, float, bool)) or v is None for v in custom.values()):
        return 'custom_data is not a mapping of names to plain values'
    topics = info.get('topics_with_message_count') or []
    if not isinstance(topics, list) or not all(
            isinstance(t, dict) and isinstance(t.get('topic_metadata'), dict)
            and all(isinstance(t['topic_metadata'].get(key), str) for key in ('name', 'type')) for t in topics):
        return 'topics_with_message_count is not a list of topics with a name and type'
    return None


def bag_files(path):
    """The MCAP files of a bag directory (or the .mcap file itself) and its custom data."""
    if not path.is_dir():
        return [regular_file(path, 'MCAP file', limit=None)], {}
    info = bag_info(path)
    if info['storage_identifier'] != 'mcap':
        raise InputError(f'{path}: storage {info["storage_identifier"][:80]!r} is not supported (mcap only)')
    return [path / p for p in info['relative_file_paths']], dict(info.get('custom_data') or {})


def storage(path):
    """The storage of a bag directory or .mcap file behind one interface, as rosbags chooses its storage plugin:
    `topics()` ({topic: message type} of the channels with messages) and `serialized(topics, on_corrupt)` ((topic,
    message type, log time ns, CDR bytes)). MCAP is read by the suite (chunks CRC-checked, a corrupt one skipped);
    sqlite3 through rosbags (no chunks to check)."""
    path = Path(path)
    if path.is_dir() and bag_info(path)['storage_identifier'] == 'sqlite3':
        return _Sqlite3(path)
    return _Mcap(path)


class _Sqlite3:
    def __init__(self, path):
        self.path = path

    @contextlib.contextmanager
    def _reader(self):
        """A rosbags Reader of the bag; its errors as one InputError line."""
        from rosbags.rosbag2 import Reader
        try:
            with Reader(self.path) as reader:
                yield reader
        except InputError:
            raise
        except Exception as exc:  # rosbags raises many kinds on a damaged bag; the user needs one line
            raise InputError(f'{self.path}: unreadable sqlite3 bag: {one_line(exc)}') from None

    def topics(self):
        with self._reader() as reader:
            return {c.topic: c.msgtype for c in reader.connections if c.msgcount}

    def serialized(self, topics, on_corrupt):
        with self._reader() as reader:
            connections = [c for c in reader.connections if topics is None or c.topic in topics]
            for connection, stamp, data in reader.messages(connections=connections) if connections else ():
                yield connection.topic, connection.msgtype, stamp, data


class _Mcap:
    def __init__(self, path):
        self.path = path

    def topics(self):
        topics = {}
        for file in bag_files(self.path)[0]:
            try:
                with file.open('rb') as f:
                    summary = make_reader(f).get_summary()
            except MCAP_ERRORS as exc:
                raise unreadable(file, exc) from None
            if summary is None:
                raise InputError(f'{file}: unreadable MCAP: no summary section (its writer did not finish it)')
            statistics = summary.statistics
            topics.update({c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()
                           if c.schema_id in summary.schemas
                           and (statistics is None or statistics.channel_message_counts.get(c.id))})
        return topics

    def serialized(self, topics, on_corrupt):
        for file in bag_files(self.path)[0]:
            try:
                with file.open('rb') as f:
                    summary = make_reader(f).get_summary()
                    if summary is None or not summary.chunk_indexes:  # read straight through, the CRCs checked
                        f.seek(0)
                        for schema, channel, message in NonSeekingReader(f, validate_crcs=True).iter_messages(topics):
                            if schema is not None:
                                yield channel.topic, schema.name, message.log_time, message.data
                    else:
                        yield from _indexed(f, file, summary, topics, on_corrupt)
            except MCAP_ERRORS as exc:
                raise unreadable(file, exc) from None


def bag_topics(path):
    """{topic: message type} of the channels with messages in a bag (its storage's `topics`)."""
    return storage(path).topics()


def chunk_data(f, file, chunks, k, on_corrupt):
    """The uncompressed records of chunks[k] (the chunk indexes of the open MCAP `file`, in file order); None if
    the chunk is corrupt, after on_corrupt(CorruptChunk). Its record is read as long as the index says, and its
    CRC checked."""
    index = chunks[k]
    try:
        if not 1 + 8 <= index.chunk_length <= os.fstat(f.fileno()).st_size - index.chunk_start_offset:
            raise ValueError(f'the chunk index gives it {index.chunk_length} bytes from byte '
                             f'{index.chunk_start_offset}, not within the file')
        if index.uncompressed_size > MAX_CHUNK_BYTES:
            raise ValueError(f'{index.uncompressed_size} bytes uncompressed, more than the {MAX_CHUNK_BYTES} read')
        f.seek(index.chunk_start_offset + 1 + 8)  # past the record's opcode and length
        chunk = Chunk.read(ReadDataStream(BytesIO(f.read(index.chunk_length - 1 - 8))))
        if (chunk.compression, chunk.uncompressed_size) != (index.compression, index.uncompressed_size):
            raise ValueError('its header differs from the chunk index')
        stream, length = get_chunk_data_stream(chunk, validate_crc=True)
        return stream.read(length)
    except MCAP_ERRORS as exc:
        on_corrupt(CorruptChunk(file, k + 1, len(chunks), index.message_start_time, index.message_end_time,
                                one_line(exc)))
        return None


@contextlib.contextmanager
def reporting_skipped(skipped):
    """Around the use of what was read past the corrupt chunks `skipped` (a list that fills while it is read):
    an InputError raised names them (their loss may be its cause), else each is a warning once it is done."""
    try:
        yield
    except InputError as exc:
        if not skipped:
            raise
        raise InputError(f'{exc}, after skipping ' + ' and '.join(f'the {c}' for c in skipped)) from None
    for chunk in skipped:
        warn_skipped(chunk)


def iter_serialized(path, topics=None, on_corrupt=warn_skipped):
    """(topic, message type, log time ns, CDR bytes) of a bag directory or .mcap file: file by file, each file
    in log-time order (a sqlite3 bag in log-time order); only `topics` if given. A corrupt MCAP chunk is skipped
    after on_corrupt(CorruptChunk)."""
    yield from storage(path).serialized(topics, on_corrupt)


def _indexed(f, file, summary, topics, on_corrupt):
    """The messages of an MCAP file with a chunk index in log-time order; as the mcap reader does, a chunk is
    read when its first message is due."""
    channels = {i: (c.topic, summary.schemas[c.schema_id].name) for i, c in summary.channels.items()
                if c.schema_id in summary.schemas and (topics is None or c.topic in topics)}
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    due = collections.deque(sorted(range(len(chunks)), key=lambda k: chunks[k].message_start_time))
    heap, order = [], itertools.count()  # (log time, order read, message)
    while due or heap:
        if due and (not heap or chunks[due[0]].message_start_time <= heap[0][0]):
            for message in _messages(chunk_data(f, file, chunks, due.popleft(), on_corrupt) or b''):
                if message.channel_id in channels:
                    heapq.heappush(heap, (message.log_time, next(order), message))
        else:
            message = heapq.heappop(heap)[2]
            yield (*channels[message.channel_id], message.log_time, message.data)


def _messages(records):
    """The Message records among uncompressed chunk records."""
    stream = ReadDataStream(BytesIO(records))
    while stream.count < len(records):
        opcode, length = stream.read1(), stream.read8()
        if opcode == Opcode.MESSAGE:
            yield Message.read(stream, length)
        else:
            stream.read(length)


def iter_messages(path, topics=None, on_corrupt=warn_skipped):
    """(topic, message type, log time ns, message) of a bag directory or .mcap file, as iter_serialized."""
    for topic, msgtype, stamp, data in iter_serialized(path, topics, on_corrupt):
        yield topic, msgtype, stamp, deserialize(path, topic, msgtype, stamp, data)


def deserialize(path, topic, msgtype, stamp, data):
    """The message of CDR `data` logged on `topic` of the bag `path` at `stamp` (ns); an InputError naming them
    if it is not the CDR of a message of its type or its type is unknown here."""
    try:
        return typestore().deserialize_cdr(data, msgtype)
    except (SerdeError, KeyError) as exc:
        raise _unreadable_message(path, topic, msgtype, stamp, exc) from None


def read_frame(path, topic, stamp, data):
    """(stamp ns, sample period s, samples) of the SampleFrame of CDR `data` logged on `topic` of the bag
    `path` at `stamp` (ns), decoded as the nodes decode them (messages.read_frame_cdr); an InputError naming
    them if it is not one."""
    try:
        return read_frame_cdr(data)
    except (struct.error, ValueError, IndexError) as exc:
        raise _unreadable_message(path, topic, SAMPLE_FRAME, stamp, exc) from None


def _unreadable_message(path, topic, msgtype, stamp, exc):
    return InputError(f'{path}: unreadable {msgtype} on {topic} (logged at {stamp * 1e-9:.6f} s): {one_line(exc)}')


def read_bag(path):
    """The signals (assembled from SampleFrames), parameter estimates and custom metadata of a bag."""
    path = Path(path)
    _, custom = bag_files(path)
    frames, estimates, truth, effects, skipped = {}, [], [], [], []
    with reporting_skipped(skipped):
        for topic, msgtype, stamp, data in iter_serialized(path, on_corrupt=skipped.append):
            if msgtype == SAMPLE_FRAME and topic.startswith(NAMESPACE):
                frames.setdefault(topic[len(NAMESPACE):], []).append(read_frame(path, topic, stamp, data))
            elif msgtype == PARAMETER_ESTIMATE and topic in (PARAMETERS_TOPIC, TRUE_PARAMETERS_TOPIC):
                msg = deserialize(path, topic, msgtype, stamp, data)
                stamp_s = stamp_to_ns(msg.header.stamp) * 1e-9
                values = _finite(estimate_values(msg))
                if topic == TRUE_PARAMETERS_TOPIC:
                    truth.append((stamp_s, values))
                else:
                    estimates.append((stamp_s, values, _finite(estimate_std(msg))))
            elif msgtype == EFFECT_ESTIMATE and topic == EFFECTS_TOPIC:
                msg = deserialize(path, topic, msgtype, stamp, data)
                effects.append((stamp_to_ns(msg.header.stamp) * 1e-9, _finite(effect_values(msg)),
                                _finite(dict(zip(msg.names, (float(s) for s in msg.std))))))
        if not frames:
            raise InputError(f'{path}: no SampleFrame messages under {NAMESPACE}: the bag holds no samples')
        recording, spans = _assemble(frames, path, custom)
    if skipped:
        absent = [topic[len(NAMESPACE):] for topic, msgtype in bag_topics(path).items()
                  if msgtype == SAMPLE_FRAME and topic.startswith(NAMESPACE) and topic[len(NAMESPACE):] not in frames]
        warn_cost(data_cost(path, spans, recording.sample_period, absent, recording.gaps, recording.start_time))
    else:   # (the skipped chunks' cost names any cut too)
        warn_cost(short_signals(path, spans, recording.sample_period,
                                max(len(data) for fs in frames.values() for _, _, data in fs)))
    for series in (estimates, truth, effects):
        series.sort(key=lambda e: e[0])
    return BagContents(recording=recording, estimates=estimates, truth=truth, metadata=custom, effects=effects)


def warn_cost(cost):
    """Log data_cost's warning, if any."""
    if cost:
        log.warning('warning: %s', cost)


def check_period(path, period):
    """An InputError unless the sample period of a bag's frames is positive and finite."""
    if not 0 < period < math.inf:
        raise InputError(f'{path}: sample period {period} is not positive and finite')


def _assemble(frames, path, custom):
    """The Recording of each signal's frames [(stamp ns, period s, samples)], cut to the places all signals have
    samples at (FrameAligner), and {signal: (first stamp, end) ns} of the frames read."""
    names = sorted(frames)  # in the order iter_chunks checks them, to name the same gap
    aligner = FrameAligner(path, names, names, None, custom)
    for name in names:
        fs = sorted(frames[name], key=lambda f: f[0])
        aligner.frames(name, np.array([f[0] for f in fs], dtype=np.int64), np.array([f[1] for f in fs]),
                       np.array([len(f[2]) for f in fs], dtype=np.int64), np.concatenate([f[2] for f in fs]))
    parts = list(aligner.finish())
    signals = {name: np.concatenate([part.signals[name] for part in parts]) for name in names}
    spans = {name: (aligner.start[name], aligner.end[name]) for name in names}
    return Recording(sample_period=aligner.period, signals=signals, start_time=parts[0].start_time, source=str(path),
                     metadata=custom, gaps=tuple(aligner.gaps)), spans


class FrameAligner:
    """Frames of each signal, checked for overlaps, put on one grid of places (sample periods from the latest
    signal's first sample: read_bag's start) and handed out in parts of the places all signals have samples at,
    as soon as every signal has them. A part never spans a gap (frames missing from any signal): the next part's
    start_time says where the record goes on, and `gaps` are the record's (Recording.gaps) as handed out."""

    def __init__(self, path, names, wanted, chunk_samples, metadata):
        """names: the signals aligned; wanted: those the parts carry; chunk_samples: the longest part (None:
        a whole segment)."""
        self.path, self.names, self.chunk_samples, self.metadata = path, names, chunk_samples, metadata
        self.period = None
        self.start, self.end = {}, {}                    # ns: first stamp, stamp the next frame must have
        self.runs = {name: [] for name in names}         # [first place, end place, samples before] of its own
                                                         # places (0 at its first sample), in time order
        self.received = dict.fromkeys(names, 0)          # samples
        self.frame = 1                                   # samples of the longest frame
        self.queues = {name: _Queue() for name in wanted}
        self.taken = dict.fromkeys(wanted, 0)            # samples of each queue handed out or dropped
        self.first = None                                # the shared start (ns), once every signal has begun
        self.offsets = {}                                # of each signal's places from the shared start's
        self.cursor = 0                                  # places before it are handed out or not shared
        self.emitted, self.gaps, self._end = 0, [], None  # samples handed out, their gaps, the place after them
        self.start_time = None                           # s: of the first sample handed out

    def frames(self, name, stamps, periods, lengths, values):
        """Take frames of signal `name` in time order (stamps ns, sample periods s, lengths) and their samples."""
        if self.period is None:
            self.period = float(periods[0])
            check_period(self.path, self.period)
        if np.any(periods != self.period):
            different = sorted({self.period, *periods.tolist()})
            raise InputError(f'{self.path}: frames have different sample periods {different}')
        step = self.period * 1e9
        durations = np.rint(lengths * step).astype(np.int64)  # round(len(data) * period * 1e9)
        late = stamps - np.concatenate(([self.end.get(name, stamps[0])], stamps[:-1] + durations[:-1]))
        if np.any(late < -0.5 * step):
            stamp = stamps[np.argmax(late < -0.5 * step)]
            raise InputError(f'{self.path}: /emla/{name} has an overlap at t = {stamp * 1e-9:.6f} s (a frame that '
                             f'begins before the one before it ends)')
        missing = np.where(late > 0.5 * step, np.rint(late / step), 0).astype(np.int64)
        runs, within = self.runs[name], np.concatenate(([0], np.cumsum(lengths[:-1])))
        begins = (runs[-1][1] if runs else 0) + np.cumsum(missing) + within
        ends = begins + lengths
        breaks = np.flatnonzero(missing > 0) if runs else np.union1d([0], np.flatnonzero(missing > 0))
        if not len(breaks) or breaks[0] > 0:   # the first frames go on from the last run
            runs[-1][1] = int(ends[(breaks[0] if len(breaks) else len(stamps)) - 1])
        for j, stop in zip(breaks, [*breaks[1:], len(stamps)]):
            runs.append([int(begins[j]), int(ends[stop - 1]), self.received[name] + int(within[j])])
        self.start.setdefault(name, int(stamps[0]))
        self.end[name] = int(stamps[-1] + durations[-1])
        self.received[name] += int(lengths.sum())
        self.frame = max(self.frame, int(lengths.max()))
        if name in self.queues:
            self.queues[name].push(values)

    def parts(self, final=False):
        """The parts complete so far (final: all that are left; an empty record as one empty part)."""
        if self.first is None:
            if len(self.start) < len(self.names):
                return
            self.first = max(self.start.values())
            self.offsets = {n: round((self.first - self.start[n]) * 1e-9 / self.period) for n in self.names}
        if final and min(self.end.values()) <= self.first:
            raise InputError(f'{self.path}: the signal topics share no time span')
        frontier = min(self.runs[n][-1][1] - self.offsets[n] for n in self.names)  # every signal's runs are known
        size = self.chunk_samples or math.inf                                       # before it
        runs = {n: [(max(a - self.offsets[n], self.cursor), min(b - self.offsets[n], frontier))
                    for a, b, _ in self.runs[n]] for n in self.names}
        for a, b in shared(runs):
            closed = final or b < frontier   # no sample will join it
            while b - a >= size or (closed and a < b):
                n = min(size, b - a)
                yield self._part(a, n)
                a += n
            if not closed:
                self.cursor = a
                break
        else:
            self.cursor = max(self.cursor, frontier)
        for n in self.names:   # runs before the cursor are done with (the last one goes on)
            done = [r for r in self.runs[n][:-1] if r[1] - self.offsets[n] <= self.cursor]
            del self.runs[n][:len(done)]
        if final and not self.emitted:
            yield Recording(sample_period=self.period, signals={name: np.empty(0) for name in self.queues},
                            start_time=self.first * 1e-9, source=str(self.path), metadata=self.metadata)

    def finish(self):
        """The last parts. A signal without frames (all in skipped chunks, or counted by a summary only) is
        absent, as from read_bag."""
        self.names = [name for name in self.names if name in self.start]
        if not self.names:
            raise InputError(f'{self.path}: no SampleFrame messages under {NAMESPACE}: the bag holds no samples')
        self.queues = {name: queue for name, queue in self.queues.items() if name in self.start}
        yield from self.parts(final=True)
        check_gaps(self.path, self.gaps, self.emitted, self.start_time, self.period)

    def _part(self, place, size):
        """The part of `size` samples from the shared `place`."""
        if self._end is None:
            self.start_time = self.first * 1e-9 + place * self.period
        elif place > self._end:
            self.gaps.append((self.emitted, place - self._end))
            if len(self.gaps) > MAX_GAPS:
                check_gaps(self.path, self.gaps, self.emitted, self.start_time, self.period)
        signals = {}
        for name, queue in self.queues.items():
            at = self._sample(name, place)
            queue.drop(at - self.taken[name])
            signals[name] = queue.take(size)
            self.taken[name] = at + size
        part = Recording(sample_period=self.period, signals=signals, start_time=self.first * 1e-9 + place * self.period,
                         source=str(self.path), metadata=self.metadata)
        self.emitted += size
        self._end = place + size
        return part

    def _sample(self, name, place):
        """The number of a signal's sample at a shared place (which its runs cover)."""
        runs, local = self.runs[name], place + self.offsets[name]
        a, _, before = runs[bisect.bisect_right([r[0] for r in runs], local) - 1]
        return before + local - a


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
