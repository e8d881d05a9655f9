"""Input checks of the grey-box identification: one clear InputError naming the source and the problem."""
import numpy as np

from emla_core.errors import InputError

from .regressors import COLUMNS, HISTORY, SIGNALS, default_model, regressions_for
from .rls import forgetting_factor

MIN_ROWS = 16           # regression rows (samples - HISTORY) below which a record is too short
_MAX_CONDITION = 1e12   # normalised information matrix above this: a parameter is not excited


def checked(recording, model, forgetting, memory_time=None):
    """(model, regression kinds, lambda) for this recording, or InputError naming its source and the problem."""
    model, kinds, lam = setup(recording, model, forgetting, memory_time)
    check_finite(recording, kinds)
    check_length(len(recording), model, recording.source)
    return model, kinds, lam


def setup(recording, model, forgetting, memory_time=None):
    """(model, regression kinds, lambda) for the signals of `recording` (all of it, or its first part)."""
    source = recording.source or 'recording'
    model = model or default_model(recording.signals)
    if model is None:
        raise InputError(f'{source}: needs columns voltage, current, position (or force, position); '
                         f'has {", ".join(recording.signals) or "none"}')
    try:
        kinds = regressions_for(model, recording.signals)
        lam = forgetting_factor(forgetting, memory_time, recording.sample_period)
    except ValueError as exc:
        raise InputError(f'{source}: {exc}') from None
    return model, kinds, lam


def check_finite(recording, kinds, first=0):
    """InputError at the first non-finite sample of the signals `kinds` use; `first`: index of sample 0."""
    for name in sorted({s for kind in kinds for s in SIGNALS[kind]}):
        bad = ~np.isfinite(recording.signals[name])
        if bad.any():
            raise InputError(f'{recording.source or "recording"}: non-finite {name} at sample '
                             f'{first + int(np.argmax(bad))}')


def check_length(samples, model, source):
    """InputError when a record has too few samples for any row of the model."""
    if samples - HISTORY < MIN_ROWS:
        raise InputError(f'{source or "recording"}: {samples} samples are too few for the {model} model '
                         f'(needs at least {MIN_ROWS + HISTORY})')


def check_excitation(gram, kind, source):
    """InputError when the regressors do not excite every coefficient (e.g. the actuator never moved); gram:
    sum of phi phi' over the rows."""
    scale = np.sqrt(np.diag(gram))
    if np.any(scale == 0) or np.linalg.cond(gram / np.outer(scale, scale)) > _MAX_CONDITION:
        raise InputError(f'{source}: the data do not excite the {kind} equation enough to identify '
                         f'{", ".join(COLUMNS[kind])}')
