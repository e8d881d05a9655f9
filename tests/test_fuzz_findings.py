"""Inputs the fuzz sweeps (tests/test_fuzz.py, `make sweep`) found, kept as tests: each is refused in one line
(exit 2) or handled, and quickly, where it hung or raised."""
import subprocess
import sys
import time

import pytest

from emla_core.parameters import TABLE1
from emla_core.recording import write_csv
from emla_sim.datasets import closed_loop


def emla(*args, timeout=60):
    return subprocess.run([sys.executable, '-m', 'emla_cli.cli', *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)


@pytest.fixture(scope='module')
def run(tmp_path_factory):
    folder = tmp_path_factory.mktemp('findings')
    recording, _ = closed_loop(TABLE1, duration=0.2, seed=1)
    write_csv(recording, folder / 'run.csv', ['voltage', 'current', 'position'])
    write_csv(recording, folder / 'untimed.csv', ['voltage', 'current', 'position'])
    lines = (folder / 'untimed.csv').read_text().splitlines()
    (folder / 'untimed.csv').write_text('\n'.join(','.join(line.split(',')[1:]) for line in lines) + '\n')
    assert emla('identify', folder / 'run.csv', '--model-out', folder / 'm.yaml').returncode == 0
    return folder


def test_a_sample_period_beside_a_time_column_is_refused(run):
    out = emla('identify', run / 'run.csv', '--sample-period', '1e-3')
    assert out.returncode == 2 and "column 't' holds the time" in out.stderr and out.stderr.count('\n') == 1


def test_a_prediction_horizon_beyond_the_record_ends_at_once(run):
    """5 L/R at a sample period of 1 ns is 3.2 million samples ahead of a 2000-sample record: nothing to
    predict (the figures are null with a warning), where it looped 3 million times."""
    start = time.monotonic()
    out = emla('compare', run / 'untimed.csv', '--model-file', run / 'm.yaml', '--sample-period', '1e-9')
    assert out.returncode in (0, 2) and 'Traceback' not in out.stderr
    assert time.monotonic() - start < 30


def test_model_file_effects_that_are_not_a_list_are_one_line(run, tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('emla_model: 1\nsample_period: 1e-4\neffects: 1\n')
    out = emla('identify', run / 'run.csv', '--model-file', bad)
    assert out.returncode == 2 and 'effects must be a list' in out.stderr and out.stderr.count('\n') == 1


def test_bag_custom_data_with_a_yaml_alias_bomb_is_refused_at_once(run, tmp_path):
    bag = tmp_path / 'bag'
    assert emla('import', run / 'run.csv', bag).returncode == 0
    metadata = bag / 'metadata.yaml'
    bomb = 'a: &a [x, x, x, x, x, x, x, x, x]\n' + ''.join(
        f'{chr(98 + k)}: &{chr(98 + k)} [*{chr(97 + k)}, *{chr(97 + k)}, *{chr(97 + k)}, *{chr(97 + k)}, '
        f'*{chr(97 + k)}, *{chr(97 + k)}, *{chr(97 + k)}, *{chr(97 + k)}, *{chr(97 + k)}]\n' for k in range(8))
    text = metadata.read_text().replace('  custom_data:', '  custom_data:\n    bomb: *i\n    was:', 1)
    metadata.write_text(bomb + text)
    start = time.monotonic()
    out = emla('import', bag, tmp_path / 'again')
    assert out.returncode == 2 and 'custom_data' in out.stderr and out.stderr.count('\n') == 1, out.stderr
    assert time.monotonic() - start < 30
