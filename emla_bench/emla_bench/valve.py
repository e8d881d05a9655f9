"""A proportional valve (a solenoid, issue 24) tracking a position profile while its coil warms: the solenoid's
inverse-model controller (emla_control.solenoid) fixed, or adapted from the online resistance estimate
(emla_identification.solenoid_online), in the lockstep loop of loop.py.

The cases are those of the moving coil's scenarios (scenarios.CASES): the plant unchanged, the plant changed with
the controller fixed, and changed with the controller adapting; they share the sensor noise. The change: R
rises linearly by `rise` between the times `warming` (a coil's temperature rise, sped up), applied at each frame.
"""
import dataclasses
from typing import Self

import numpy as np

from emla_control.reference import StrokeReference
from emla_control.solenoid import SolenoidController
from emla_core.model_file import Model
from emla_core.physics.solenoid import SolenoidParameters
from emla_core.recording import Recording
from emla_identification.solenoid_online import ResistanceTracker
from emla_sim.sensor import Sensor, SensorConfig
from emla_sim.solenoid import SolenoidPlant

from .loop import LoopResult, run_frame

# The valve of issue 24 (SolenoidParameters()) between 0.3 and 0.9 mm of its 1.2 mm stroke: 1.1-1.4 A held.
VALVE_REFERENCE = StrokeReference(stroke=0.6e-3, period=0.04, transition=8e-3, offset=0.3e-3)


@dataclasses.dataclass(frozen=True)
class ValveScenario:
    """A solenoid valve's closed-loop comparison: what scenarios.run_scenario runs and `emla scenario` reports."""

    name: str
    description: str
    duration: float            # s
    evaluate_from: float       # s; metrics over whole cycles from here
    rise: float = 0.3          # R's relative rise in the changed plant
    warming: tuple = (0.2, 0.5)  # s: R rises linearly over this span
    params: SolenoidParameters = SolenoidParameters()
    reference: StrokeReference = VALVE_REFERENCE
    sample_period: float = 1e-4  # s, also the control period
    memory_time: float = 0.03    # s, of the resistance estimate
    frame_samples: int = 50      # samples between the estimate's (and the controller's) updates
    seed: int = 0
    cases: dict = dataclasses.field(default_factory=lambda: {
        'nominal': (False, False), 'changed_fixed': (True, False), 'changed_adaptive': (True, True)})
    compensated: tuple = ()
    actuator: str = 'solenoid'
    graph_case: str = 'changed_adaptive'   # what `emla launch` runs (emla_bench.node_parameters)

    def with_model(self, model: Model, source: str = 'model file') -> Self:
        """This scenario on the solenoid of a model file (emla_core.model_file), the controller's model too."""
        return dataclasses.replace(self, params=model.require('solenoid', source).solenoid())

    def resistance(self, t: float, changed: bool) -> float:
        """The plant's R at time t (s)."""
        if not changed:
            return self.params.resistance
        start, end = self.warming
        return self.params.resistance * (1.0 + self.rise * min(max((t - start) / (end - start), 0.0), 1.0))

    def run_case(self, case: str) -> LoopResult:
        """The LoopResult of one case: the recording (voltage, current, position measured; reference), the true
        current, position and velocity, and per frame the estimate of R, its sigma, the controller's R and the
        plant's."""
        changed, adapt = self.cases[case]
        ts, every = self.sample_period, self.frame_samples
        start = float(np.mean(self.reference(0.0)[0]))
        plant = SolenoidPlant(self.params, initial_state=(0.0, start, 0.0))
        sensor = Sensor(SensorConfig(sample_period=ts, seed=self.seed))
        controller = SolenoidController(self.params, control_period=ts)
        controller.reset(start)
        tracker = ResistanceTracker(self.params, ts, memory_time=self.memory_time)
        n = int(round(self.duration / ts))
        references = np.column_stack(self.reference(controller.midpoint_times(ts * np.arange(n))))
        columns = [np.empty(n) for _ in range(6)]   # true I, x, v; measured I, x; voltage (run_frame's order)
        frames = range(0, n, every)
        log = {key: np.empty(len(frames)) for key in ('estimate', 'std', 'model', 'true')}
        for f, first in enumerate(frames):
            stop = min(first + every, n)
            plant.change(resistance=self.resistance(first * ts, changed))
            frame = run_frame(plant, sensor.measure, controller.step, 1, ts, stop - first,
                              iter(references[first:stop].tolist()))
            for column, values in zip(columns, frame):
                column[first:stop] = values
            tracker.update(columns[5][first:stop], columns[3][first:stop], columns[4][first:stop])
            if adapt and tracker.samples > self.memory_time / ts:
                controller.update_resistance(tracker.resistance)
            log['estimate'][f], log['std'][f] = tracker.resistance, tracker.std
            log['model'][f], log['true'][f] = controller.resistance, plant.params.resistance
        true_i, true_x, true_v, current, position, voltage = columns
        recording = Recording(ts, {'voltage': voltage, 'current': current, 'position': position,
                                   'reference': self.reference(ts * np.arange(n))[0]}, source='valve closed loop')
        return LoopResult(recording=recording, truth={'current': true_i, 'position': true_x, 'velocity': true_v},
                          frame_times=ts * np.minimum(np.array(frames) + every, n),
                          estimates={'resistance': log['estimate']}, std={'resistance': log['std']},
                          covariance=[], model={'resistance': log['model']},
                          true_parameters={'resistance': log['true']}, accepted=controller.accepted,
                          rejected=controller.rejected)
