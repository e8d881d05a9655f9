"""A sprung actuator's record with gaps, or read in parts: the return spring is tried there as on a whole record
in memory (the rows with its column accumulated beside the nominal ones, none across a gap)."""
import numpy as np
import pytest
from bench_experiments import open_loop_steps
from test_streaming import assert_same_result

from emla_core.recording import Recording
from emla_identification.greybox import identify
from emla_identification.streaming import identify_chunks, split

NAMES = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping', 'spring_stiffness')
LOST = ((7000, 5), (15000, 40), (23000, 12))   # (first sample lost, samples lost)


@pytest.fixture(scope='module')
def sprung():
    return open_loop_steps(rate=10000.0, duration=3.0, spring=2000.0, seed=3)


def _with_gaps(recording):
    """The record with the samples of LOST dropped, as a logger that drops them writes it."""
    keep = np.ones(len(recording), dtype=bool)
    for first, missing in LOST:
        keep[first:first + missing] = False
    gaps, dropped = [], 0
    for first, missing in LOST:
        gaps.append((first - dropped, missing))
        dropped += missing
    return Recording(recording.sample_period, {k: np.asarray(v)[keep] for k, v in recording.signals.items()},
                     source='gapped', gaps=tuple(gaps))


def _check(result, truth):
    errors = {n: ((result.parameters[n] - truth[n]) / truth[n], (result.parameters[n] - truth[n]) / result.std[n])
              for n in NAMES}
    assert all(abs(rel) < 0.01 and abs(sig) < 3.0 for rel, sig in errors.values()), errors
    assert any('return spring' in note for note in result.notes)
    assert result.fit['mechanical'].adequate


def test_a_sprung_record_with_gaps_gets_its_spring(sprung):
    recording, truth = sprung
    gapped = _with_gaps(recording)
    assert len(gapped.segments()) == 4
    result = identify(gapped, points=1)
    _check(result, truth)
    whole = identify(recording, points=1)
    for name in NAMES:   # the gaps cost 57 of 30000 samples: the estimate barely moves
        assert abs(result.parameters[name] - whole.parameters[name]) <= whole.std[name], name


def test_a_sprung_record_read_in_parts_is_the_record_in_memory(sprung):
    recording, truth = sprung
    streamed = identify_chunks(split(recording, 4096), points=1)
    _check(streamed, truth)
    # a spring's column beside the position's (x_k vs its differences) conditions the normal equations worse
    assert_same_result(streamed, identify(recording, points=1), rel=1e-8, std_rel=1e-4)


def test_the_spring_can_be_asked_for_or_refused_in_parts(sprung):
    recording, _ = sprung
    gapped = _with_gaps(recording)
    assert 'spring_stiffness' not in identify(gapped, spring=False, points=1).parameters
    assert 'spring_stiffness' in identify_chunks(split(recording, 4096), spring=True, points=1).parameters
