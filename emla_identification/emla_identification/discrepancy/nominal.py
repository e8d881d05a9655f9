"""The nominal model of a record, rescued from the start an effect gives where it alone cannot be identified."""
import numpy as np

from emla_core.errors import InputError

from ..plausibility import plausibility_warnings
from .candidates import library
from .fit import fit, nominal_fit, physical
from .rank import assess
from .start import rescue_starts


def nominal_model(data, recording, names):
    """(the nominal Fit, its warnings). When the nominal model alone cannot be identified (no estimate, or an
    impossible one), it is fitted about the start some effect gives (start.py) where one does: the best such fit
    of the raw data, with a warning saying so; otherwise an InputError says why not."""
    try:
        nominal, failure = fit(data), None
    except InputError as error:
        nominal, failure = None, error
    if nominal is not None and physical(nominal.parameters):
        return nominal, plausibility_warnings(_physical_only(nominal.parameters), nominal.std, recording)
    rescued = []   # (held-out residual sums of squares per equation, in its units; label, nominal fit)
    for label, start, givers in rescue_starts(data, library(data, names)):
        base = nominal_fit(data, start)
        for giver in givers:   # a re-alignment as it is (its start came from it), another effect at its best
            trial = fit(giver.realigned(data), (giver,), base) if giver.realigned(data) is not data else \
                assess(base, giver).fit
            errors = trial.heldout.sum(axis=0) * np.array([trial.sigma[kind] ** 2 for kind in data.kinds])
            if np.all(np.isfinite(errors)) and physical(trial.parameters):
                rescued.append((errors, label, base))
    if rescued:   # the start whose model explains the raw data best, each equation's error against its least
        least = np.min([errors for errors, *_ in rescued], axis=0)
        _, label, best = min(rescued, key=lambda r: float(np.sum(r[0] / np.maximum(least, 1e-300))))
        return best, [f'the nominal model alone cannot be identified from these data; it is fitted about the '
                      f'estimate {label} gives']
    if failure is not None:
        raise failure
    warnings = plausibility_warnings(_physical_only(nominal.parameters), nominal.std, recording)
    found = (', '.join(f'{k} = {v:.4g}' for k, v in nominal.parameters.items())
             if all(np.isfinite(list(nominal.parameters.values()))) else 'no finite estimate')
    raise InputError(f'{data.source}: the nominal model cannot be identified from these data: ' +
                     ('; '.join(warnings) or f'{found}; does the recording excite the actuator?'))


def _physical_only(parameters):
    """The fit's physical parameters, without its sample period."""
    return {k: v for k, v in parameters.items() if k != 'sample_period'}
