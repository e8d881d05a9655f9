"""A bag's signals in parts with bounded memory: iter_chunks.

The SampleFrames of each MCAP chunk are decoded in one compiled pass: the per-message deserialisation that
read_bag uses would take longer than the identification of the samples.
"""
from pathlib import Path

import numba
import numpy as np
from mcap.reader import make_reader

from emla_core.errors import InputError
from emla_core.topics import NAMESPACE, SAMPLE_FRAME

from .reader import (
    MCAP_ERRORS,
    FrameAligner,
    bag_files,
    chunk_data,
    data_cost,
    read_bag,
    reporting_skipped,
    short_signals,
    unreadable,
    warn_cost,
)

_MCAP_MESSAGE = 0x05      # the opcode of an MCAP Message record
_DECODE_BYTES = 1 << 20   # uncompressed chunk data decoded at a time


def iter_chunks(path, signals=None, chunk_samples=1 << 14):
    """read_bag(path).recording as consecutive Recordings of `chunk_samples` samples (the last one shorter),
    decoded and aligned as the MCAP chunks are read: memory holds a part, not the record. A part never spans a
    gap of the record (frames missing): the one after it is shorter, and its start_time says where it goes on.

    signals: the names the parts carry (default: all); all of the bag's signals are aligned, as read_bag does.
    Each signal's frames must be stored in time order (the suite stores frames at their stamps), where read_bag
    also accepts them shuffled. A file without a summary and chunk index (e.g. a bare .mcap whose writer was
    killed) is read whole by read_bag and comes as one part (a part per segment). A corrupt chunk is skipped as
    read_bag skips it, and the data it cost are named as read_bag names them.
    """
    if isinstance(chunk_samples, bool) or not isinstance(chunk_samples, int) or chunk_samples < 1:
        raise ValueError(f'chunk_samples must be a positive integer, got {chunk_samples!r}')
    path = Path(path)
    files, custom = bag_files(path)
    layouts = _signal_channels(files)
    if layouts is None:
        recording = read_bag(path).recording
        recording.signals = {k: v for k, v in recording.signals.items() if signals is None or k in signals}
        yield from recording.segments()
        return
    names = sorted({topic[len(NAMESPACE):] for _, channels in layouts for topic in channels.values()})
    if not names:
        raise InputError(f'{path}: no SampleFrame messages under {NAMESPACE}: the bag holds no samples')
    aligner = FrameAligner(path, names, names if signals is None else [n for n in names if n in signals],
                           chunk_samples, custom)
    skipped = []
    with reporting_skipped(skipped):
        for file, channels in layouts:
            slot_of_channel = np.full(max(channels, default=0) + 1, -1, dtype=np.int64)
            for channel, topic in channels.items():
                slot_of_channel[channel] = names.index(topic[len(NAMESPACE):])
            for slot_of, stamps, periods, lengths, values, starts in _decoded_chunks(
                    file, slot_of_channel, len(names), skipped.append):
                for slot, name in enumerate(names):
                    mine = slot_of == slot
                    if mine.any():
                        aligner.frames(name, stamps[mine], periods[mine], lengths[mine],
                                       values[starts[slot]:starts[slot + 1]])
                yield from aligner.parts()
        yield from aligner.finish()
    spans = {n: (aligner.start[n], aligner.end[n]) for n in aligner.names}
    if skipped:
        warn_cost(data_cost(path, spans, aligner.period, [n for n in names if n not in aligner.start], aligner.gaps,
                            aligner.start_time))
    else:   # a signal that begins late or ends early, as read_bag warns of it
        warn_cost(short_signals(path, spans, aligner.period, aligner.frame))


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
    except MCAP_ERRORS:
        return None


def _decoded_chunks(file, slot_of_channel, slots, on_corrupt):
    """_decode_frames of the chunks of an MCAP file, in file order, a few together (the records of consecutive
    chunks, uncompressed, are one valid sequence of records); a corrupt chunk is left out after
    on_corrupt(CorruptChunk). The chunk index is read here, file by file: over thousands of files it would take
    memory in proportion to the record."""
    try:
        with file.open('rb') as f:
            summary = make_reader(f).get_summary()
            if summary is None:  # it had one when iter_chunks began
                raise ValueError('the summary section is gone')
            chunk_indexes = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
            batch, size = [], 0
            for j, index in enumerate(chunk_indexes):
                data = chunk_data(f, file, chunk_indexes, j, on_corrupt)
                if data is not None:
                    batch.append(data)
                    size += len(data)
                if size >= _DECODE_BYTES or j == len(chunk_indexes) - 1:
                    *frames, bad = _decode_frames(np.frombuffer(b''.join(batch), np.uint8), slot_of_channel, slots)
                    if bad >= 0:
                        raise ValueError(f'malformed record or SampleFrame in the chunks before byte '
                                         f'{index.chunk_start_offset + index.chunk_length}')
                    yield frames
                    batch, size = [], 0
    except MCAP_ERRORS as exc:
        raise unreadable(file, exc) from None


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
        length = _little_endian(buf, pos + 1, 8) if pos + 9 <= buf.size else -1  # negative past 2**63: refused
        if length < 0 or length > buf.size - pos - 9:
            bad = pos
            break
        body, end = pos + 9, pos + 9 + length
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
