"""The closed loop in-process, in deterministic lockstep: plant + sensor + identifier + controller.

Per sample k (period Ts): the sensor measures the plant at t_k, the controller (every `decimation`
samples) turns the measurement into a voltage, and the plant holds that voltage over [t_k, t_k + Ts).
Per frame of `frame_samples` samples: the identifier takes the frame's voltages and measurements, and the
controller is offered the new estimate (if adapting). Everything is seeded, so a run repeats exactly.

The per-sample work uses the plant's and sensor's public per-step APIs around the compiled control law:
about 3 us a sample of CPU (30 times faster than real time at 10 kHz). The identifier's cost is mostly its
estimate(), taken once a frame (about 2 ms now), hence frames of 50 ms: 16 times real time in all.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from emla_core.parameters import PARAMETER_NAMES
from emla_core.recording import Recording
from emla_sim.sensor import Sensor

if TYPE_CHECKING:
    from emla_control.controller import InverseSystemController
    from emla_identification.online import OnlineIdentifier
    from emla_sim.plant import Plant

FRAME_SAMPLES = 500  # 50 ms at 10 kHz: the identifier's and the parameter updates' rhythm


@dataclasses.dataclass
class LoopResult:
    """What a closed-loop run produced.

    recording: voltage (as commanded), current and position (as measured), reference, at the sample times.
    truth: the plant's true current, position and velocity at the same times (for evaluation).
    frame_times: end time of each frame; estimates / std: the identifier's (NaN without one; with the parameters
    of the effects it estimates online, if any), covariance: its
    (names, matrix) per frame (empty without one);
    model: the parameters the controller used in each frame; true_parameters: the plant's at each frame end.
    """
    recording: Recording
    truth: dict
    frame_times: np.ndarray
    estimates: dict
    std: dict
    covariance: list
    model: dict
    true_parameters: dict
    accepted: int
    rejected: int


def run_closed_loop(plant: Plant, controller: InverseSystemController,
                    reference: Callable[[np.ndarray], Sequence[np.ndarray]], duration: float, *,
                    sensor: Sensor | None = None, identifier: OnlineIdentifier | None = None, adapt: bool = True,
                    frame_samples: int = FRAME_SAMPLES) -> LoopResult:
    """Run the loop from the plant's present state for `duration` s; returns a LoopResult.

    sensor: emla_sim Sensor (default: 10 kHz, 5 mA, 1 um, seed 0); its sample period is the loop's.
    identifier: e.g. OnlineIdentifier with update(voltage, current, position), full_estimate() -> (params, std,
    (names, covariance)) and samples; with adapt=False it still runs, but the controller keeps its parameters.
    """
    sensor = sensor or Sensor()
    ts = sensor.config.sample_period
    decimation = int(round(controller.control_period / ts))
    if decimation < 1 or abs(decimation * ts - controller.control_period) > 1e-9 * ts:
        raise ValueError(f'the control period {controller.control_period} s must be a multiple of the sample '
                         f'period {ts} s')
    if frame_samples % decimation:
        raise ValueError(f'frame_samples ({frame_samples}) must be a multiple of the decimation ({decimation})')
    n = int(round(duration / ts))
    t0 = plant.time
    signals = {name: np.empty(n) for name in ('voltage', 'current', 'position')}
    truth = {name: np.empty(n) for name in ('current', 'position', 'velocity')}
    frames = range(0, n, frame_samples)
    estimated = PARAMETER_NAMES + tuple(getattr(identifier, 'effects', ()))  # with the effects estimated online
    log = {key: {name: np.full(len(frames), np.nan) for name in (estimated if key in ('estimates', 'std')
                                                                 else PARAMETER_NAMES)}
           for key in ('estimates', 'std', 'model', 'true_parameters')}
    covariance = []
    controller.reset(plant.position)
    # the reference for every control interval at once (vectorised); row j = (s, s', s'', s''')
    references = np.column_stack(reference(controller.midpoint_times(t0 + ts * np.arange(0, n, decimation))))
    for f, start in enumerate(frames):
        stop = min(start + frame_samples, n)
        frame = run_frame(plant, sensor.measure, controller.step, decimation, ts, stop - start,
                           iter(references[start // decimation:(stop + decimation - 1) // decimation].tolist()))
        for (store, name), values in zip(_FRAME_COLUMNS, frame):
            (signals if store == 'signals' else truth)[name][start:stop] = values
        if identifier is not None:
            identifier.update(*(signals[name][start:stop] for name in ('voltage', 'current', 'position')))
            estimate, std, named_covariance = identifier.full_estimate()
            covariance.append(named_covariance)
            _log_values(log['estimates'], f, estimate)
            _log_values(log['std'], f, std)
            if adapt:
                controller.update_parameters(estimate, identifier.samples)
        _log_values(log['model'], f, controller.parameters.physical())
        _log_values(log['true_parameters'], f, plant.true_parameters().physical())
    signals['reference'] = reference(t0 + ts * np.arange(n))[0]
    return LoopResult(recording=Recording(sample_period=ts, signals=signals, start_time=t0, source='closed loop'),
                      truth=truth, frame_times=t0 + ts * np.minimum(np.array(frames) + frame_samples, n),
                      covariance=covariance, accepted=controller.accepted, rejected=controller.rejected, **log)


_FRAME_COLUMNS = (('truth', 'current'), ('truth', 'position'), ('truth', 'velocity'),
                  ('signals', 'current'), ('signals', 'position'), ('signals', 'voltage'))


def run_frame(plant, measure, control, decimation, ts, n, references):
    """n samples of the lockstep with the controller's parameters fixed; lists in _FRAME_COLUMNS order.

    Plain lists and locals: this is the per-sample hot path (the law itself is compiled)."""
    true_i, true_x, true_v, meas_i, meas_x, volts = ([0.0] * n for _ in range(6))
    voltage = 0.0
    for k in range(n):
        i, x = plant.current, plant.position
        true_i[k], true_x[k], true_v[k] = i, x, plant.velocity
        i, x = measure(i, x)
        meas_i[k], meas_x[k] = i, x
        if k % decimation == 0:
            voltage = control(i, x, next(references))
        volts[k] = voltage
        plant.step(voltage, ts)
    return true_i, true_x, true_v, meas_i, meas_x, volts


def _log_values(log, frame, values):
    for name, value in values.items():
        if name in log:
            log[name][frame] = value
