"""The identifier node: online grey-box identification (emla_identification.online) of the measured frames,
or with model `arx` a black-box ARX(na, nb, nk) model of one signal's response to another (emla_identification.arx,
the recursion of `emla identify --model arx`: from theta = 0 and P = 1e6 I, with the same forgetting).

Publishes /emla/parameters (latched; with model arx /emla/arx_model instead: a, b, poles, zeros, fit and MSE;
with `effects` or a `model_file` also /emla/effects, the effects' parameters estimated along, same stamps; with
`actuator: solenoid` the coil's R on /emla/effects alone, with `online_model` the whole solenoid model refitted over
a moving window there instead (emla_identification.solenoid_online.WindowedSolenoid; no model_file), and with
`position_observer` the armature's position
estimated from the voltage and current, without a position input, on /emla/position_estimate, a frame per frame in)
at every multiple of `publish_period` that ends a control period, stamped with the end of the data used, and a
final estimate at the end time /emla/plant/done announces (see emla_core.nodes); /diagnostics with the
first estimate, then every second of sample time, and with the final one. Bad frames (see emla_core.nodes) are
reported and skipped. An estimate that cannot be computed (an overflow, a singular or non-finite information
matrix: one frame of 1e50 among samples of order 1) is an input fault too ('unestimable', reported as the others):
the grey box goes back to the statistics of the last estimate it published (the frames since, which poisoned
them, forgotten: at most a publish period's; a second failure without a good estimate between restarts it), the
ARX estimator restarts (a solenoid's cannot: kept). Non-finite samples: the grey-box estimator gets only finite
samples, and a gap() wherever some are missing; the ARX one gets them in place and skips the regression rows
they are in (as identify_arx does), so its last model equals `emla identify --model arx` on the same data.

The samples are counted (SampleCounts): received, used by the estimator, lost (gaps in an input's stamps) and
skipped (out-of-order or duplicate stamps). The counts are in each /diagnostics status (WARN when any were lost
or skipped) and in one warning line when the first are lost or skipped, and one with the totals at the end of
the run (and at shutdown, if they changed since): never a line per gap.

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
from emla_core.messages import read_frame_cdr
from emla_core.nodes.alignment import AlignedSamples
from emla_core.nodes.faults import Faults
from emla_core.nodes.frames import subscribe_frames, subscribe_signal_frames
from emla_core.nodes.node import EmlaNode
from emla_core.nodes.param_specs import Spec, declare, family
from emla_core.nodes.qos import DIAGNOSTICS_QOS, FRAME_QOS, LATCHED_QOS
from emla_core.nodes.run import run
from emla_core.nodes.standard_topics import StandardTopics
from emla_identification.arx import DEFAULT_ORDERS, DEFAULT_SIGNALS, ArxEstimator
from emla_identification.moments import UnestimableError
from emla_identification.online import OnlineIdentifier
from emla_identification.physical import MODEL_PARAMETERS
from emla_msgs.msg import ArxModel, EffectEstimate, ParameterEstimate, SampleFrame

SPECS = [
    Spec('sample_period', 1e-4, 'sample period Ts of the inputs (the grid of input_topics), s', 1e-6, 1e-2),
    Spec('actuator', 'moving_coil', 'moving_coil, or solenoid: its coil resistance followed online from the '
                                    'voltage balance with the inductance curve of `model_file` (a solenoid\'s, '
                                    'emla identify --actuator solenoid --model-out), on /emla/effects'),
    Spec('position_observer', False, 'actuator solenoid without a position sensor: the armature\'s position '
                                     'estimated from the coil\'s voltage and current alone (a Kalman filter on its '
                                     'flux linkage, the mechanics and R), on /emla/position_estimate; needs '
                                     'current_noise and a model_file with the mechanics'),
    Spec('online_model', False, 'actuator solenoid: identify the whole model (R, L0, a, g0, m, B, k, F0) from the '
                                'voltage, current and position over the latest window_time, refitted every '
                                'refit_period, on /emla/effects (no model_file needed)'),
    Spec('window_time', 2.0, 'online_model: the samples each fit takes, the latest ones, s', 1e-3, 1e4),
    Spec('refit_period', 0.5, 'online_model: new samples between fits, s', 1e-4, 1e4),
    Spec('current_noise', 0.0, 'position_observer: the current\'s noise standard deviation (emla identify '
                               '--actuator solenoid --json: fit.electrical.rms / R), A', 0.0, 10.0),
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
# What computing an estimate raises where the data make it impossible (the grey box: UnestimableError alone;
# the ARX model's poles of a non-finite theta: LinAlgError, a ValueError)
UNESTIMABLE = (UnestimableError, np.linalg.LinAlgError, ArithmeticError)


class SampleCounts:
    """The samples of a node's inputs, counted frame by frame on their way in, and those the estimator used.

    For each input: `received` (every sample of every frame), `lost` (the instants of a gap in its stamps: a
    frame that starts more than 1.5 sample periods after the last sample of the one before counts the
    samples between them as lost) and `skipped` (the samples of a frame stamped before the end of the one
    before: out of order or a duplicate, which the frame handling drops). The totals are those of the input
    with the most of each (the inputs carry the same instants: a frame lost on every input is lost once);
    `used` is counted by the node (`use`).

    Parameters
    ----------
    names : iterable of str
        The inputs.
    step : int
        The sample period, ns.
    """

    def __init__(self, names, step):
        self.step = step
        self.received = dict.fromkeys(names, 0)
        self.lost = dict.fromkeys(names, 0)
        self.skipped = dict.fromkeys(names, 0)
        self.used = 0
        self._end = dict.fromkeys(names)  # ns: the instant after the latest frame's last sample, per input

    def frame(self, name, stamp, count):
        """Count a frame of input `name`: `count` samples from `stamp` (ns) on."""
        self.received[name] += count
        end = self._end[name]
        if end is not None and stamp < end - self.step // 2:
            self.skipped[name] += count
            return
        if end is not None and stamp - end > self.step // 2:  # the last sample was at end - step
            self.lost[name] += round((stamp - end) / self.step)
        self._end[name] = max(stamp + count * self.step, end or 0)

    def use(self, count):
        """Count `count` samples the estimator used."""
        self.used += count

    def totals(self):
        """{'samples_received', 'samples_used', 'samples_lost', 'samples_skipped'}: int."""
        return {'samples_received': max(self.received.values(), default=0), 'samples_used': self.used,
                'samples_lost': max(self.lost.values(), default=0),
                'samples_skipped': max(self.skipped.values(), default=0)}

    @property
    def faulty(self):
        """Whether any samples were lost or skipped."""
        totals = self.totals()
        return bool(totals['samples_lost'] or totals['samples_skipped'])

    def key_values(self):
        """The totals as diagnostic_msgs KeyValues."""
        return [KeyValue(key=key, value=str(value)) for key, value in self.totals().items()]

    def summary(self):
        """The totals in words, with the inputs that lost or skipped samples where not all did alike."""
        totals = self.totals()
        text = (f'{totals["samples_used"]} of {totals["samples_received"]} samples received used; '
                f'{totals["samples_lost"]} lost (gaps in the stamps), {totals["samples_skipped"]} skipped '
                f'(out-of-order or duplicate stamps)')
        counts = {name: (self.lost[name], self.skipped[name]) for name in self.received}
        if len(set(counts.values())) > 1:
            text += ' [' + ', '.join(f'{name}: {lost} lost, {skipped} skipped'
                                     for name, (lost, skipped) in counts.items() if lost or skipped) + ']'
        return text


class SampleFaults(Faults):
    """Faults whose lost and out-of-order frames ('missing', 'stamp_back') are counted but not logged: the
    node's SampleCounts says them in one line with the sample counts."""

    COUNTED = ('missing', 'stamp_back')

    def report(self, kind, message):
        if kind in self.COUNTED:
            self.counts[kind] += 1
        else:
            super().report(kind, message)


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
        self.solenoid = family(p.actuator) == 'solenoid'
        if p.position_observer and not self.solenoid:
            raise InputError('position_observer is for actuator solenoid (a moving coil\'s position is measured)')
        if p.online_model and not self.solenoid:
            raise InputError('online_model is for actuator solenoid (a moving coil\'s model is the grey box\'s)')
        if self.solenoid:
            self.identifier = solenoid_tracker(p)
            self.feed = self.identifier.update
            if p.position_observer:
                self.signals = ('voltage', 'current')
        elif self.arx:
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
        self.counts = SampleCounts(self.signals, self.step)
        self.counts_logged = None  # the totals of the latest warning line about lost or skipped samples
        self.status = None  # the diagnostic status of the latest estimate published, as a function
        self.estimates = None if self.solenoid else \
            self.create_publisher(ArxModel, topics.ARX_MODEL_TOPIC, LATCHED_QOS) if self.arx \
            else self.create_publisher(ParameterEstimate, topics.PARAMETERS_TOPIC, LATCHED_QOS)
        self.effect_estimates = None if self.arx or not self.identifier.effects else \
            self.create_publisher(EffectEstimate, topics.EFFECTS_TOPIC, LATCHED_QOS)
        self.position_estimates = self.create_publisher(SampleFrame, topics.POSITION_ESTIMATE_TOPIC, FRAME_QOS) \
            if self.solenoid and p.position_observer else None
        self.diagnostics = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS_TOPIC, DIAGNOSTICS_QOS)
        self.faults = faults = SampleFaults(self)
        together = p.measured_frames and not self.inputs
        self.measured = AlignedSamples(
            self, {name: spec.describe() for name, spec in self.inputs.items()}
            or {name: f'{topics.MEASURED_FRAMES_TOPIC} {name}' if together else topics.MEASURED_TOPICS[name]
                for name in self.signals},
            self.on_samples, faults, p.sample_period, self.publish_step, subscribe=False)
        if self.inputs:
            StandardTopics(self, self.inputs, self.receive, faults, p.sample_period)
        elif together:
            subscribe_signal_frames(self, topics.MEASURED_FRAMES_TOPIC, self)
        else:
            subscribe_frames(self, {name: topics.MEASURED_TOPICS[name] for name in self.signals},
                             lambda name, cdr: self.receive(name, *_frame_args(cdr)))
        self.create_subscription(Time, topics.DONE_TOPIC, self.on_done, LATCHED_QOS)

    def ready(self):
        waiting = ', '.join(dict.fromkeys(spec.topic for spec in self.inputs.values()))
        return super().ready() + (f'; subscribing to {waiting} once they have a publisher' if waiting else '')

    @property
    def names(self):
        """The inputs' names (for subscribe_signal_frames, which feeds receive())."""
        return self.measured.names

    def receive(self, name, stamp, samples, period):
        """A frame of input `name`: counted, then aligned with the other inputs' (AlignedSamples.receive)."""
        self.counts.frame(name, stamp, len(samples))
        if self.counts_logged is None and self.counts.faulty:
            self.log_counts('input samples lost or skipped so far: ')
        self.measured.receive(name, stamp, samples, period)

    def log_counts(self, prefix=''):
        """Log the sample counts as one warning line (if some were lost or skipped and it says something new)."""
        totals = self.counts.totals()
        if self.counts.faulty and totals != self.counts_logged:
            self.get_logger().warning(prefix + self.counts.summary())
            self.counts_logged = totals

    def stop(self, executor):
        """At shutdown: the totals, if they changed since the last line about them; then EmlaNode.stop."""
        self.log_counts('at shutdown: ')
        super().stop(executor)

    def on_samples(self, start, samples):
        signals = [samples[name] for name in self.signals]
        # ARX: every sample, in place (see the module doc)
        usable = np.full(len(signals[0]), True) if self.arx else np.isfinite(signals).all(axis=0)
        for first, last in finite_runs(usable):
            if start + first * self.step != self.fed:
                self.identifier.gap()
            fed = self.feed(*(signal[first:last] for signal in signals))
            if self.position_estimates:   # the observer's (positions, held flags)
                self.position_estimates.publish(messages.frame_message(start + first * self.step, self.sample_period,
                                                                       fed[0]))
            self.counts.use(last - first)
            self.fed = start + last * self.step
        self.covered = start + len(usable) * self.step
        if self.covered % self.publish_step == 0 or self.covered == self.end:
            self.publish()

    def on_done(self, msg):
        self.end = topics.stamp_to_ns(msg)
        self.measured.finish(self.end)
        if self.covered == self.end:
            if self.published != self.end:
                self.publish()
            else:  # the final estimate went out before the end was known: its status and counts now
                self.diagnose()

    def feed_arx(self, u, y):
        errors = self.identifier.update(u, y)
        finite = errors[np.isfinite(errors)]
        if finite.size:
            self.prediction_error = float(finite[-1])

    def publish(self):
        """Publish the estimate now and its status; one that cannot be computed is an input fault: recover(), then
        the estimate of what is left (if that fails too, the status says so and nothing is published)."""
        try:
            self.status = self.publish_estimate()
        except UNESTIMABLE as error:
            self.recover(error)
            try:
                self.status = self.publish_estimate()
            except UNESTIMABLE as again:
                self.status = self.no_estimate(again)
        else:  # (not after recover(): the state it went back to, whose checkpoint it used up)
            if hasattr(self.identifier, 'checkpoint'):
                self.identifier.checkpoint()  # the statistics the next failure goes back to
        self.published = self.covered
        self.diagnose()

    def publish_estimate(self):
        return self.publish_arx() if self.arx else self.publish_resistance() if self.solenoid \
            else self.publish_parameters()

    def recover(self, error):
        """After an estimate that cannot be computed: the grey box back to its last checkpoint (the statistics of
        the last estimate published, once; a second failure without a good estimate between resets it), the ARX
        estimator reset (a solenoid's estimator has neither: kept). The samples forgotten are no longer used."""
        at = f'the estimate at {self.covered / 1e9:.6g} s cannot be computed ({error})'
        if hasattr(self.identifier, 'restore'):
            forgotten = self.identifier.restore()
            what = 'reset' if not self.identifier.samples else \
                f'back to the estimate of its first {self.identifier.samples} samples'
        elif hasattr(self.identifier, 'reset'):
            forgotten, what = self.counts.used, 'reset'
            self.identifier.reset()
        else:
            forgotten, what = 0, 'kept (it cannot go back)'
        self.counts.use(-forgotten)
        self.faults.report('unestimable', f'{at}: the estimator {what}, {forgotten} samples since forgotten')

    def no_estimate(self, error):
        """The diagnostic status (as a function) for an instant without an estimate."""
        return lambda: DiagnosticStatus(level=DiagnosticStatus.WARN, name='emla/identifier', hardware_id='emla',
                                        message=f'no estimate: {error}', values=[])

    def diagnose(self):
        """The status of the latest estimate on /diagnostics with the first, then every DIAGNOSTICS_STEP of
        sample time, and with the final one (then the counts are logged too, if samples were lost or skipped)."""
        final = self.covered == self.end
        if self.diagnosed is None or self.covered - self.diagnosed >= DIAGNOSTICS_STEP or \
                final and self.diagnosed != self.end:
            self.diagnostics.publish(DiagnosticArray(header=Header(stamp=messages.time_msg(self.covered)),
                                                     status=[self.with_counts(self.status())]))
            self.diagnosed = self.covered
        if final:
            self.log_counts('at the end of the run: ')

    def with_counts(self, status):
        """The estimator's diagnostic `status` with the sample counts; WARN if samples were lost or skipped."""
        status.values.extend(self.counts.key_values())
        if self.counts.faulty:
            status.level = max(status.level, DiagnosticStatus.WARN)
            status.message += f'; {self.counts.summary()}'
        return status

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


    def publish_resistance(self):
        """Publish a solenoid's R, or its whole model (online_model), now (/emla/effects); a function that gives its
        diagnostic status: WARN before the first estimate, and for the model's failed fit or its warnings."""
        values, std, _ = self.identifier.full_estimate()
        self.effect_estimates.publish(messages.effect_message(self.covered, values, std))
        samples = self.identifier.samples
        problems = self.identifier.problems()
        message = f'solenoid: R {values["resistance"]:.6g} ohm from {samples} samples'
        return lambda: DiagnosticStatus(
            level=DiagnosticStatus.OK if samples and not problems else DiagnosticStatus.WARN, name='emla/identifier',
            hardware_id='emla', message='; '.join([message, *problems]),
            values=[KeyValue(key='samples', value=str(samples))]
            + [KeyValue(key=f'{name}_std', value=f'{value:g}') for name, value in std.items()])


