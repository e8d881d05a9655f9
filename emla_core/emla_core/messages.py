"""One builder and one reader per message type of the suite, used by the nodes, the recorder, `emla simulate`
and `emla import` alike (bags store the same messages the graph publishes, serialised by rclpy); ArxModel has
a builder only (no bag holds it).

The readers take either an rclpy message or a rosbags one (a bag read back): both carry the same fields.
"""
import array
import importlib
import struct

import numpy as np
from builtin_interfaces.msg import Time

from emla_core.limits import MAX_STAMP_NS, check_stamp
from emla_core.parameters import PARAMETER_NAMES
from emla_core.topics import SIGNALS
from emla_msgs.msg import ArxModel, EffectEstimate, ParameterEstimate, SampleFrame


def message_class(msgtype):
    """The rclpy class of 'pkg/msg/Name' (or 'pkg/Name')."""
    package, *_, name = msgtype.split('/')
    return getattr(importlib.import_module(f'{package}.msg'), name)



def serialize(message):
    """The CDR bytes of an rclpy message, as a bag stores them."""
    from rclpy.serialization import serialize_message
    return serialize_message(message)


# ---- builtin_interfaces/Time ----

def time_msg(ns):
    """A builtin_interfaces/Time of `ns` nanoseconds; InputError beyond what it holds (limits.check_stamp: its
    sec is a signed 32-bit integer, which rclpy would wrap without a word)."""
    if not 0 <= ns <= MAX_STAMP_NS:
        check_stamp(ns, 'a stamp')
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


# ---- emla_msgs/SampleFrame ----

def frame_message(stamp, sample_period, data, frame_id=''):
    """A SampleFrame of `data` (1-D float64) with its first sample at `stamp` (ns)."""
    msg = SampleFrame(sample_period=float(sample_period))
    msg.header.stamp = time_msg(stamp)
    msg.header.frame_id = frame_id
    msg.data = array.array('d', np.ascontiguousarray(data, dtype=np.float64).tobytes())
    return msg


# Serialised messages (CDR, XCDR1) built and read without rclpy message objects: a node publishes the bytes (a
# publisher takes them) and subscribes raw, for a few us per message where building or converting an rclpy
# message costs some 15 us. The bytes are rclpy's but for the padding, zeros here. After the encapsulation
# (little endian), a SampleFrame with an empty frame_id is: stamp sec and nanosec, frame_id (length 1: its NUL),
# padding to 8, sample_period, data length, and if there are data, padding to 8 and the data. CDR aligns from
# the start of the body (after the encapsulation), so a frame inside a SignalFrames pads as its place needs.
_LITTLE_ENDIAN = b'\x00\x01\x00\x00'
_FRAME_STAMP = struct.Struct('<iII')
_FRAME_PERIOD = struct.Struct('<dI')


