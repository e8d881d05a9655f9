"""The identifier node: online grey-box identification (emla_identification.online) of the measured frames,
or with model `arx` a black-box ARX(na, nb, nk) model of one signal's response to another (emla_identification.arx,
the recursion of `emla identify --model arx`: from theta = 0 and P = 1e6 I, with the same forgetting).

Publishes /emla/parameters (latched; with model arx /emla/arx_model instead: a, b, poles, zeros, fit and MSE;
with `effects` or a `model_file` also /emla/effects, the effects' parameters estimated along, same stamps)
at every multiple of `publish_period` that ends a control period, stamped with the end of the data used, and a
final estimate at the end time /emla/plant/done announces (see emla_core.nodes); /diagnostics with the
first estimate, then every second of sample time, and with the final one. Bad frames (see emla_core.nodes) are
reported and skipped. Non-finite samples: the grey-box estimator gets only finite samples, and a gap() wherever
some are missing; the ARX one gets them in place and skips the regression rows they are in (as identify_arx
does), so its last model equals `emla identify --model arx` on the same data.

Its inputs are the measured /emla/ SampleFrames, or with `input_topics` a real drive's topics of standard
message types, e.g. ['voltage=/drive/voltage', 'current=/drive/current', 'position=/joint_states:position[slider]']
(the syntax of `emla identify --topics`; with model arx only the input and output need mapping): each sample
goes on the sample_period grid by its message's header stamp, else its receive time, then takes the frames'
path (StandardTopics). The time stamps put publish instants and the done signal on that time line too.
"""
import math
import sys

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.parameter import Parameter
from std_msgs.msg import Header

from emla_core import messages, topics
from emla_core.errors import InputError
from emla_core.nodes.alignment import AlignedSamples
from emla_core.nodes.faults import Faults
from emla_core.nodes.frames import subscribe_signal_frames
from emla_core.nodes.node import EmlaNode
from emla_core.nodes.param_specs import Spec, declare
from emla_core.nodes.qos import DIAGNOSTICS_QOS, LATCHED_QOS
from emla_core.nodes.run import run
from emla_core.nodes.standard_topics import StandardTopics
from emla_identification.arx import DEFAULT_ORDERS, DEFAULT_SIGNALS, ArxEstimator
from emla_identification.online import OnlineIdentifier
from emla_identification.physical import MODEL_PARAMETERS
from emla_msgs.msg import ArxModel, EffectEstimate, ParameterEstimate

SPECS = [
    Spec('sample_period', 1e-4, 'sample period Ts of the inputs (the grid of input_topics), s', 1e-6, 1e-2),
    Spec('model', 'full', f'grey-box model, one of {sorted(MODEL_PARAMETERS)}, or arx (black box: orders, '
                                 'input, output; published on /emla/arx_model)'),
    Spec('forgetting', 1.0, 'RLS forgetting factor lambda (1 = no forgetting), 1', 0.5, 1.0),
    Spec('memory_time', 0.0,
                'memory time constant tau instead of a forgetting factor, lambda = 1 - Ts/tau (0 = unused), s',
                0.0, 1e6),
    Spec('orders', list(DEFAULT_ORDERS),
                'model arx: [na, nb, nk], the output lags, input lags and input delay (samples)'),
    Spec('input', DEFAULT_SIGNALS[0], f'model arx: the input signal u, one of {list(topics.SIGNALS)}'),
    Spec('output', DEFAULT_SIGNALS[1], f'model arx: the output signal y, one of {list(topics.SIGNALS)}'),
    Spec('measured_frames', False, 'take the measured frames of each period in one message on /emla/frames '
                                          '(as `emla launch` runs it) instead of /emla/{voltage,current,position}'),
    Spec('effects', Parameter.Type.STRING_ARRAY,
                'grey box: effects estimated online with the nominal parameters, published on /emla/effects: those '
                'of the physics layer with an online column, or followed by the memory (docs/physics.md section 6; '
                'an effect that cannot run online is refused with its reason)'),
    Spec('model_file', '', 'grey box: a model file (emla discrepancy --model-out) whose effects to estimate '
                                  'online, as `effects` (which adds to them)'),
    Spec('publish_period', topics.ESTIMATE_PERIOD,
                'publish an estimate at multiples of this time (of the samples: simulated, or the inputs\' stamps), s',
                1e-6, 1e6),
    Spec('input_topics', Parameter.Type.STRING_ARRAY,
                'inputs from topics of standard message types instead of /emla/{voltage,current,position} (empty): '
                'NAME=TOPIC[:FIELD[INDEX]] for voltage, current and position, as `emla identify --topics` '
                '(Float64/32, their MultiArrays, JointState, SampleFrame; type and QoS from the publishers; time: '
                'header stamp, else when handled (jittery), to the nearest sample instant). rclpy takes ~6-10k '
                'messages/s, so one sample per message suits rates up to ~1-2 kHz'),
]


