"""The sensor node: the DSP's view of the plant (emla_sim.sensor), frame by frame (see emla_core.nodes).

The plant's true frames of each period come in one message (/emla/plant/frames): the current and position
frames are measured (delay, noise, quantisation) onto /emla/current and /emla/position, the voltage frame
passes unchanged onto /emla/voltage (the DSP knows what it applied); the three go together on /emla/frames
too (a SignalFrames: one delivery per period for the controller and identifier of a launch). State frames it
cannot use (see emla_core.nodes) give empty measured frames with their stamp: the period goes unmeasured, the
lockstep goes on.
"""
import sys

import numpy as np

from emla_core import messages, topics
from emla_core.nodes.faults import Faults
from emla_core.nodes.frames import FrameSets, frame_publishers
from emla_core.nodes.node import EmlaNode
from emla_core.nodes.param_specs import Spec, declare
from emla_core.nodes.qos import FRAME_QOS, frame_qos
from emla_core.nodes.run import run
from emla_msgs.msg import SignalFrames
from emla_sim.sensor import Sensor, SensorConfig

STATES = ('current', 'position')

SPECS = [
    Spec('current_noise_std', SensorConfig.current_noise_std, 'current noise (Gaussian), std, A', 0.0, 100.0),
    Spec('position_noise_std', SensorConfig.position_noise_std,
                'position noise (Gaussian, before quantisation), std, m', 0.0, 1.0),
    Spec('position_resolution', SensorConfig.position_resolution, 'position LSB; 0 = not quantised, m',
                0.0, 1.0),
    Spec('delay_samples', SensorConfig.delay_samples, 'measurement delay, samples', 0, 1_000_000),
    Spec('seed', SensorConfig.seed, 'seed of the noise generator', 0, 2**31 - 1),
    Spec('control_period', topics.CONTROL_PERIOD, 'the plant\'s control period, the length of the frames it measures: '
                                                  'its publishers keep a second of them for a reader that lags, s',
         1e-6, 1.0),
]


class SensorNode(EmlaNode):
    NAME = 'sensor'

    def __init__(self):
        super().__init__()
        p = declare(self, SPECS)
        self.sensor = Sensor(SensorConfig(**{spec.name: getattr(p, spec.name) for spec in SPECS
                                            if spec.name != 'control_period'}))
        self.outputs = frame_publishers(self, topics.MEASURED_TOPICS, p.control_period)
        self.together = self.create_publisher(SignalFrames, topics.MEASURED_FRAMES_TOPIC, frame_qos(p.control_period))
        self.states = FrameSets(self, {name: f'{topics.PLANT_FRAMES_TOPIC} {name}' for name in STATES},
                                       self.measure, Faults(self), subscribe=False)
        self.voltage = None  # (stamp, samples) of the period being measured
        self.create_subscription(SignalFrames, topics.PLANT_FRAMES_TOPIC, self.on_frames, FRAME_QOS, raw=True)

    def on_frames(self, cdr):
        frames = messages.read_signal_frames_cdr(cdr)
        stamp, sample_period, voltages = frames['voltage']
        self.voltage = stamp, voltages
        if len(voltages):  # (none beside the state at t = 0)
            self.outputs['voltage'].publish(messages.frame_cdr(stamp, sample_period, voltages))
        for name in STATES:
            stamp, sample_period, samples = frames[name]
            self.states.receive(name, stamp, samples, sample_period)

    def measure(self, stamp, sample_period, frames):
        measured = (np.empty(0),) * 2 if frames is None else self.sensor.measure(frames['current'], frames['position'])
        for name, samples in zip(STATES, measured):
            self.outputs[name].publish(messages.frame_cdr(stamp, sample_period, samples))
        self.together.publish(messages.signal_frames_cdr(sample_period, {
            'voltage': self.voltage, **{name: (stamp, samples) for name, samples in zip(STATES, measured)}}))


def main(args=None):
    return run(SensorNode, args)


if __name__ == '__main__':
    sys.exit(main())