def _frame_body(stamp, sample_period, data, at):
    """A SampleFrame (empty frame_id) serialised from body offset `at` (a multiple of 4)."""
    data = np.ascontiguousarray(data, dtype='<f8')
    if not 0 <= stamp <= MAX_STAMP_NS:
        check_stamp(stamp, 'a frame stamp')
    head = _FRAME_STAMP.pack(stamp // 1_000_000_000, stamp % 1_000_000_000, 1) + bytes(4 if at % 8 == 0 else 8) \
        + _FRAME_PERIOD.pack(sample_period, len(data))
    return head + bytes(4) + data.tobytes() if len(data) else head


def _read_frame_body(cdr, at, order):
    """((stamp ns, sample period s, samples), end) of the SampleFrame serialised from byte `at` of `cdr`."""
    sec, nanosec, id_length = struct.unpack_from(order + 'iII', cdr, at)
    period_at = 4 + (at + 8 + id_length + 7) // 8 * 8  # 8-aligned in the body, which starts at byte 4
    sample_period, length = struct.unpack_from(order + 'dI', cdr, period_at)
    if not length:
        return (sec * 1_000_000_000 + nanosec, sample_period, np.empty(0)), period_at + 12
    samples = np.frombuffer(cdr, dtype=order + 'f8', count=length, offset=period_at + 16)
    return (sec * 1_000_000_000 + nanosec, sample_period, samples), period_at + 16 + 8 * length


def header_stamp_ns(cdr):
    """The stamp a serialised message starts with (std_msgs/Header or builtin_interfaces/Time), in ns."""
    sec, nanosec = struct.unpack_from('<iI' if cdr[1] == 1 else '>iI', cdr, 4)
    return sec * 1_000_000_000 + nanosec


def frame_cdr(stamp, sample_period, data):
    """The CDR bytes of frame_message(stamp, sample_period, data); an empty one padded to 36 bytes as rclpy pads
    it (a bag's reader may expect that)."""
    body = _frame_body(stamp, sample_period, data, 0)
    return _LITTLE_ENDIAN + (body if len(body) % 8 == 0 else body + bytes(4))


def read_frame_cdr(cdr):
    """(stamp ns, sample period s, samples) of a serialised SampleFrame (a raw subscription's bytes), the samples
    a read-only float64 array over `cdr`; any frame_id and byte order. struct.error if it is too short."""
    return _read_frame_body(cdr, 4, '<' if cdr[1] == 1 else '>')[0]


# ---- emla_msgs/SignalFrames ----

def signal_frames_cdr(sample_period, frames):
    """The CDR bytes of a SignalFrames of frames {signal: (stamp ns, data)} of every signal in SIGNALS."""
    body = b''
    for name in SIGNALS:
        stamp, data = frames[name]
        body += _frame_body(stamp, sample_period, data, len(body))
    return _LITTLE_ENDIAN + body


def read_signal_frames_cdr(cdr):
    """{signal: (stamp ns, sample period s, samples)} of a serialised SignalFrames (as read_frame_cdr)."""
    order, at, frames = '<' if cdr[1] == 1 else '>', 4, {}
    for name in SIGNALS:
        frames[name], at = _read_frame_body(cdr, at, order)
    return frames


# ---- emla_msgs/ParameterEstimate ----

def estimate_message(stamp, values, std=None, covariance=None, samples=0, residual_rms=float('nan')):
    """A ParameterEstimate stamped `stamp` (ns); covariance = (names, matrix) of the identified parameters
    (the full matrix is stored, 6 x 6 in PARAMETER_NAMES order; other names, an effect's, are left to
    effect_message). What is not given is NaN."""
    msg = ParameterEstimate(samples_used=int(samples), residual_rms=float(residual_rms))
    msg.header.stamp = time_msg(stamp)
    for name in PARAMETER_NAMES:
        setattr(msg, name, float(values.get(name, float('nan'))))
    std = std or {}
    msg.std = [float(std.get(name, float('nan'))) for name in PARAMETER_NAMES]
    full = np.full((len(PARAMETER_NAMES),) * 2, np.nan)
    if covariance is not None:
        names, matrix = covariance
        kept = [k for k, name in enumerate(names) if name in PARAMETER_NAMES]
        index = [PARAMETER_NAMES.index(names[k]) for k in kept]
        full[np.ix_(index, index)] = np.asarray(matrix)[np.ix_(kept, kept)]
    msg.covariance = full.ravel()
    return msg


def estimate_values(msg):
    """{name: value} of a ParameterEstimate (NaN for what the estimator does not identify)."""
    return {name: float(getattr(msg, name)) for name in PARAMETER_NAMES}


def estimate_std(msg):
    """{name: one-sigma} of a ParameterEstimate (NaN where unknown)."""
    return dict(zip(PARAMETER_NAMES, (float(s) for s in msg.std)))


# ---- emla_msgs/EffectEstimate ----

def effect_message(stamp, values, std=None):
    """An EffectEstimate stamped `stamp` (ns) of the effects' parameters {name: value} (and {name: one-sigma})."""
    std = std or {}
    msg = EffectEstimate(names=list(values), values=[float(v) for v in values.values()],
                         std=[float(std.get(name, float('nan'))) for name in values])
    msg.header.stamp = time_msg(stamp)
    return msg


def effect_values(msg):
    """{name: value} of an EffectEstimate."""
    return dict(zip(msg.names, (float(v) for v in msg.values)))


# ---- emla_msgs/ArxModel ----

def arx_message(stamp, model, signals, sample_period, samples=0, prediction_error=float('nan')):
    """An ArxModel stamped `stamp` (ns) of `model` (an emla_identification.arx.ArxModel: orders, a, b, poles, zeros,
    forgetting, fit_percent, mse) from the input to the output signal, signals = (input, output)."""
    na, nb, nk = model.orders
    poles, zeros = model.poles, model.zeros
    msg = ArxModel(input_signal=signals[0], output_signal=signals[1], na=na, nb=nb, nk=nk,
                   sample_period=float(sample_period), a=model.a.tolist(), b=model.b.tolist(),
                   poles_real=poles.real.tolist(), poles_imag=poles.imag.tolist(),
                   zeros_real=zeros.real.tolist(), zeros_imag=zeros.imag.tolist(),
                   forgetting=float(model.forgetting), samples_used=int(samples),
                   prediction_error=float(prediction_error), fit_percent=float(model.fit_percent),
                   mse=float(model.mse))
    msg.header.stamp = time_msg(stamp)
    return msg