DIAGNOSTICS_STEP = 1_000_000_000  # ns of sample time between /diagnostics statuses (ROS's usual 1 Hz)


def estimate(identifier):
    """(values, std, (names, covariance)) of the estimator now."""
    with np.errstate(invalid='ignore'):  # NaN std (negative variance) before enough excitation
        return identifier.full_estimate()


def finite_runs(finite):
    """[first, last) of each run of True in a 1-D boolean array."""
    return np.flatnonzero(np.diff(finite, prepend=False, append=False)).reshape(-1, 2).tolist()


def warm_up(identifier):
    """Run the estimator's compiled kernels once (about 0.5 s the first time), before the node subscribes:
    the plant starts only then, so the first frames do not pile up (a non-adaptive loop does not wait)."""
    ramp = np.linspace(0.0, 1.0, 32)
    if isinstance(identifier, ArxEstimator):
        identifier.update(ramp, ramp)
    else:
        identifier.update(ramp, ramp, ramp)
        estimate(identifier)


def arx_signals(p):
    """(input, output) with model arx, else None; the model and the ARX parameters checked."""
    if p.model != 'arx':
        if p.model not in MODEL_PARAMETERS:
            raise InputError(f'model {p.model!r} is not one of {sorted(MODEL_PARAMETERS)} or arx')
        return None
    if len(p.orders) != 3:
        raise InputError(f'orders {list(p.orders)}: need three integers [na, nb, nk]')
    for name in ('input', 'output'):
        if getattr(p, name) not in topics.SIGNALS:
            raise InputError(f'{name} {getattr(p, name)!r} is not one of {list(topics.SIGNALS)}')
    if p.input == p.output:
        raise InputError(f'input and output are both {p.input}; choose two signals')
    return p.input, p.output


def online_effects(p):
    """The effects to estimate online: those of the model file, then the `effects` parameter's."""
    effects = []
    if p.model_file:
        from emla_core.model_file import read
        effects = [effect.candidate for effect in read(p.model_file).effects]
    return tuple(dict.fromkeys(effects + list(p.effects)))


def standard_inputs(mapping, signals):
    """{signal: TopicSignal} of the input_topics parameter, which must map `signals`; {} if it is empty."""
    if not mapping:
        return {}
    from emla_core.bag.foreign import parse_topics  # with rosbags: loaded only when used
    inputs = parse_topics(','.join(mapping), 'input_topics')
    if set(inputs) != set(signals):
        raise InputError(f'input_topics maps {", ".join(inputs)}; map {", ".join(signals)}')
    return inputs


