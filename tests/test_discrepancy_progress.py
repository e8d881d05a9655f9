"""The discrepancy workflow tells a caller how far it has got (diagnose's `progress`), and `emla discrepancy`
shows that as a bar on a terminal only."""
import io

import independent_plant as ip
import pytest

from emla_cli.commands.discrepancy import progress_bar
from emla_identification.discrepancy import diagnose
from emla_identification.discrepancy.candidates import library
from emla_identification.discrepancy.data import Data


@pytest.fixture(scope='module')
def friction_record():
    return ip.record(duration=1.0, effects=[ip.make_effect('coulomb_friction', force=1.0)], seed=4)[0]


def test_progress_names_each_stage_and_every_candidate(friction_record):
    calls = []
    diagnosis = diagnose(friction_record, progress=lambda *call: calls.append(call))
    assert diagnosis.main is not None and diagnosis.main.name == 'coulomb_friction'
    assert calls[0][0] == 'the nominal model'
    candidates = [c.name for c in library(Data.from_recording(friction_record))]
    first = [call for call in calls if call[0] == 'ranking']
    assert [name for *_, name in first] == candidates   # each once, in order, before it is assessed
    assert [(done, total) for _, done, total, _ in first] == [(i, len(candidates)) for i in range(len(candidates))]
    assert ('naming', 0, 1, 'coulomb_friction') in calls
    after = [call for call in calls if call[0] == 'ranking after coulomb_friction']
    assert len(after) == len(candidates) - 1 and 'coulomb_friction' not in {name for *_, name in after}
    assert diagnosis.to_dict() == diagnose(friction_record).to_dict()   # watching changes nothing


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_bar_on_a_terminal_shows_the_stage_and_the_candidate():
    stream = _Terminal()
    with progress_bar(stream) as progress:
        progress('ranking', 3, 11, 'coulomb_friction')
    shown = stream.getvalue()
    assert 'ranking: 3/11' in shown and 'coulomb_friction' in shown


def test_no_bar_in_a_log():
    stream = io.StringIO()
    with progress_bar(stream) as progress:
        assert progress is None
    assert stream.getvalue() == ''
