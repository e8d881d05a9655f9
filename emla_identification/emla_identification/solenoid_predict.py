"""A solenoid model's prediction of a record (`emla compare` with a solenoid's model file): the solenoid driven by
the record's measured voltage from its first measured current and position, at rest, a free run over the whole
record (docs/physics.md §9.4).

A solenoid under open-loop voltage is stable (its spring returns the armature, its end stops hold it), so unlike a
moving coil in a closed loop (discrepancy/predict.py: k-step-ahead subsystems) the free run does not drift away
for reasons that have nothing to do with the model: the current and position it predicts are the model's whole
answer to the voltage. Not so for a proportional solenoid held between its stops by a position loop: there the
force's stiffness at constant flux linkage can exceed the spring's, and the free run of such a record's voltage
drifts off to a stop, so its position's gap measures that drift, not the model's error. The plant step is the
physics layer's (emla_core.physics.solenoid.solenoid_sequence: RK4 sub-steps of at most SUBSTEP with inelastic
stops).
"""
import math

import numpy as np

from emla_core.physics.solenoid import SolenoidParameters, solenoid_sequence

from .discrepancy.predict import Prediction
from .solenoid import SUBSTEP


def predict_solenoid(params: SolenoidParameters, recording) -> dict:
    """{'current': Prediction, 'position': Prediction} of the solenoid `params` on `recording` (voltage, current,
    position; the voltage held over each interval): each sample from 1 on predicted by the free run, the horizon
    the whole record."""
    recording.require('voltage', 'current', 'position')
    u, i, x = (np.asarray(recording.signals[name], dtype=float) for name in ('voltage', 'current', 'position'))
    ts = recording.sample_period
    position = min(max(float(x[0]), params.stroke_min), params.stroke_max)
    state = np.array([float(i[0]), position, 0.0])
    rows = solenoid_sequence(state, u[:-1], ts, max(1, math.ceil(ts / SUBSTEP - 1e-9)), params.kernel_vector())
    index = np.arange(1, len(u))
    return {name: Prediction(name, index, measured[1:], rows[:, column], len(u) - 1)
            for name, measured, column in (('current', i, 0), ('position', x, 1))}
