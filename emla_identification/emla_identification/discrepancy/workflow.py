"""The model-discrepancy workflow: is the nominal model adequate? If not, name the missing effects one by one
(rank the candidates, add the best, re-identify), until the model is adequate or no candidate explains what
is left; report the gap between model and measurement before and after, and where what is left lies.

Adequacy (adequacy.py): each equation's held-out one-step residual against the floor the sensor noise
alone would leave in it. The verdict: `adequate` (the nominal model fits to the noise floor), `explained`
(the named effects leave nothing), `unexplained` (a disagreement remains that no candidate explains). What
is left is located (emla_identification/dependence.py) on the signals it is a smooth function of.

The stages, each a module: nominal.py (the nominal model), adequacy.py (is it adequate?), rank.py
(the candidates against it), judge.py (how each is judged), name.py (name the best, add it, rank again),
refine.py (polish what is named), diagnosis.py (the result and its JSON), locate.py (where what is left lies)."""
from collections.abc import Callable, Sequence
from pathlib import Path

from numpy.typing import ArrayLike

from emla_core.data import as_recording
from emla_core.recording import Recording

from ..checks import check_magnitudes, numerical_failures
from .candidates import library
from .data import Data
from .diagnosis import Diagnosis
from .measures import adequacy_of
from .name import name_effects, other_form
from .nominal import nominal_model
from .predict import predict
from .rank import rank

Progress = Callable[[str, int, int, str], None]   # (stage, done, total, name of the item): see diagnose


def diagnose(data: Recording | Path | str | None = None, names: Sequence[str] | None = None, *,
             sample_period: float | None = None, voltage: ArrayLike | None = None, current: ArrayLike | None = None,
             position: ArrayLike | None = None, force: ArrayLike | None = None,
             progress: Progress | None = None) -> Diagnosis:
    """Find what the two-equation actuator model is missing in a record: say whether it is adequate, name the
    missing effects, add them and show the gap shrink, or say where an unexplained disagreement lies.

    The nominal model is identified and its held-out residuals compared with the sensor-noise floor. If it
    does not fit to that floor, each candidate effect (those of the physics layer, emla_core.physics, and any
    added with `register_candidate`) is judged by the share of the held-out
    prediction error it removes; the best one is named when that is significant and removes most of the
    disagreement, added, and the search repeats (up to four effects).

    Parameters
    ----------
    data : Recording, str or Path, optional
        The record (a Recording, or a CSV file or ROS 2 bag to load); leave it out to pass arrays instead.
    names : sequence of str, optional
        The registered candidates to consider (default: all).
    sample_period : float, optional
        Sample period in s of the arrays.
    voltage, current, position, force : array_like, optional
        Uniformly sampled signals in V, A, m and N: voltage, current and position, or force and position.
    progress : callable, optional
        progress(stage, done, total, name), called as the work goes on: the stage ('the nominal model', 'ranking',
        'naming', 'ranking after NAMES', 'other forms'), how many of its `total` items are done, and the item's
        name (the candidate being assessed or named); for a progress bar (`emla discrepancy` on a terminal).

    Returns
    -------
    Diagnosis
        `verdict` ('adequate', 'explained' or 'unexplained'); `to_dict()` gives the `emla discrepancy` JSON
        (verdict, missing_effect, effects, disagreement, candidates, gap before and after, parameters);
        `write_report(diagnosis, directory)` writes the Markdown report with plots.

    Raises
    ------
    InputError
        Unusable data, or data from which the nominal model cannot be identified.

    Examples
    --------
    >>> from emla_identification.discrepancy import diagnose
    >>> diagnosis = diagnose('bags/example_discrepancy')            # doctest: +SKIP
    >>> diagnosis.verdict, diagnosis.to_dict()['missing_effect']    # doctest: +SKIP
    ('explained', 'coulomb_friction')
    """
    recording = as_recording(data, sample_period=sample_period, voltage=voltage, current=current, position=position,
                             force=force)
    windowed = Data.from_recording(recording)
    check_magnitudes(recording)
    with numerical_failures(windowed.source, 'the model cannot be diagnosed'):   # degenerate data show up as
        if progress is not None:
            progress('the nominal model', 0, 1, '')
        nominal, warnings = nominal_model(windowed, recording, names)            # non-finite or unphysical estimates
        adequacy = adequacy_of(nominal)   # (no candidate reads a signal: the rows' floor is the whole floor)
        ranked = rank(nominal, library(windowed, names), progress)
        diagnosis = Diagnosis(windowed, nominal, ranked, adequacy, predict(nominal), warnings=warnings)
        name_effects(diagnosis, names, nominal, adequacy, ranked, progress)
        return other_form(diagnosis, names, progress) if diagnosis.verdict == 'unexplained' else diagnosis
