"""The plant node: the simulated actuator, one control period per voltage command (lockstep, see emla_core.nodes).

Each period's true frames go to the sensor in one SignalFrames message (/emla/plant/frames); on
/emla/plant/{voltage,current,position}, which only a recorder reads, they go with the true parameters, in
frames of `parameters_period`.

Effects by name (`effects`), tuned by `effect_parameters` entries 'effect.field=value'; timed parameter
changes from the equally long arrays change_times / change_parameters / change_factors.

With `actuator: solenoid` the plant is a solenoid (emla_sim.solenoid; docs/physics.md §9) of `model_file` (a
solenoid's model file; empty: SolenoidParameters(), the valve of issue 24), which takes no effects; its changes
(of SolenoidParameters fields) take effect at the first sample instant at or after their time, and its true
parameters go out as R, m and B (the ParameterEstimate's other fields are the moving coil's: NaN).
"""
import math
import sys
import time

import numpy as np
from builtin_interfaces.msg import Time
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from emla_core import messages, topics
from emla_core.errors import InputError
from emla_core.nodes.frames import frame_publishers
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
from emla_core.nodes.qos import CLOCK_QOS, FRAME_QOS, LATCHED_QOS
from emla_core.nodes.run import run
from emla_core.parameters import FAMILIES, PARAMETER_NAMES, ActuatorParameters
from emla_core.physics import EFFECTS, make_effect
from emla_msgs.msg import ParameterEstimate, SampleFrame, SignalFrames
from emla_sim.effects import ParameterChange
from emla_sim.plant import Plant

SPECS = [
    Spec('sample_period', 1e-4, 'sample period Ts, s', 1e-6, 1e-2),
    Spec('control_period', topics.CONTROL_PERIOD,
         'control period Tc (a whole multiple of Ts; samples per frame = Tc/Ts), s',
                1e-6, 1.0),
    Spec('duration', 1.0, 'simulated time to run, then publish done and exit; 0 = until stopped, s',
                0.0, 1e6),
    Spec('initial_position', 0.0, 'position at t = 0 (at rest, no current), m', -1.0, 1.0),
    Spec('actuator', 'moving_coil', f'the actuator family, of {list(FAMILIES)}'),
    Spec('model_file', '', 'actuator solenoid: its model file (emla identify --actuator solenoid --model-out); '
                           'empty: the valve of issue 24'),
    *actuator_specs('true'),
    Spec('effects', Parameter.Type.STRING_ARRAY,
         f'effects by name, of {sorted(n for n, e in EFFECTS.items() if not e.simulation_refusal)}'),
    Spec('effect_parameters', Parameter.Type.STRING_ARRAY,
                "settings of those effects, 'effect.field=value' (SI units, see docs/physics.md)"),
    Spec('change_times', Parameter.Type.DOUBLE_ARRAY, 'times of step parameter changes, s'),
    Spec('change_parameters', Parameter.Type.STRING_ARRAY,
                f'parameter each change scales, of {PARAMETER_NAMES} (a solenoid\'s: of SolenoidParameters)'),
    Spec('change_factors', Parameter.Type.DOUBLE_ARRAY, 'factor each change multiplies it by, 1'),
    Spec('parameters_period', topics.ESTIMATE_PERIOD,
                'publish the true parameters and frames at multiples of this (and after each change), s', 1e-6, 1e6),
    Spec('start_subscribers', 2, 'start once /emla/position has this many subscriptions (and, if > 0, the '
                'frames for the sensor and the commands are matched), 1', 0, 1000),
    Spec('frames_subscribers', 0, 'and /emla/frames (the measured frames in one message) this many, 1', 0, 1000),
    Spec('done_subscribers', 1, 'and /emla/plant/done this many (the plant leaves once they acknowledged '
                'it; a reader found later would never get it), 1', 0, 1000),
]


def effects_from(names, settings):
    fields = {name: {} for name in names}
    for setting in settings:
        key, _, value = setting.partition('=')
        effect, _, field = key.strip().partition('.')
        if effect not in fields or not field or not value:
            raise InputError(f"effect_parameters: {setting!r} is not 'effect.field=value' for an effect in {names}")
        try:
            fields[effect][field] = float(value)
        except ValueError:
            raise InputError(f'effect_parameters: {setting!r}: {value!r} is not a number') from None
    return [make_effect(name, **fields[name]) for name in names]


