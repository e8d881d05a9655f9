"""What the workflow compares fits by: each equation's held-out and in-sample error, the disagreement a
fit leaves above the noise floor, and the share of it a candidate removes; the costly ones kept per Fit."""
import numpy as np

from .adequacy import noise_gains, rows_adequacy, sensor_noise
from .fit import physical


def _kept(model, measure):
    """measure(model), computed once per Fit and kept in its __dict__ under the measure's name."""
    key = '_' + measure.__name__
    if key not in model.__dict__:
        model.__dict__[key] = measure(model)
    return model.__dict__[key]


def adequacy_of(model):
    """rows_adequacy of a Fit, kept (the candidates' comparisons ask for it again and again)."""
    return _kept(model, rows_adequacy)


def variances_of(model):
    """adequacy.sensor_noise of a Fit, kept (a polish, a backfit and the score ask again)."""
    return _kept(model, sensor_noise)


def noise_gains_of(model):
    """adequacy.noise_gains of a Fit, kept (each re-aligning candidate judged against it asks again)."""
    return _kept(model, noise_gains)


def chi_squares(result):
    """Each equation's weighted residual sum of squares on all its rows (in the Fit's own weights, data.kinds
    order); infinite for an impossible actuator."""
    return _possible(result, [result.degrees_of_freedom * (result.rms[kind] / result.sigma[kind]) ** 2
                              for kind in result.data.kinds])


def heldout_errors(result):
    """Each equation's held-out residual sum of squares (data.kinds order); infinite for an impossible actuator or
    a failed fit."""
    return _possible(result, result.heldout.sum(axis=0))


def _possible(result, errors):
    errors = np.asarray(errors, dtype=float)
    return errors if np.all(np.isfinite(errors)) and physical(result.parameters) else np.full(errors.shape, np.inf)


def heldout_total(result):
    """A Fit's held-out residual sum of squares; infinite for an impossible actuator or a failed fit."""
    return float(np.sum(heldout_errors(result)))


def removed_share(before, after):
    """The share of the disagreement `before` that a candidate removes, leaving `after`: 1 when it removes all,
    0 when none, down to -1 when it doubles it or worse (bounded both ways, whatever the sizes)."""
    if not after < np.inf:   # a fit that failed (or diverged) on the held-out data
        return -1.0
    largest = max(before, after)
    return float((before - after) / largest) if largest > 0 else 0.0


def disagreement_of(adequacy):
    """The low-band residual power above the noise floor, in floor units, summed over the equations."""
    return sum(max(a.ratio - 1.0, 0.0) for a in adequacy.values())


def least_left(bands):
    """The index of the adequacy among `bands` (of fits to the same data) that leaves the least disagreement: _left
    in the lowest floor among them, per equation (each fit's own floor rises with its misfit); the first of equals."""
    unit = {equation: min(b[equation].floor for b in bands) for equation in bands[0]}
    return min(range(len(bands)), key=lambda i: _left(bands[i], unit))


def _left(adequacy, unit):
    """The log of the product over the equations of the low-band residual power in `unit` ({equation: floor}),
    the floor added: a factor gained in either equation counts alike, whatever their units."""
    return sum(np.log1p((a.size / unit[e]) ** 2) if unit[e] > 0 else np.inf for e, a in adequacy.items())
