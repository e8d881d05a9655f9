"""Input checks of the grey-box identification: one clear InputError naming the source and the problem."""
import contextlib
import warnings

import numpy as np

from emla_core.errors import InputError

from .plausibility import SI_UNITS
from .regressors import COLUMNS, FIRST_ORDER, HISTORY, SIGNALS, default_model, regressions_for
from .rls import forgetting_factor

MIN_ROWS = 16           # regression rows (samples - HISTORY) below which a record is too short
_MAX_CONDITION = 1e12   # normalised information matrix above this: a parameter is not excited
# Typical SI magnitudes (sample period s, peaks V, A, m, N). A record more than SPAN from them, or with a
# sample period outside SAMPLE_PERIODS, is refused: its unit is far off, and the regressions (which divide
# differences by Ts^2 and square them) and the discrepancy fit lose the magnitudes they are made for.
TYPICAL = {'t': 1e-4, 'voltage': 10.0, 'current': 1.0, 'position': 1e-3, 'velocity': 0.1, 'force': 1.0}
SPAN = 1e9
SAMPLE_PERIODS = (1e-9, 1e3)


def checked(recording, model, forgetting, memory_time=None):
    """(model, regression kinds, lambda) for this recording, or InputError naming its source and the problem."""
    model, kinds, lam = setup(recording, model, forgetting, memory_time)
    check_finite(recording, kinds)
    check_magnitudes(recording)
    check_length(len(recording), model, recording.source)
    return model, kinds, lam


def missing_signals(recording):
    """The InputError for a record without the signals of any grey-box model: what it has, and the flags that map
    a user's own names."""
    return InputError(f'{recording.source or "recording"}: needs columns voltage, current, position (or force, '
                      f'position); has {", ".join(recording.signals) or "none"}: map yours with --columns '
                      f'voltage=NAME,current=NAME,position=NAME (a bag\'s topics with --topics)')


def setup(recording, model, forgetting, memory_time=None):
    """(model, regression kinds, lambda) for the signals of `recording` (all of it, or its first part)."""
    source = recording.source or 'recording'
    model = model or default_model(recording.signals)
    if model is None:
        raise missing_signals(recording)
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


def check_magnitudes(recording):
    """InputError when the sample period or a signal's peak is too far from SI magnitudes for the regressions
    (a unit far off), naming it and the flag that gives its unit."""
    source = recording.source or 'recording'
    low, high = SAMPLE_PERIODS
    if not low <= recording.sample_period <= high:
        raise InputError(f'{source}: the sample period {recording.sample_period:.3g} s is beyond what the '
                         f'identification resolves ({low:g} to {high:g} s): give the time\'s unit with --units '
                         f't=UNIT (or --sample-period in s)')
    for name, values in recording.signals.items():
        values = np.abs(np.asarray(values, dtype=float)) if name in TYPICAL else np.zeros(0)
        peak = float(np.max(values[np.isfinite(values)], initial=0.0))
        low, high = (TYPICAL.get(name, 1.0) * f for f in (1 / SPAN, SPAN))
        if peak and not low <= peak <= high:
            raise InputError(f'{source}: the {name} peaks at {peak:.3g} {SI_UNITS[name]}, beyond what the '
                             f'identification is made for ({low:g} to {high:g} {SI_UNITS[name]}): give its unit '
                             f'with --units {name}=UNIT')


@contextlib.contextmanager
def numerical_failures(source, what):
    """Turn a numerical failure inside (a singular or non-finite matrix, an overflow) into an InputError: 'SOURCE:
    WHAT from these data: why' (what: 'the full model cannot be identified'); the library's boundary to its
    users. Floating-point warnings inside are silenced: their results are checked where they matter."""
    try:
        with np.errstate(all='ignore'), warnings.catch_warnings():
            warnings.simplefilter('ignore', RuntimeWarning)   # (a mean of nothing: NaN, reported where used)
            yield
    except (ValueError, ZeroDivisionError, OverflowError, FloatingPointError) as exc:  # LinAlgError: a ValueError
        reason = str(exc) if type(exc) is ValueError else f'the arithmetic failed ({exc or type(exc).__name__})'
        raise InputError(f'{source or "recording"}: {what} from these data: {reason}') from None


def check_length(samples, model, source):
    """InputError when a record has too few samples for any row of the model."""
    if samples - HISTORY < MIN_ROWS:
        raise InputError(f'{source or "recording"}: {samples} samples are too few for the {model} model '
                         f'(needs at least {MIN_ROWS + HISTORY})')


def check_excitation(gram, kind, source):
    """InputError when the regressors do not excite every coefficient (e.g. the actuator never moved); gram:
    sum of phi phi' over the rows."""
    T, names = FIRST_ORDER.get(kind, (np.eye(len(gram)), COLUMNS[kind]))
    gram = T @ gram @ T.T
    scale = np.sqrt(np.diag(gram))
    if np.any(scale == 0) or np.linalg.cond(gram / np.outer(scale, scale)) > _MAX_CONDITION:
        raise InputError(f'{source}: the data do not excite the {kind} equation enough to identify '
                         f'{", ".join(names)}')