def check_lengths(times, parameters, factors):
    if not len(times) == len(parameters) == len(factors):
        raise InputError('change_times, change_parameters and change_factors must have the same length')


def changes_from(times, parameters, factors):
    check_lengths(times, parameters, factors)
    return [ParameterChange(t, name, factor) for t, name, factor in zip(times, parameters, factors)]


class SolenoidStepper:
    """A solenoid plant as the node steps it: (I, x, v) after each interval, its parameter changes (times,
    names, factors) applied at the first sample instant at or after their time, its true parameters."""

    def __init__(self, params, times, names, factors, initial_position):
        from emla_sim.solenoid import SolenoidPlant
        check_lengths(times, names, factors)
        fields = params.__dataclass_fields__
        for name, factor in zip(names, factors):
            if name not in fields:
                raise InputError(f'change_parameters: {name!r} is not a solenoid\'s parameter ({", ".join(fields)})')
            if not (math.isfinite(factor) and factor > 0):
                raise InputError(f'change_factors: {factor!r} is not a positive factor')
        self.changes = sorted(zip(times, names, factors))
        self.plant = SolenoidPlant(params, initial_state=(0.0, initial_position, 0.0))
        self._apply_due()

    current = property(lambda self: self.plant.current)
    position = property(lambda self: self.plant.position)

    def step(self, voltage, dt):
        self.plant.step(voltage, dt)
        self._apply_due()
        return self.plant.current, self.plant.position, self.plant.velocity

    def _apply_due(self):
        while self.changes and self.changes[0][0] <= self.plant.time + 1e-9:
            _, name, factor = self.changes.pop(0)
            try:
                self.plant.change(**{name: getattr(self.plant.params, name) * factor})
            except ValueError as exc:
                raise InputError(f'a change of {name} by {factor}: {exc}') from None

    def true_values(self):
        params = self.plant.params
        return {'resistance': params.resistance, 'mass': params.mass, 'damping': params.damping}


