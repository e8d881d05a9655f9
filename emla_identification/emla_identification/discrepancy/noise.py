"""The sensor noise a re-alignment (a sensor's delay or filter) passes into the rows: a re-alignment filters the
signals, so its variants carry different shares of the noise, and they are compared on their error less it."""
import numpy as np

from emla_core.physics import Candidate

from .adequacy import heldout_noise
from .measures import heldout_errors, heldout_total, noise_gains_of, variances_of


def realigns(candidate):
    """Does the candidate re-align the data (a sensor's delay or filter: Candidate.realigned)?"""
    return type(candidate).realigned is not Candidate.realigned


def gains(result, errors, candidate):
    """adequacy.noise_gains of a finite fit where `candidate` re-aligns the data (noise_free_of reads them), else {}."""
    return noise_gains_of(result) if realigns(candidate) and np.all(np.isfinite(errors)) else {}


def noise_free_error(result, noise_free, candidate, errors=None):
    """A Fit's held-out errors (or `errors`, each equation's) through `noise_free` (noise_free_of of `candidate`)."""
    errors = heldout_errors(result) if errors is None else errors
    return noise_free(gains(result, errors, candidate), errors)


def noise_free_of(model, candidate):
    """(noise gains of a fit (adequacy.noise_gains), each equation's error) -> where `candidate` re-aligns the
    data, the sum over the equations of the error less the sensor noise the fit's rows carry into it, in units of
    the noise the Fit `model`'s rows carry into that equation, at the noise levels fitted to the residuals of
    `model` (adequacy.sensor_noise: a fit with a re-alignment of that kind, whose residual's high band is the
    noise; the misaligned model's is not: behind a 1 kHz current filter at 10 kHz it gave 28 mA for the plant's
    5); the errors' sum otherwise.

    A re-alignment filters the signals (undoing a position filter, x = y + tau dy/dt, amplifies the position's
    noise by about (tau / Ts)^2; a current filter passes the position through the filter, which smooths it), so
    its variants carry different shares of the noise, and the held-out error rewards the one that carries least:
    behind a 2 kHz position filter at 10 kHz it took tau 1-4 % short (R 5 sigma off), less the noise within
    1.1 %. The fitted noise levels are within 5 % of the independent plant's. Each equation in its noise's units:
    the rows are weighted by the residual of the model before the re-alignment, which a misaligned position
    leaves huge in the force balance (805000 times its floor, 2 samples late at 5 kHz), and in those weights the
    electrical equation's noise, not the force balance, set the delay (2.007 samples, the force balance left at
    10 times its floor, where 2 leaves it at 1)."""
    if not realigns(candidate) or not noise_known(model):
        return lambda gains, errors: float(np.sum(errors))
    variances = variances_of(model)
    own = heldout_noise(noise_gains_of(model), variances)
    kinds = model.data.kinds
    scale = [own[kind] if own[kind] > 0 else 1.0 for kind in kinds]

    def noise_free(gains, errors):
        noise = heldout_noise(gains, variances)   # {} where the fit failed: its errors are infinite
        return float(sum((error - noise.get(kind, 0.0)) / unit for kind, error, unit in zip(kinds, errors, scale)))
    return noise_free


def noise_known(model):
    """Are the sensor noise levels fitted to a finite Fit's residuals (adequacy.sensor_noise) its noise: do they
    put no more into each equation's held-out error than it holds (within 3 sqrt(2 / n), the spread of a sum of n
    squares of white noise)? Where the residual is misfit, not white noise, the levels fitted to its high band
    can predict more than all of it (a 1-sample current delay named 2.84 samples beside a missing spring at
    3 kHz: 1.4 and 2 times, 235 mA for 5), and taking that off its held-out error made the worst candidate
    perfect; the right re-alignments here predict their held-out error within 1 %."""
    if not np.isfinite(heldout_total(model)):
        return False
    noise = heldout_noise(noise_gains_of(model), variances_of(model))
    errors = model.heldout.sum(axis=0)
    spread = 1.0 + 3.0 * np.sqrt(2.0 / model.degrees_of_freedom)
    return all(noise[kind] <= spread * error for kind, error in zip(model.data.kinds, errors))


def excess_noise(base, result):
    """(FOLDS, kinds): the sensor noise a Fit `result` whose last candidate re-aligns the data carries into each
    equation's held-out blocks beyond what the rows of `base` carry there (at the noise levels fitted to `result`,
    shared among the blocks by their rows); 0 for any other candidate. Taken off its held-out error, its score is
    the misfit it removes, not the noise it passes: undoing a 2 kHz position filter at 10 kHz amplifies the
    position's noise by about 1 + 0.26 (tau / Ts)^2, a delay of about tau (an all-pass) does not, and the delay
    was named for the filter."""
    if not realigns(result.candidates[-1]) or not noise_known(result):
        return 0.0
    variances = variances_of(result)
    own, theirs = (heldout_noise(noise_gains_of(f), variances) for f in (result, base))
    rows = np.diff(result.bounds) / (result.bounds[-1] - result.bounds[0])
    return rows[:, None] * np.array([own[kind] - theirs[kind] for kind in result.data.kinds])
