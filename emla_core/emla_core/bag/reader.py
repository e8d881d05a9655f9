"""Reading rosbag2 directories (or bare .mcap files) of the suite's topics whole: read_bag, iter_messages."""
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader

from emla_core.errors import InputError
from emla_core.messages import estimate_std, estimate_values, frame_data
from emla_core.recording import Recording
from emla_core.topics import (NAMESPACE, PARAMETER_ESTIMATE, PARAMETERS_TOPIC, SAMPLE_FRAME, TRUE_PARAMETERS_TOPIC,
                              stamp_to_ns)

from .schema import typestore


def _finite(values):
    return {k: v for k, v in values.items() if np.isfinite(v)}


@dataclass
class BagContents:
    recording: Recording
    estimates: list        # [(time_s, {name: value}, {name: std})] from /emla/parameters, in time order
    truth: list            # [(time_s, {name: value})] from /emla/plant/parameters (simulated runs only)
    metadata: dict         # custom_data of the bag


def bag_files(path):
    """The MCAP files of a bag directory (or the .mcap file itself) and its custom data."""
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


MCAP_ERRORS = (McapError, OSError, ValueError, KeyError, EOFError, IndexError, struct.error)  # unreadable files


def iter_messages(path, topics=None):
    """(topic, msgtype, stamp_ns, message) of a bag directory or .mcap file, file by file."""
    path = Path(path)
    if not path.exists():
        raise InputError(f'{path}: no such file or directory')
    store = typestore()
    files, _ = bag_files(path)
    for file in files:
        try:
            with file.open('rb') as f:
                for schema, channel, message in make_reader(f).iter_messages(topics=topics):
                    yield channel.topic, schema.name, message.log_time, store.deserialize_cdr(message.data,
                                                                                               schema.name)
        except MCAP_ERRORS as exc:
            raise InputError(f'{file}: unreadable MCAP: {" ".join(str(exc).split()) or type(exc).__name__}') from None


def read_bag(path):
    """The signals (assembled from SampleFrames), parameter estimates and custom metadata of a bag."""
    path = Path(path)
    if not path.exists():
        raise InputError(f'{path}: no such file or directory')
    _, custom = bag_files(path)
    frames, estimates, truth = {}, [], []
    for topic, msgtype, stamp, msg in iter_messages(path):
        if msgtype == SAMPLE_FRAME and topic.startswith(NAMESPACE):
            frames.setdefault(topic[len(NAMESPACE):], []).append(
                (stamp_to_ns(msg.header.stamp), msg.sample_period, frame_data(msg)))
        elif msgtype == PARAMETER_ESTIMATE and topic in (PARAMETERS_TOPIC, TRUE_PARAMETERS_TOPIC):
            stamp_s = stamp_to_ns(msg.header.stamp) * 1e-9
            values = _finite(estimate_values(msg))
            if topic == TRUE_PARAMETERS_TOPIC:
                truth.append((stamp_s, values))
            else:
                estimates.append((stamp_s, values, _finite(estimate_std(msg))))
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