class PlantNode(EmlaNode):
    NAME = 'plant'

    def __init__(self):
        super().__init__()
        p = declare(self, SPECS)
        self.samples_per_period = period_samples(p.sample_period, p.control_period)
        self.step = topics.to_ns(p.sample_period)
        self.periods = round(p.duration / p.control_period) if p.duration else None
        if self.periods == 0:
            raise InputError(f'duration ({p.duration} s) is shorter than one control period')
        self.awaited_readers = {topics.START_TOPIC: p.start_subscribers,
                                topics.MEASURED_FRAMES_TOPIC: p.frames_subscribers,
                                topics.DONE_TOPIC: p.done_subscribers}
        if family(p.actuator) == 'solenoid':
            if p.effects:
                raise InputError('actuator solenoid takes no effects (the physics layer\'s are the moving coil\'s)')
            params = solenoid_from(p.model_file)
            self.change_times = list(p.change_times)
            self.plant = SolenoidStepper(params, p.change_times, p.change_parameters, p.change_factors,
                                         p.initial_position)
            self.true_values = self.plant.true_values
        else:
            if p.model_file:
                raise InputError('model_file is for actuator solenoid (a moving coil takes its parameters)')
            params = ActuatorParameters(**{name: getattr(p, name) for name in ACTUATOR_FIELDS})
            changes = changes_from(p.change_times, p.change_parameters, p.change_factors)
            self.change_times = [change.time for change in changes]
            self.plant = Plant(params, effects_from(p.effects, p.effect_parameters), changes,
                               initial_state=(0.0, p.initial_position, 0.0))
            self.true_values = lambda: self.plant.true_parameters().physical()
        self.supply = params.supply_voltage
        self.parameters_step = topics.to_ns(p.parameters_period)
        self.sample_period = p.sample_period
        self.period = 0
        self.wall_start = None  # wall clock at the first command (for the realtime factor)
        self.commands = {}  # stamp -> voltages
        self.frames = frame_publishers(self, topics.PLANT_TOPICS)
        self.true_frames = {name: [] for name in topics.SIGNALS}  # (stamp, samples) not yet on PLANT_TOPICS
        self.together = self.create_publisher(SignalFrames, topics.PLANT_FRAMES_TOPIC, FRAME_QOS)
        # The truth is part of the record: kept as frames are (FRAME_QOS), so a recorder starved of CPU lags
        # and loses none of a ramp's 1 ms steps (keep last 1 replaced unacknowledged ones)
        self.truth = self.create_publisher(ParameterEstimate, topics.TRUE_PARAMETERS_TOPIC, FRAME_QOS)
        self.done = self.create_publisher(Time, topics.DONE_TOPIC, LATCHED_QOS)
        self.clock = self.create_publisher(Clock, topics.CLOCK_TOPIC, CLOCK_QOS)
        self.commands_in = self.create_subscription(SampleFrame, topics.COMMAND_TOPIC, self.on_command,
                                                    FRAME_QOS, raw=True)
        self.barrier = self.create_timer(0.02, self.try_start)
        self.get_logger().info('waiting for ' + ' and '.join(f'{n} subscription(s) of {topic}'
                                                             for topic, n in self.awaited_readers.items()))

    @property
    def now(self):
        return self.period * self.samples_per_period * self.step

    def try_start(self):
        if any(self.count_subscribers(topic) < n for topic, n in self.awaited_readers.items()):
            return
        loop = self.awaited_readers[topics.START_TOPIC] + self.awaited_readers[topics.MEASURED_FRAMES_TOPIC]
        if loop and not (self.together.get_subscription_count() and self.commands_in.get_publisher_count()):
            return  # a loop to run: its first frames would wait for these to match (up to a discovery period)
        self.barrier.cancel()
        self.get_logger().info('started')
        self.publish_frames({'voltage': (0, []), 'current': (0, [self.plant.current]),
                             'position': (0, [self.plant.position])})
        self.publish_truth()
        self.clock.publish(Clock(clock=messages.time_msg(0)))
        self.advance()

    def on_command(self, cdr):
        stamp, _, voltages = messages.read_frame_cdr(cdr)
        if stamp < self.now or len(voltages) != self.samples_per_period:
            self.get_logger().error(f'ignored a voltage command stamped {stamp} ns with {len(voltages)} samples '
                                    f'(expected {self.samples_per_period} from {self.now} ns on)')
            return
        self.commands[stamp] = voltages
        if self.barrier.is_canceled():
            self.advance()

    def advance(self):
        while self.now in self.commands and not self.finished:
            start = self.now
            if self.period == 0:
                self.wall_start = time.monotonic()
            voltages = self.commands.pop(start).clip(-self.supply, self.supply)  # as the plant applies them
            states = [self.plant.step(u, self.sample_period) for u in voltages.tolist()]  # (I, x, v) at the ends
            self.publish_frames({'voltage': (start, voltages),
                                 'current': (start + self.step, [state[0] for state in states]),
                                 'position': (start + self.step, [state[1] for state in states])})
            self.period += 1
            self.clock.publish(Clock(clock=messages.time_msg(self.now)))
            changed = any(start * 1e-9 < t <= self.now * 1e-9 for t in self.change_times)
            if changed or self.now % self.parameters_step == 0 or self.period == self.periods:
                self.publish_truth()
            if self.period == self.periods:
                self.finish()

    def publish_frames(self, frames):
        """A period's true frames {signal: (stamp, samples)}: in one message to the sensor now, on PLANT_TOPICS
        with the next truth (only a recorder reads them: fewer, longer frames cost it less)."""
        self.together.publish(messages.signal_frames_cdr(self.sample_period, frames))
        for name, frame in frames.items():
            if len(frame[1]):
                self.true_frames[name].append(frame)

    def publish_truth(self):
        """The true frames held (one per signal) and the true parameters."""
        for name, frames in self.true_frames.items():
            if frames:
                samples = np.concatenate([samples for _, samples in frames])
                self.frames[name].publish(messages.frame_cdr(frames[0][0], self.sample_period, samples))
                frames.clear()
        values = self.true_values()
        self.truth.publish(messages.estimate_message(self.now, values, std=dict.fromkeys(values, 0.0)))

    def stop(self, executor):
        if not self.finished and self.barrier.is_canceled():
            self.publish_truth()  # stopped early: the true frames held
        super().stop(executor)

    def finish(self):
        wall = time.monotonic() - self.wall_start
        self.done.publish(messages.time_msg(self.now))
        self.get_logger().info(f'done at t = {self.now * 1e-9:g} s; from the first command to the last frame: '
                               f'wall time {wall:.3f} s, realtime factor {self.now * 1e-9 / wall:.3f}')
        self.finished = True  # run exits once the readers acknowledged


def main(args=None):
    return run(PlantNode, args)


if __name__ == '__main__':
    sys.exit(main())
