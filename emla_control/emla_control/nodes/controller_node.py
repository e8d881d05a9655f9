"""The controller node: the adaptive inverse-system controller (emla_control.controller) in the lockstep.

From the last sample of each measured state frame (time t) it computes the voltage held over the control
period starting at t + Tc and publishes it (stamp t + Tc): one period of computational delay, so that it
computes while the plant runs the period from t (whose voltage it published a period earlier); the law
predicts the state at t + Tc from its model (InverseSystemController.step_ahead). From its first state
(t = 0) it also commands the period starting there, with the law's voltage without delay. The stroke reference
it tracks goes out ahead, in frames of REFERENCE_FRAME periods. Adaptive: at each t that is a multiple of
`adaptation_period` (from the second on) it first waits for the estimate stamped one adaptation period
earlier (see emla_core.nodes) and offers it to the controller's guard. Without a usable state for t (a
bad frame, reported: see emla_core.nodes) it holds the last voltage over the period from t + Tc, still published so
the lockstep goes on. With `adapt_effects` it takes the effect estimate of the same stamp (/emla/effects) with
each estimate: the friction and spring the identifier estimates online are compensated like the model's.

With `actuator: solenoid` the law is a solenoid's (emla_control.solenoid, of `model_file`; empty: the valve of
issue 24), from the state it predicts one period ahead (SolenoidController.step_ahead); adaptive, it takes the
coil's R the identifier follows (/emla/effects) once that estimate is from `min_samples` samples.
"""
import collections
import copy
import math
import sys

import numpy as np
from rclpy.qos import QoSProfile

from emla_control import controller as law
from emla_control import solenoid as solenoid_law
from emla_control.reference import StrokeReference
from emla_core import messages, topics
from emla_core.errors import InputError
from emla_core.nodes.faults import Faults
from emla_core.nodes.frames import FrameSets, frame_publishers, subscribe_signal_frames
from emla_core.nodes.node import EmlaNode
from emla_core.nodes.param_specs import (
    ACTUATOR_FIELDS,
    Spec,
    actuator_specs,
    declare,
    family,
    period_samples,
    solenoid_from,
)
from emla_core.nodes.qos import LATCHED_QOS
from emla_core.nodes.run import run
from emla_core.parameters import FAMILIES, ActuatorParameters
from emla_msgs.msg import EffectEstimate, ParameterEstimate

BLOCK = 100  # control periods of reference evaluated at once
# Control periods per /emla/reference frame: only a recorder reads them, and fewer, longer frames cost it less.
REFERENCE_FRAME = 10
# The estimates as they are published (LATCHED), but keeping several: each is taken an adaptation period after
# its stamp, and the next one may have come by then.
ESTIMATE_QOS = QoSProfile(depth=10, reliability=LATCHED_QOS.reliability,
                          durability=LATCHED_QOS.durability)
# Closed-loop bandwidth for the default 1 ms control period, where it tracks best (12 um RMS on the default
# stroke in simulation); the library's default suits 10 kHz control and saturates the voltage at 1 kHz.
BANDWIDTH = 150.0  # Hz

SPECS = [
    Spec('sample_period', 1e-4, 'sample period Ts, s', 1e-6, 1e-2),
    Spec('control_period', topics.CONTROL_PERIOD, 'control period Tc (a whole multiple of Ts), s', 1e-6, 1.0),
    Spec('bandwidth', BANDWIDTH, 'closed-loop bandwidth, Hz', 0.1, 1e4),
    Spec('damping_ratio', law.DEFAULT_DAMPING, 'closed-loop damping ratio, 1', 0.05, 10.0),
    Spec('observer_bandwidth', law.DEFAULT_OBSERVER_BANDWIDTH, 'velocity observer bandwidth, Hz', 0.1, 1e5),
    Spec('actuator', 'moving_coil', f'the actuator family, of {list(FAMILIES)}'),
    Spec('model_file', '', 'actuator solenoid: the model file of the law (emla identify --actuator solenoid '
                           '--model-out); empty: the valve of issue 24'),
    Spec('flux_time', solenoid_law.DEFAULT_FLUX_TIME, 'actuator solenoid: time constant of the flux loop, s',
         1e-6, 1.0),
    Spec('stroke', StrokeReference.stroke, 'reference stroke, m', 1e-6, 1.0),
    Spec('reference_offset', StrokeReference.offset, 'position the reference cycle starts from and returns to, m',
         -1.0, 1.0),
    Spec('reference_period', StrokeReference.period, 'reference out-and-back period, s', 1e-4, 1e3),
    Spec('transition', StrokeReference.transition, 'reference move duration (<= half a period), s',
                1e-5, 1e3),
    Spec('measured_frames', False, 'take the measured frames of each period in one message on /emla/frames '
                                          '(as `emla launch` runs it) instead of /emla/current and /emla/position'),
    Spec('adaptive', True, 'take the identifier estimates (true) or keep the initial model (false)'),
    Spec('adaptation_period', topics.ESTIMATE_PERIOD,
                "take an estimate at multiples of this (a multiple of the identifier's publish_period), s",
                1e-6, 1e6),
    Spec('min_samples', law.DEFAULT_MIN_SAMPLES, 'reject estimates from fewer samples, samples',
                0, 2**31 - 1),
    Spec('max_jump', law.DEFAULT_MAX_JUMP, 'reject estimates moving R, L, Km or m by more than this factor, 1',
                1.001, 1e3),
    *actuator_specs('initial model'),
    Spec('coulomb_force', 0.0, "the model's Coulomb friction, compensated by the law (0 = none), N", 0.0, 1e4),
    Spec('spring_stiffness', 0.0, "the model's spring k (x - x0), either sign (0 = none), N/m", -1e7, 1e7),
    Spec('spring_center', 0.0, "the model's spring rest position x0, m", -1.0, 1.0),
    Spec('adapt_effects', False, 'adaptive: also take the Coulomb friction and spring stiffness the '
                'identifier estimates online (/emla/effects; its load force is then the total at x = 0)'),
]


