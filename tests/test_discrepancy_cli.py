"""`emla discrepancy` end to end, and the generator of the bundled example bag.

Regenerate bags/example_discrepancy (1 s of closed-loop data at 10 kHz, Table 1 actuator, 5 mA / 1 um
sensor, with 1 N of Coulomb friction the nominal model does not know about):

    .venv/bin/python tests/test_discrepancy_cli.py
"""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from emla_core.bag import write_recording
from emla_core.data import load
from emla_core.physics import EFFECTS, CoulombFriction
from emla_core.recording import Recording, write_csv
from emla_sim.datasets import closed_loop

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / 'bags' / 'example_discrepancy'
HIDDEN = CoulombFriction(coulomb_force=1.0)


def example_recording():
    recording, _ = closed_loop(duration=1.0, seed=7, effects=(HIDDEN,))
    return recording


def write_example(path):
    """The example bag at `path` (must not exist or be empty)."""
    write_recording(example_recording(), path, custom_data={
        'hidden_effect': HIDDEN.name, 'hidden_coulomb_force': HIDDEN.coulomb_force,
        'generator': 'tests/test_discrepancy_cli.py'})


def emla(*args):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    return subprocess.run([sys.executable, '-m', 'emla_cli.cli', *map(str, args)], capture_output=True,
                          text=True, timeout=300, env=env)


def test_example_bag_is_what_the_generator_writes():
    bundled, fresh = load(EXAMPLE), example_recording()
    assert bundled.metadata['hidden_effect'] == 'coulomb_friction'
    for name, values in fresh.signals.items():
        np.testing.assert_array_equal(bundled.signals[name], values)


def test_cli_on_the_example_bag(tmp_path):
    out = emla('discrepancy', EXAMPLE, '--json', tmp_path / 'd.json', '--report', tmp_path / 'report')
    assert out.returncode == 0, out.stderr
    result = json.loads((tmp_path / 'd.json').read_text())
    assert {'missing_effect', 'candidates', 'gap_before', 'gap_after', 'added_parameters'} <= set(result)
    assert result['missing_effect'] == 'coulomb_friction' and result['warnings'] == []   # a plausible actuator
    assert result['added_parameters']['coulomb_force'] == pytest.approx(1.0, rel=0.1)
    assert result['gap_after']['position'] < 0.5 * result['gap_before']['position']
    for candidate in result['candidates']:
        assert set(candidate) == {'effect', 'score', 'significant', 'evidence'}
    names = {c['effect'] for c in result['candidates']}
    assert names == set(EFFECTS)   # every effect of the physics layer is a candidate
    report = tmp_path / 'report'
    text = (report / 'report.md').read_text()
    for figure in ('gap.png', 'residuals.png', 'correlation.png', 'disagreement.png'):
        assert (report / figure).stat().st_size > 10_000
        assert f'({figure})' in text
    assert json.loads((report / 'diagnosis.json').read_text()) == result
    assert [p.name for p in report.iterdir() if p.name.startswith('.')] == ['.emla-output']


def test_cli_mechanical_only_csv_to_stdout(tmp_path):
    recording = example_recording()
    force = Recording(recording.sample_period, {'force': 10.8 * recording.signals['current'],
                                                'position': recording.signals['position']})
    write_csv(force, tmp_path / 'force.csv')
    out = emla('discrepancy', tmp_path / 'force.csv')
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert result['missing_effect'] == 'coulomb_friction'
    assert set(result['gap_before']) == {'position'}


@pytest.mark.parametrize('make, message', [
    (lambda d: d / 'missing.csv', 'no such file'),
    (lambda d: (d / 'x.csv').write_text('t,voltage\n0,1\n1e-4,2\n') and d / 'x.csv', 'needs columns'),
    (lambda d: (d / 'plain').mkdir() or d / 'plain', 'not a rosbag2 directory'),  # beside the outputs, not holding them
])
def test_cli_bad_input_is_one_line_and_exit_2(tmp_path, make, message):
    out = emla('discrepancy', make(tmp_path), '--json', tmp_path / 'out.json', '--report', tmp_path / 'r')
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1 and message in out.stderr
    assert not (tmp_path / 'out.json').exists() and not (tmp_path / 'r').exists()


def test_cli_unknown_candidate_is_refused():
    out = emla('discrepancy', EXAMPLE, '--candidates', 'coulomb_friction,gremlins')
    assert out.returncode == 2 and 'gremlins' in out.stderr


if __name__ == '__main__':
    shutil.rmtree(EXAMPLE, ignore_errors=True)
    write_example(EXAMPLE)
    print(f'wrote {EXAMPLE}')