def solenoid_tracker(p):
    """What a solenoid's identifier node runs, with the model of its model_file: the PositionObserver with
    position_observer (its current_noise), else the ResistanceTracker with the memory of its memory_time (or
    forgetting)."""
    from emla_core.model_file import read
    from emla_identification.solenoid_observer import PositionObserver
    from emla_identification.solenoid_online import ResistanceTracker, WindowedSolenoid
    if p.online_model:
        if p.model_file or p.position_observer or p.model != 'full' or p.effects or p.input_topics:
            raise InputError('online_model identifies the whole solenoid from its voltage, current and position: no '
                             'model_file, position_observer, model, effects or input_topics')
        return WindowedSolenoid(p.sample_period, window=p.window_time, refit_period=p.refit_period)
    if not p.model_file:
        raise InputError('actuator solenoid needs model_file: a solenoid\'s (emla identify --actuator solenoid '
                         '--model-out), whose inductance curve the resistance is followed with')
    if p.model != 'full' or p.effects or p.input_topics:
        raise InputError('actuator solenoid takes no model, effects or input_topics (it follows R alone)')
    params = read(p.model_file).require('solenoid', p.model_file).solenoid()
    if p.position_observer:
        if not p.current_noise > 0:
            raise InputError('position_observer needs current_noise: the current\'s noise standard deviation, A '
                             '(emla identify --actuator solenoid --json: fit.electrical.rms / R)')
        return PositionObserver(params, p.sample_period, current_noise=p.current_noise)
    memory = p.memory_time or (p.sample_period / (1.0 - p.forgetting) if p.forgetting < 1.0 else 1e6)
    return ResistanceTracker(params, p.sample_period, memory_time=memory)


def _frame_args(cdr):
    """(stamp, samples, period) of a serialised SampleFrame: receive()'s arguments after the input's name."""
    stamp, period, samples = read_frame_cdr(cdr)
    return stamp, samples, period


def main(args=None):
    return run(IdentifierNode, args)


if __name__ == '__main__':
    sys.exit(main())
