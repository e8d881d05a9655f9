"""The sensor node: the DSP's view of the plant (emla_sim.sensor), frame by frame (see common).

State frames /emla/plant/{current,position} are measured (delay, noise, quantisation) onto /emla/*; the
voltage frames pass unchanged (the DSP knows what it applied). Plant frames it cannot use (see common) give
empty measured frames with their stamp: the period goes unmeasured, the lockstep goes on.
"""
import sys

import numpy as np

from emla_core import messages, topics
from emla_core.nodes import common
from emla_msgs.msg import SampleFrame
from emla_sim.sensor import Sensor, SensorConfig

SPECS = [
    common.Spec('current_noise_std', SensorConfig.current_noise_std, 'current noise (Gaussian), std, A', 0.0, 100.0),
    common.Spec('position_noise_std', SensorConfig.position_noise_std,
                'position noise (Gaussian, before quantisation), std, m', 0.0, 1.0),
    common.Spec('position_resolution', SensorConfig.position_resolution, 'position LSB; 0 = not quantised, m',
                0.0, 1.0),
    common.Spec('delay_samples', SensorConfig.delay_samples, 'measurement delay, samples', 0, 1_000_000),
    common.Spec('seed', SensorConfig.seed, 'seed of the noise generator', 0, 2**31 - 1),
]


class SensorNode(common.EmlaNode):
    NAME = 'sensor'

    def __init__(self):
        super().__init__()
        p = common.declare(self, SPECS)
        self.sensor = Sensor(SensorConfig(**{spec.name: getattr(p, spec.name) for spec in SPECS}))
        self.outputs = common.frame_publishers(self, topics.MEASURED_TOPICS)
        self.create_subscription(SampleFrame, topics.PLANT_TOPICS['voltage'], self.outputs['voltage'].publish,
                                 common.FRAME_QOS, raw=True)  # passed on serialised
        self.states = common.FrameSets(self, {name: topics.PLANT_TOPICS[name] for name in ('current', 'position')},
                                       self.measure, common.Faults(self))

    def measure(self, stamp, sample_period, frames):
        measured = (np.empty(0),) * 2 if frames is None else self.sensor.measure(frames['current'], frames['position'])
        for name, samples in zip(('current', 'position'), measured):
            self.outputs[name].publish(messages.frame_message(stamp, sample_period, samples))


def main(args=None):
    return common.run(SensorNode, args)


if __name__ == '__main__':
    sys.exit(main())