class IdentifierNode(EmlaNode):
    NAME = 'identifier'
    # Outside the loop (an adaptive controller takes each estimate an adaptation period after its stamp), it
    # takes the frames that came every POLL_PERIOD instead of waking for each of them (see EmlaNode).
    POLL_PERIOD = 0.003  # s

    def __init__(self):
        super().__init__()
        p = declare(self, SPECS)
        self.arx = arx_signals(p)
        self.signals = self.arx or topics.SIGNALS  # what the estimator is fed, in its update()'s order
        self.inputs = standard_inputs(p.input_topics, self.signals)
        if self.inputs:
            self.POLL_PERIOD = None  # unstamped messages are timed when handled: each as it comes
        memory = dict(sample_period=p.sample_period, forgetting=p.forgetting, memory_time=p.memory_time or None)
        if self.arx:
            self.identifier = ArxEstimator(*p.orders, **memory)
            warm_up(ArxEstimator(*p.orders, **memory))
            self.feed = self.feed_arx
            self.prediction_error = math.nan  # the latest finite one
        else:
            effects = online_effects(p)
            self.identifier = OnlineIdentifier(model=p.model, effects=effects, **memory)
            warm_up(OnlineIdentifier(model=p.model, effects=effects, **memory))
            self.feed = self.identifier.update
        self.sample_period = p.sample_period
        self.step = topics.to_ns(p.sample_period)
        self.publish_step = topics.to_ns(p.publish_period)
        self.covered = 0  # ns: the estimator has used every (usable) voltage interval before this time
        self.fed = None  # ns: the end of the samples fed last (the next ones follow on from there, or a gap)
        self.published = None  # stamp of the latest estimate
        self.diagnosed = None  # stamp of the latest /diagnostics status
        self.end = None  # end of the run, from /emla/plant/done
        self.estimates = self.create_publisher(ArxModel, topics.ARX_MODEL_TOPIC, LATCHED_QOS) if self.arx \
            else self.create_publisher(ParameterEstimate, topics.PARAMETERS_TOPIC, LATCHED_QOS)
        self.effect_estimates = None if self.arx or not self.identifier.effects else \
            self.create_publisher(EffectEstimate, topics.EFFECTS_TOPIC, LATCHED_QOS)
        self.diagnostics = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS_TOPIC, DIAGNOSTICS_QOS)
        faults = Faults(self)
        together = p.measured_frames and not self.inputs
        self.measured = AlignedSamples(
            self, {name: spec.describe() for name, spec in self.inputs.items()}
            or {name: f'{topics.MEASURED_FRAMES_TOPIC} {name}' if together else topics.MEASURED_TOPICS[name]
                for name in self.signals},
            self.on_samples, faults, p.sample_period, self.publish_step, subscribe=not (self.inputs or together))
        if self.inputs:
            StandardTopics(self, self.inputs, self.measured.receive, faults, p.sample_period)
        elif together:
            subscribe_signal_frames(self, topics.MEASURED_FRAMES_TOPIC, self.measured)
        self.create_subscription(Time, topics.DONE_TOPIC, self.on_done, LATCHED_QOS)

    def ready(self):
        waiting = ', '.join(dict.fromkeys(spec.topic for spec in self.inputs.values()))
        return super().ready() + (f'; subscribing to {waiting} once they have a publisher' if waiting else '')

    def on_samples(self, start, samples):
        signals = [samples[name] for name in self.signals]
        # ARX: every sample, in place (see the module doc)
        usable = np.full(len(signals[0]), True) if self.arx else np.isfinite(signals).all(axis=0)
        for first, last in finite_runs(usable):
            if start + first * self.step != self.fed:
                self.identifier.gap()
            self.feed(*(signal[first:last] for signal in signals))
            self.fed = start + last * self.step
        self.covered = start + len(usable) * self.step
        if self.covered % self.publish_step == 0 or self.covered == self.end:
            self.publish()

    def on_done(self, msg):
        self.end = topics.stamp_to_ns(msg)
        self.measured.finish(self.end)
        if self.covered == self.end and self.published != self.end:
            self.publish()

    def feed_arx(self, u, y):
        errors = self.identifier.update(u, y)
        finite = errors[np.isfinite(errors)]
        if finite.size:
            self.prediction_error = float(finite[-1])

    def publish(self):
        status = self.publish_arx() if self.arx else self.publish_parameters()
        if self.diagnosed is None or self.covered - self.diagnosed >= DIAGNOSTICS_STEP or self.covered == self.end:
            self.diagnostics.publish(DiagnosticArray(header=Header(stamp=messages.time_msg(self.covered)),
                                                     status=[status()]))
            self.diagnosed = self.covered
        self.published = self.covered

    def publish_arx(self):
        """Publish the ARX model now; a function that gives its diagnostic status."""
        model, samples = self.identifier.model, self.identifier.rls.samples
        self.estimates.publish(messages.arx_message(self.covered, model, self.arx, self.sample_period, samples,
                                                    self.prediction_error))
        return lambda: DiagnosticStatus(
            level=DiagnosticStatus.OK if samples else DiagnosticStatus.WARN, name='emla/identifier', hardware_id='emla',
            message=f'ARX{model.orders} of {self.arx[1]} from {self.arx[0]}: {samples} samples', values=[
                KeyValue(key='largest_pole_modulus', value=f'{max(np.abs(model.poles), default=0.0):.9g}'),
                KeyValue(key='samples', value=str(samples)),
                KeyValue(key='covariance_trace', value=f'{np.trace(self.identifier.rls.covariance):g}'),
                KeyValue(key='prediction_error', value=f'{self.prediction_error:g}')])

    def publish_parameters(self):
        """Publish the grey-box estimate now; a function that gives its diagnostic status."""
        values, std, (names, covariance) = estimate(self.identifier)
        if self.effect_estimates:  # first: a controller that adapts them takes the two together
            effects = self.identifier.effects
            self.effect_estimates.publish(messages.effect_message(self.covered, {k: values[k] for k in effects},
                                                                  {k: std[k] for k in effects}))
        self.estimates.publish(messages.estimate_message(self.covered, values, std, (names, covariance),
                                                       self.identifier.samples, self.identifier.residual_rms))
        identified = sum(math.isfinite(v) for v in values.values())
        return lambda: DiagnosticStatus(
            level=DiagnosticStatus.OK if identified == len(values) else DiagnosticStatus.WARN,
            name='emla/identifier', hardware_id='emla',
            message=f'{identified} of {len(values)} parameters identified', values=[
                KeyValue(key='excitation', value=f'{identified / len(values):g}'),
                KeyValue(key='covariance_trace', value=f'{np.trace(covariance):g}'),
                KeyValue(key='samples', value=str(self.identifier.samples)),
                KeyValue(key='residual_rms', value=f'{self.identifier.residual_rms:g}')])


def main(args=None):
    return run(IdentifierNode, args)


if __name__ == '__main__':
    sys.exit(main())
