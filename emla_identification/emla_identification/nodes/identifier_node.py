"""The identifier node: online grey-box identification (emla_identification.online) of the measured frames.

Publishes /emla/parameters (latched) at every multiple of `publish_period` that ends a control period,
stamped with the end of the data used, and a final estimate at the end time /emla/plant/done announces
(see emla_core.nodes.common); /diagnostics with each estimate. Bad frames (see common) are reported and
skipped, non-finite samples too: the estimator gets only finite samples, and a gap() wherever some are missing.
"""
import math
import sys

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from emla_core import messages, topics
from emla_core.errors import InputError
from emla_core.nodes import common
from emla_identification.online import OnlineIdentifier
from emla_identification.physical import MODEL_PARAMETERS
from emla_msgs.msg import ParameterEstimate

SPECS = [
    common.Spec('sample_period', 1e-4, 'sample period Ts of the frames, s', 1e-6, 1e-2),
    common.Spec('model', 'full', f'grey-box model, one of {sorted(MODEL_PARAMETERS)}'),
    common.Spec('forgetting', 1.0, 'RLS forgetting factor lambda (1 = no forgetting), 1', 0.5, 1.0),
    common.Spec('memory_time', 0.0,
                'memory time constant tau instead of a forgetting factor, lambda = 1 - Ts/tau (0 = unused), s',
                0.0, 1e6),
    common.Spec('publish_period', topics.ESTIMATE_PERIOD, 'publish an estimate at multiples of this simulated time, s', 1e-6, 1e6),
]


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
    identifier.update(ramp, ramp, ramp)
    estimate(identifier)


class IdentifierNode(common.EmlaNode):
    NAME = 'identifier'

    def __init__(self):
        super().__init__()
        p = common.declare(self, SPECS)
        if p.model not in MODEL_PARAMETERS:
            raise InputError(f'model {p.model!r} is not one of {sorted(MODEL_PARAMETERS)}')
        settings = dict(sample_period=p.sample_period, model=p.model, forgetting=p.forgetting,
                        memory_time=p.memory_time or None)
        self.identifier = OnlineIdentifier(**settings)
        warm_up(OnlineIdentifier(**settings))
        self.step = topics.to_ns(p.sample_period)
        self.publish_step = topics.to_ns(p.publish_period)
        self.covered = 0  # ns: the estimator has used every (usable) voltage interval before this time
        self.fed = None  # ns: the end of the samples fed last (the next ones follow on from there, or a gap)
        self.published = None  # stamp of the latest estimate
        self.end = None  # end of the run, from /emla/plant/done
        self.estimates = self.create_publisher(ParameterEstimate, topics.PARAMETERS_TOPIC, common.LATCHED_QOS)
        self.diagnostics = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS_TOPIC, common.DIAGNOSTICS_QOS)
        self.measured = common.AlignedSamples(self, topics.MEASURED_TOPICS, self.on_samples, common.Faults(self),
                                             p.sample_period, self.publish_step)
        self.create_subscription(Time, topics.DONE_TOPIC, self.on_done, common.LATCHED_QOS)

    def on_samples(self, start, samples):
        signals = [samples[name] for name in ('voltage', 'current', 'position')]
        finite = np.isfinite(signals).all(axis=0)
        for first, last in finite_runs(finite):
            if start + first * self.step != self.fed:
                self.identifier.gap()
            self.identifier.update(*(signal[first:last] for signal in signals))
            self.fed = start + last * self.step
        self.covered = start + len(finite) * self.step
        if self.covered % self.publish_step == 0 or self.covered == self.end:
            self.publish()

    def on_done(self, msg):
        self.end = topics.stamp_to_ns(msg)
        if self.covered == self.end and self.published != self.end:
            self.publish()

    def publish(self):
        values, std, (names, covariance) = estimate(self.identifier)
        stamp = messages.time_msg(self.covered)
        self.estimates.publish(messages.estimate_message(self.covered, values, std, (names, covariance),
                                                       self.identifier.samples, self.identifier.residual_rms))
        self.published = self.covered
        identified = sum(math.isfinite(v) for v in values.values())
        status = DiagnosticStatus(
            level=DiagnosticStatus.OK if identified == len(values) else DiagnosticStatus.WARN,
            name='emla/identifier', hardware_id='emla',
            message=f'{identified} of {len(values)} parameters identified', values=[
                KeyValue(key='excitation', value=f'{identified / len(values):g}'),
                KeyValue(key='covariance_trace', value=f'{np.trace(covariance):g}'),
                KeyValue(key='samples', value=str(self.identifier.samples)),
                KeyValue(key='residual_rms', value=f'{self.identifier.residual_rms:g}')])
        self.diagnostics.publish(DiagnosticArray(header=Header(stamp=stamp), status=[status]))


def main(args=None):
    return common.run(IdentifierNode, args)


if __name__ == '__main__':
    sys.exit(main())