def warm_up(controller):
    """Run the compiled law once on a copy of `controller` (compiling it takes about 0.5 s the first time after an
    install), before the node subscribes: the plant starts only then, and a first command that late would
    stall the loop."""
    trial = copy.deepcopy(controller)
    trial.start_ahead(0.0, 0.0, (0.0,) * 4)
    trial.step_ahead(0.0, 0.0, (0.0,) * 4)


class SolenoidLaw:
    """A solenoid's law (emla_control.solenoid) behind the interface of the moving coil's that the node drives;
    adaptive, it takes R from the effect estimates (the coil's resistance the identifier follows)."""

    def __init__(self, controller, adaptive, min_samples):
        self.law, self.adapt_effects, self.min_samples = controller, adaptive, min_samples

    def midpoint_times(self, t):
        return self.law.midpoint_times(t)

    def reset(self, position):
        self.law.reset(position)

    def start_ahead(self, current, position, reference):
        """The voltage of the period that starts at the first state (no delay: nothing was commanded before)."""
        self.law.reset(position)
        return self.law.step(current, position, reference)

    def step_ahead(self, current, position, reference):
        return self.law.step_ahead(current, position, reference)

    def update_parameters(self, values, samples):
        if samples >= self.min_samples and 'resistance' in values:
            self.law.update_resistance(values['resistance'])


def solenoid_controller(p):
    """The SolenoidLaw of a solenoid's controller node (InputError for what only a moving coil's takes)."""
    if p.coulomb_force or p.spring_stiffness or p.adapt_effects:
        raise InputError('actuator solenoid: its spring and friction are in its model file (no coulomb_force, '
                         'spring_stiffness or adapt_effects)')
    return SolenoidLaw(solenoid_law.SolenoidController(
        solenoid_from(p.model_file), control_period=p.control_period, bandwidth=p.bandwidth, damping=p.damping_ratio,
        flux_time=p.flux_time, observer_bandwidth=p.observer_bandwidth), p.adaptive, p.min_samples)


def moving_coil_controller(p):
    """The InverseSystemController of a moving coil's controller node."""
    if p.model_file:
        raise InputError('model_file is for actuator solenoid (a moving coil\'s law takes its parameters)')
    model = ActuatorParameters(**{name: getattr(p, name) for name in ACTUATOR_FIELDS})
    return law.InverseSystemController(
        model, bandwidth=p.bandwidth, damping=p.damping_ratio, control_period=p.control_period,
        supply_voltage=model.supply_voltage, observer_bandwidth=p.observer_bandwidth,
        min_samples=p.min_samples, max_jump=p.max_jump,
        effects={name: getattr(p, name) for name in law.EFFECTS}, adapt_effects=p.adaptive and p.adapt_effects)


