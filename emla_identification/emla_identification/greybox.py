"""Grey-box identification of a whole record: physical EMLA parameters (R, L, Km, m, B, Fl) with one-sigma
uncertainties and their convergence over the record.

Each regression of regressors.py is solved by exponentially weighted least squares over the record, the
electrical one by instrumental variables (offline.py; streams: rls.py, see online.py and streaming.py); the
physical parameters follow from the solutions (physical.py) with uncertainties from a sensor-noise model
(noise.py). On the test data the reported values match the scatter over noise realisations to within some 50 %.
"""
from dataclasses import dataclass, field

import numpy as np

from emla_core.errors import InputError

from . import offline
from .checks import check_excitation, checked
from .moments import RowMoments
from .physical import physical
from .regressors import HISTORY, instruments, rows


@dataclass
class Trajectory:
    """Estimates after growing parts of a record: time (s) of the last sample used, {name: array}."""

    time: np.ndarray
    parameters: dict
    std: dict


@dataclass
class GreyBoxResult:
    model: str
    parameters: dict        # {name: value}, SI; only the parameters the model identifies
    std: dict               # {name: one-sigma}
    covariance: np.ndarray  # of the parameters, in the order of `parameters`
    samples: int
    sample_period: float
    forgetting: float
    trajectory: Trajectory = field(repr=False, default=None)

    def to_dict(self):
        """The `emla identify` JSON object."""
        return {'model': self.model, 'samples': self.samples, 'sample_period': self.sample_period,
                'parameters': dict(self.parameters), 'std': dict(self.std)}


def identify(recording, model=None, forgetting=1.0, *, initial_covariance=1e6, points=200, progress=None):
    """Grey-box parameters of a whole Recording (default model: full for coil signals, mechanical for force).

    The result's trajectory holds the estimates after about `points` growing parts of the record (the
    last one is the final estimate), for convergence plots. progress: None or a function called with the
    fraction of the work done (0..1) as it goes.
    """
    model, kinds, lam = checked(recording, model, forgetting)
    source = recording.source or 'recording'
    report = progress or (lambda fraction: None)
    n, ts = len(recording), recording.sample_period
    every = max(1, (n - HISTORY) // points)
    trajectories = {}  # kind -> [Statistics after rows [0, end) for each end]
    for j, kind in enumerate(kinds):
        phi, y = rows(kind, recording.signals, ts)
        zeta = instruments(kind, recording.signals, ts)
        check_excitation(phi.T @ phi, kind, source)
        track = offline.trajectory(phi, y, every, instruments=zeta, forgetting=lam,
                                   initial_covariance=initial_covariance)
        ends = track.samples
        moments, z, start = RowMoments(phi.shape[1], lam, zeta is not None), np.column_stack((phi, y)), 0
        trajectories[kind] = []
        for theta, covariance, end in zip(track.theta, track.covariance, ends):
            moments.update(z[start:end], None if zeta is None else zeta[start:end])
            trajectories[kind].append(moments.statistics(theta, covariance))
            start = end
        report((j + 1) / (len(kinds) + 1))
    snapshots = [{kind: trajectory[j] for kind, trajectory in trajectories.items()} for j in range(len(ends))]
    return result(model, snapshots, ends, recording, n, lam,
                   lambda j: report((len(kinds) + (j + 1) / len(ends)) / (len(kinds) + 1)))


def result(model, snapshots, ends, recording, samples, forgetting, done=lambda j: None):
    """The GreyBoxResult from {kind: Statistics} after rows [0, end) for each of `ends` (the last: all rows).

    recording: the record or its first part (source, start time, sample period); done(j) after snapshot j."""
    source, ts = recording.source or 'recording', recording.sample_period
    values, stds = [], []
    for j, statistics in enumerate(snapshots):
        names, value, covariance = physical(model, statistics, ts)
        values.append(value)
        stds.append(np.sqrt(np.diag(covariance)))
        done(j)
    values, stds = np.array(values), np.array(stds)
    if not np.all(np.isfinite(values[-1])):
        raise InputError(f'{source}: the {model} model gives no finite estimate from these data')
    trajectory = Trajectory(time=recording.start_time + (np.asarray(ends) + HISTORY - 1) * ts,
                            parameters=dict(zip(names, values.T)), std=dict(zip(names, stds.T)))
    return GreyBoxResult(model=model, parameters={k: float(v) for k, v in zip(names, values[-1])},
                         std={k: float(s) for k, s in zip(names, stds[-1])}, covariance=covariance,
                         samples=samples, sample_period=ts, forgetting=forgetting, trajectory=trajectory)
