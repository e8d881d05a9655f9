"""Where the nominal fit starts when the nominal model alone cannot be identified from a record.

A strong effect can bias the grey-box identification's regressions so far that the physical parameters it fits
are impossible (a negative inductance under a magnetic stiffness; a negative resistance when the current ADC is
three samples late at 3 kHz). The model with the effect would fit, but the workflow linearises every model
about the nominal estimate (fit.py). So each effect that can give a start is asked for one:
- an effect with an online column (a spring, a friction: emla_core.physics, `Effect.online`): the grey-box
  identification with those columns beside the regressions' own (online.OnlineIdentifier over the record);
- a candidate that re-aligns the data (a sensor's delay or filter): the grey-box identification of the data as
  the variant re-aligns them whose rows the free regressions fit best (least squares on the coefficients, no
  physics: a fraction of a grey-box identification's cost, which is mostly its minimum-distance fit).
Each physical start comes with the candidates that gave it; the workflow keeps the start about which the nominal
model with one of them fits the raw data best (held-out error), and names an effect only if its ranking finds it.
"""
import numpy as np

from emla_core.errors import InputError
from emla_core.physics import EFFECTS, Candidate
from emla_core.recording import Recording
from emla_identification.online import OnlineIdentifier
from emla_identification.regressors import rows

from .fit import physical
from .rows import nominal_names


def rescue_starts(data, candidates):
    """[(what gave it, {nominal parameter: value}, [the candidates or variant that gave it])] of the physical
    starts the `candidates` (instances) give on `data` (module doc); empty when none does."""
    from emla_identification.greybox import identify  # here: greybox's fit check imports this package
    out = []
    online = [c for c in candidates if getattr(EFFECTS.get(c.name), 'online', None) is not None]
    if online and data.electrical:
        identifier = OnlineIdentifier(data.sample_period, effects=[c.name for c in online])
        identifier.update(**data.signals)
        out.append((' and '.join(c.name for c in online), identifier.estimate()[0], online))
    for candidate in candidates:
        if type(candidate).realigned is Candidate.realigned:
            continue
        variant = min(candidate.variants(data), key=lambda v: _free_misfit(v.realigned(data)))
        moved = variant.realigned(data)
        try:
            result = identify(Recording(data.sample_period, dict(moved.signals), source=data.source),
                              model='mechanical' if data.kinds == ('force',) else 'full', points=1, spring=False)
        except InputError:
            continue
        out.append((f'{candidate.name} {variant.settings()}', result.parameters, [variant]))
    names = nominal_names(data)
    return [(label, {k: float(start[k]) for k in names}, givers) for label, start, givers in out
            if physical(start) and all(np.isfinite([start[k] for k in names]))]


def _free_misfit(data):
    """Sum over the regressions of the log of their residual variance with free coefficients (least squares)."""
    total = 0.0
    for kind in data.kinds:
        phi, y = rows(kind, data.signals, data.sample_period)
        residual = y - phi @ np.linalg.lstsq(phi, y, rcond=None)[0]
        total += float(np.log(max(np.mean(residual ** 2), 1e-300)))
    return total