class ControllerNode(EmlaNode):
    NAME = 'controller'

    def __init__(self):
        super().__init__()
        p = declare(self, SPECS)
        self.samples_per_period = period_samples(p.sample_period, p.control_period)
        self.sample_period = p.sample_period
        self.step_ns = topics.to_ns(p.sample_period)
        solenoid = family(p.actuator) == 'solenoid'
        self.controller = solenoid_controller(p) if solenoid else moving_coil_controller(p)
        warm_up(self.controller)
        self.reference = StrokeReference(p.stroke, p.reference_period, p.transition, p.reference_offset)
        self.period_ns = self.samples_per_period * self.step_ns
        self.block = (None, None, None)  # (first period, references at the midpoints, reference samples)
        self.adaptation_ns = topics.to_ns(p.adaptation_period) if p.adaptive else None
        # (t_ns, current, position) of the measured samples not acted on yet (NaN: none), in time order: the plant
        # runs a period ahead, so a second may come while the first waits for its estimate
        self.samples = collections.deque()
        self.voltage = 0.0  # the latest command
        self.estimates = None if solenoid else {}  # stamp -> ParameterEstimate
        self.effect_estimates = {} if self.controller.adapt_effects else None  # stamp -> EffectEstimate
        self.started = False  # the law has had a usable sample
        self.commanded = False
        self.command = frame_publishers(self, {'voltage': topics.COMMAND_TOPIC, 'reference': topics.REFERENCE_TOPIC},
                                        p.control_period)
        self.states = FrameSets(
            self, {name: f'{topics.MEASURED_FRAMES_TOPIC} {name}' if p.measured_frames else topics.MEASURED_TOPICS[name]
                   for name in ('current', 'position')},
            self.on_states, Faults(self), p.sample_period, subscribe=not p.measured_frames)
        if p.measured_frames:
            subscribe_signal_frames(self, topics.MEASURED_FRAMES_TOPIC, self.states)
        if p.adaptive and not solenoid:
            self.create_subscription(ParameterEstimate, topics.PARAMETERS_TOPIC, self.on_estimate, ESTIMATE_QOS)
        if self.effect_estimates is not None:
            self.create_subscription(EffectEstimate, topics.EFFECTS_TOPIC, self.on_effects, ESTIMATE_QOS)

    def on_states(self, stamp, sample_period, frames):
        if frames is None:  # unusable: the state frame of a period ends on the first period start from its stamp
            self.samples.append((-(-stamp // self.period_ns) * self.period_ns, math.nan, math.nan))
        else:
            t = stamp + (len(frames['position']) - 1) * self.step_ns
            self.samples.append((t, frames['current'][-1], frames['position'][-1]))
        self.act()

    def on_estimate(self, msg):
        self.estimates[topics.stamp_to_ns(msg.header.stamp)] = msg
        self.act()

    def on_effects(self, msg):
        self.effect_estimates[topics.stamp_to_ns(msg.header.stamp)] = msg
        self.act()

    def act(self):
        while self.samples:
            t, current, position = self.samples[0]
            measured = math.isfinite(current) and math.isfinite(position)
            due = t - self.adaptation_ns if self.adaptation_ns else 0  # the stamp of the estimate taken at t, if any
            if measured and due > 0 and due % self.adaptation_ns == 0:
                if any(estimates is not None and due not in estimates
                       for estimates in (self.estimates, self.effect_estimates)):
                    return  # wait for it
                values, samples = {}, due // self.step_ns  # (the samples of a solenoid's R: all up to its stamp)
                if self.estimates is not None:
                    values, samples = messages.estimate_values(self.estimates[due]), self.estimates[due].samples_used
                if self.effect_estimates is not None:
                    values.update(messages.effect_values(self.effect_estimates[due]))
                self.controller.update_parameters({k: v for k, v in values.items() if math.isfinite(v)}, samples)
            if self.estimates:
                self.estimates = {stamp: msg for stamp, msg in self.estimates.items() if stamp > due}
            if self.effect_estimates:
                self.effect_estimates = {stamp: msg for stamp, msg in self.effect_estimates.items() if stamp > due}
            self.samples.popleft()
            self.control(t // self.period_ns, current, position, measured)

    def control(self, period, current, position, measured):
        """Command the period after `period` from the sample at its start (and `period` itself at the first)."""
        if not self.commanded:  # the first state: the period it starts needs a command too (0 V if unusable)
            if measured:
                self.voltage = self.controller.start_ahead(current, position, self.references(period)[0])
                self.started = True
            self.publish(period)
        if measured:  # else the last voltage is held
            if not self.started:
                self.controller.reset(position)  # step_ahead from 0 V, all that was commanded before
                self.started = True
            self.voltage = self.controller.step_ahead(current, position, self.references(period + 1)[0])
        self.publish(period + 1)

    def publish(self, period):
        """The command (the latest voltage) for control period `period`; at the first and at multiples of
        REFERENCE_FRAME, the reference it tracks up to the next multiple."""
        t = period * self.period_ns
        self.command['voltage'].publish(messages.frame_cdr(t, self.sample_period,
                                                           np.full(self.samples_per_period, self.voltage)))
        if not self.commanded or period % REFERENCE_FRAME == 0:
            end = (period // REFERENCE_FRAME + 1) * REFERENCE_FRAME
            samples = np.concatenate([self.references(k)[1] for k in range(period, end)])
            self.command['reference'].publish(messages.frame_cdr(t, self.sample_period, samples))
        self.commanded = True

    def references(self, period):
        """The reference (s, s', s'', s''') at the period's midpoint and its samples over the period.

        Evaluated for BLOCK periods at a time: one evaluation costs some 30 us, mostly numpy call overhead."""
        first, midpoints, samples = self.block
        if first is None or not first <= period < first + BLOCK:
            first = period
            starts = (first + np.arange(BLOCK)) * self.period_ns * 1e-9
            midpoints = np.column_stack(self.reference(self.controller.midpoint_times(starts))).tolist()
            samples = self.reference(starts[:, None] + self.sample_period * np.arange(self.samples_per_period))[0]
            self.block = (first, midpoints, samples)
        return midpoints[period - first], samples[period - first]


def main(args=None):
    return run(ControllerNode, args)


if __name__ == '__main__':
    sys.exit(main())
