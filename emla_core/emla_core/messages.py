"""One builder and one reader per message type of the suite, used by the nodes, the recorder, `emla simulate`
and `emla import` alike (bags store the same messages the graph publishes, serialised by rclpy); ArxModel has
a builder only (no bag holds it).

The readers take either an rclpy message or a rosbags one (a bag read back): both carry the same fields.
"""
import array
import importlib

import numpy as np
from builtin_interfaces.msg import Time

from emla_core.parameters import PARAMETER_NAMES
from emla_msgs.msg import ArxModel, ParameterEstimate, SampleFrame


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
    """A builtin_interfaces/Time of `ns` nanoseconds."""
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


# ---- emla_msgs/SampleFrame ----

def frame_message(stamp, sample_period, data, frame_id=''):
    """A SampleFrame of `data` (1-D float64) with its first sample at `stamp` (ns)."""
    msg = SampleFrame(sample_period=float(sample_period))
    msg.header.stamp = time_msg(stamp)
    msg.header.frame_id = frame_id
    msg.data = array.array('d', np.ascontiguousarray(data, dtype=np.float64).tobytes())
    return msg


def frame_data(msg):
    """The samples of a SampleFrame as a read-only float64 array over the message's buffer."""
    return np.frombuffer(msg.data, dtype=np.float64)


# ---- emla_msgs/ParameterEstimate ----

def estimate_message(stamp, values, std=None, covariance=None, samples=0, residual_rms=float('nan')):
    """A ParameterEstimate stamped `stamp` (ns); covariance = (names, matrix) of the identified parameters
    (the full matrix is stored, 6 x 6 in PARAMETER_NAMES order). What is not given is NaN."""
    msg = ParameterEstimate(samples_used=int(samples), residual_rms=float(residual_rms))
    msg.header.stamp = time_msg(stamp)
    for name in PARAMETER_NAMES:
        setattr(msg, name, float(values.get(name, float('nan'))))
    std = std or {}
    msg.std = [float(std.get(name, float('nan'))) for name in PARAMETER_NAMES]
    full = np.full((len(PARAMETER_NAMES),) * 2, np.nan)
    if covariance is not None:
        index = [PARAMETER_NAMES.index(name) for name in covariance[0]]
        full[np.ix_(index, index)] = covariance[1]
    msg.covariance = full.ravel()
    return msg


def estimate_values(msg):
    """{name: value} of a ParameterEstimate (NaN for what the estimator does not identify)."""
    return {name: float(getattr(msg, name)) for name in PARAMETER_NAMES}


def estimate_std(msg):
    """{name: one-sigma} of a ParameterEstimate (NaN where unknown)."""
    return dict(zip(PARAMETER_NAMES, (float(s) for s in msg.std)))


def estimate_covariance(msg):
    """The 6 x 6 covariance of a ParameterEstimate (PARAMETER_NAMES order; NaN where unknown)."""
    return np.asarray(msg.covariance, dtype=float).reshape(len(PARAMETER_NAMES), len(PARAMETER_NAMES))


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
