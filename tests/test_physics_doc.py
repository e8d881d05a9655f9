"""docs/physics.md against the registries it describes: every effect the plant simulates and every discrepancy
candidate has its section, with each of its parameters named and the plant's defaults as the code has them; and
the document names no effect the code does not have. The test fails when one of them changes alone."""
import dataclasses
import re
from pathlib import Path

import pytest

from emla_core.physics import CANDIDATES, EFFECTS

DOC = Path(__file__).resolve().parents[1] / 'docs' / 'physics.md'


def _section(text, heading):
    """The text under the markdown heading that starts with `heading`, up to the next heading of its level or a
    higher one."""
    level = heading.split(' ')[0]
    start = text.index('\n' + heading) + 1
    match = re.compile(rf'^#{{1,{len(level)}}} ', re.M).search(text, start + len(heading))
    return text[start:match.start() if match else len(text)]


def _blocks():
    """{effect name: its text} of the bold-named blocks of 6.2 (each effect) and 7 (the bench imperfections)."""
    text = DOC.read_text()
    blocks = {}
    for heading in ('### 6.2', '## 7.'):
        section = _section(text, heading)
        marks = list(re.finditer(r'\*\*([a-z_]+)\*\*', section))
        for mark, following in zip(marks, marks[1:] + [None]):
            blocks.setdefault(mark.group(1), '')
            blocks[mark.group(1)] += section[mark.start():following.start() if following else len(section)]
    return blocks


BLOCKS = _blocks()


def test_the_document_describes_every_registered_effect_and_no_other():
    registered = set(EFFECTS) | set(CANDIDATES)
    assert registered - set(BLOCKS) == set(), 'registered but not in docs/physics.md'
    assert set(BLOCKS) - registered == set(), 'in docs/physics.md but not registered'


@pytest.mark.parametrize('name', sorted(EFFECTS))
def test_each_plant_parameter_is_named_with_the_default_the_code_has(name):
    block = BLOCKS[name]
    for field in dataclasses.fields(EFFECTS[name]):
        assert f'`{field.name}`' in block, f'{name}: parameter {field.name} not in docs/physics.md'
        stated = re.search(rf'`{field.name}`[^`]*?default ([-+0-9.e]+)', block)
        if stated:
            assert float(stated.group(1).rstrip('.')) == pytest.approx(field.default), f'{name}.{field.name}'


@pytest.mark.parametrize('name', sorted(CANDIDATES))
def test_each_candidate_parameter_is_named(name):
    for parameter in CANDIDATES[name].parameters:
        assert f'`{parameter}`' in BLOCKS[name], f'{name}: parameter {parameter} not in docs/physics.md'


def test_the_table_of_where_effects_live_names_registered_candidates_only():
    table = _section(DOC.read_text(), '### 6.3')
    rows = [line.split('|')[1].strip() for line in table.splitlines() if line.startswith('| ') and '---' not in line]
    names = {name.strip() for row in rows[1:] for name in row.split('/')}
    assert names - {'magnetic_stiffness'} == set(CANDIDATES)
