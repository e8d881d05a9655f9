"""Subsystem simulation by k-step-ahead prediction, vectorised over start samples.

A closed loop has an integrator in it, so a free-run simulation of the whole actuator drifts away from
the data for reasons that have nothing to do with the model. Each subsystem is therefore run from its own
measured inputs, and every sample is predicted from the measured state `horizon` samples before it
(MATLAB's compare(data, model, k)):

    electrical: current from the measured voltage and the back-EMF velocity of the measured position,
                iterating the fitted regression (candidate terms evaluated on the predicted current);
                horizon 5 L/R, by which the initial current is forgotten (a free run in effect).
    mechanical: position from the measured current (force Km I) or force, integrating m dv/dt =
                F - B v - Fl - candidate forces exactly over each interval (force held at its interval
                mean); starts from the measured position and a model-based local velocity estimate;
                horizon MECHANICAL_TIME.
"""
from dataclasses import dataclass

import numpy as np

from .data import State
from .fit import held_samples
from .rows import rows_of

MECHANICAL_TIME = 0.01   # s: about half the mechanical time constant m/B of Table 1 (18 ms)
VELOCITY_SPAN = 5        # samples each side of a start used to estimate its velocity


@dataclass
class Prediction:
    signal: str
    index: np.ndarray       # samples predicted
    measured: np.ndarray
    predicted: np.ndarray
    horizon: int            # samples ahead

    @property
    def nrmse(self):
        """||y - yhat|| / ||y - mean(y)||; NaN when y is empty (a horizon longer than the record) or constant."""
        spread = np.linalg.norm(self.measured - self.measured.mean()) if self.measured.size else 0.0
        return float(np.linalg.norm(self.measured - self.predicted) / spread) if spread else float('nan')


def predict(fit):
    """{signal: Prediction} of the subsystems in the fit's data."""
    out = {}
    if fit.data.electrical:
        out['current'] = predict_current(fit)
    out['position'] = predict_position(fit)
    return out


def predict_current(fit):
    data, p = fit.data, fit.parameters
    rows = rows_of(data, 'electrical', fit.linearised_about)
    horizon = max(1, int(np.ceil(5.0 * p['inductance'] / (p['resistance'] * data.sample_period))))
    coefficients = rows.coefficients + rows.jacobian @ fit.shift
    starts = np.arange(max(len(rows.y) - horizon + 1, 0))
    current = rows.phi[starts, 0]
    for j in range(horizon if len(starts) else 0):   # a horizon beyond the record: nothing to predict
        r = starts + j
        step = coefficients[0] * current + rows.phi[r, 1:] @ coefficients[1:]
        if fit.candidates:
            step += rows.columns(fit.candidates, r, current) @ fit.added
        current = step
    index = rows.index[starts + horizon - 1]
    return Prediction('current', index, data.signals['current'][index], current, horizon)


def predict_position(fit):
    data, p = fit.data, fit.parameters
    ts = data.sample_period
    horizon = max(2, int(round(MECHANICAL_TIME / ts)))
    drive = data.signals[data.drive]
    mean_drive = 0.5 * (drive[:-1] + drive[1:])
    force = mean_drive * (p['emf_constant'] if data.drive == 'current' else 1.0)
    a, to_x, force_to_v, force_to_x = _interval(p['mass'], p['damping'], ts)
    starts = np.arange(VELOCITY_SPAN, len(data) - horizon)
    x = data.signals['position'][starts]
    v = _start_velocity(data, force, p)[starts]
    held = held_samples(data, fit.candidates)
    for j in range(horizon if len(starts) else 0):   # a horizon beyond the record: nothing to predict
        k = starts + j
        net = force[k] - p['load_force']
        if fit.candidates:
            state = State(data, k, position=x, velocity=v, **{data.drive: mean_drive[k]})
            for c, part in fit.added_slices():
                f = c.force(state)
                if f is not None:
                    net = net - fit.added[part] @ f
        moved, v = x + to_x * v + force_to_x * net, a * v + force_to_v * net
        if held is not None:   # stuck over the interval: the part stays where it is
            stuck = held[k] & held[k + 1]
            moved, v = np.where(stuck, x, moved), np.where(stuck, 0.0, v)
        x = moved
    index = starts + horizon
    return Prediction('position', index, data.signals['position'][index], x, horizon)


def _start_velocity(data, force, p):
    """Velocity at each sample from a least-squares line through the positions of the surrounding
    +-VELOCITY_SPAN samples after the model's double integral of F/m is taken out of them.

    A plain local fit is biased by the fast strokes' jerk; with the known force taken out, what is left
    is a line plus noise, and an acceleration the model misses cancels on the symmetric window."""
    ts = data.sample_period
    velocity = data.velocity()
    acceleration = (np.append(force, force[-1]) - p['damping'] * velocity - p['load_force']) / p['mass']
    speed = np.concatenate(([0.0], np.cumsum(acceleration[:-1]) * ts))    # integral of a from the start
    travel = np.concatenate(([0.0], np.cumsum(speed[:-1] * ts + 0.5 * acceleration[:-1] * ts * ts)))
    j = np.arange(-VELOCITY_SPAN, VELOCITY_SPAN + 1)
    slope = np.convolve(data.signals['position'] - travel, j[::-1] / (ts * np.sum(j * j)), mode='same')
    return slope + speed   # valid where the window is complete: VELOCITY_SPAN <= k < n - VELOCITY_SPAN


def _interval(mass, damping, ts):
    """Exact ZOH of m dv/dt = F - B v over ts: v' = a v + bv F, x' = x + cx v + bx F."""
    rate = damping / mass
    if abs(rate * ts) < 1e-6:   # B -> 0 limits
        return 1.0, ts, ts / mass, 0.5 * ts * ts / mass
    decay = -np.expm1(-rate * ts)   # 1 - a
    return 1.0 - decay, decay / rate, decay / damping, (ts - decay / rate) / damping
