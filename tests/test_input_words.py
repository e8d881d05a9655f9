"""Words for inputs that were misleading or ended in a traceback (issue 53, "misleading words" and some
"tracebacks"): a forgetting factor whose memory is too short is named instead of a flipped current; an isolated
outlier is named before any unit or sign hint; a CSV line too long for the reader, an empty --topics, an empty
bag, a path with a name too long, a closed stdout and a topic name too long are one line each, exit 2; a
candidate given twice to `emla discrepancy` is taken once."""
import os
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from emla_cli.cli import main
from emla_core.data import load
from emla_identification.plausibility import isolated_outliers, outlier_warnings, plausibility_warnings

LOGGER = Path(__file__).resolve().parents[1] / 'docs' / 'examples' / 'logger.csv'
BAG = Path(__file__).resolve().parents[1] / 'bags' / 'example_discrepancy'


def run(capsys, *args):
    """(exit status, stdout, stderr) of `emla ARGS` in this process; never a traceback."""
    status = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert 'Traceback' not in err
    return status, out, err


def refused(capsys, *args):
    """The one stderr line of `emla ARGS`, which must exit 2."""
    status, _, err = run(capsys, *args)
    assert status == 2 and err.count('\n') == 1, err
    return err


def warnings_of(capsys, *args):
    status, _, err = run(capsys, *args)
    assert status == 0, err
    return [line.split(': warning: ', 1)[1] for line in err.splitlines() if ': warning: ' in line]


@pytest.fixture()
def record(tmp_path):
    path = tmp_path / 'run.csv'
    shutil.copy(LOGGER, path)
    return path


# 1. A forgetting factor's short memory, not a flipped signal

def test_a_short_memory_is_named_not_a_flipped_current(record, capsys):
    """--forgetting 0.5 (and 0.7) gives negative estimates on a good record: the memory of 1/(1 - lambda)
    samples is named as the cause, and no signal flip is advised."""
    for lam, memory in (('0.5', '2'), ('0.7', '3.33')):
        (warning,) = warnings_of(capsys, 'identify', record, '--forgetting', lam)
        assert f'1/(1 - {lam}) = {memory} samples' in warning and 'not a flipped signal' in warning, warning
        assert 'runs the other way round' not in warning and '--units' not in warning, warning


def test_unresolved_estimates_with_forgetting_name_the_memory(record, capsys):
    found = warnings_of(capsys, 'identify', record, '--forgetting', '0.8')
    assert any('do not resolve' in line for line in found)
    assert any('remembers only 1/(1 - 0.8) = 5 of the 3000 samples' in line for line in found), found


def test_signs_within_their_noise_are_no_sign_slip_but_significant_ones_are():
    """The pattern of a flipped current (R, L, m < 0) is advised only where the estimates are beyond 3 sigma
    and the memory is long enough."""
    record_ = SimpleNamespace(signals={'position': np.array([0.0, 2e-3])}, sample_period=1e-4)
    flipped = {'resistance': -3.2, 'inductance': -2e-3, 'emf_constant': 8.5, 'mass': -0.05, 'damping': 3.0}
    sharp = {name: abs(value) * 1e-3 for name, value in flipped.items()}
    (warning,) = plausibility_warnings(flipped, sharp, record_)
    assert 'the current runs the other way round' in warning
    (warning,) = plausibility_warnings(flipped, sharp, record_, forgetting=0.99)   # memory 100 samples
    assert 'the current runs the other way round' in warning
    (warning,) = plausibility_warnings(flipped, sharp, record_, forgetting=0.5, samples=3000)
    assert 'remembers only 1/(1 - 0.5) = 2 samples' in warning and '--units' not in warning
    noisy = {name: abs(value) for name, value in flipped.items()}   # each within 1 sigma of zero
    (warning,) = plausibility_warnings(flipped, noisy, record_)
    assert 'within 3 sigma of zero' in warning and '--units' not in warning


# 2. An isolated outlier is named, ahead of the unit and sign hints

def test_an_isolated_outlier_is_named_first(record, tmp_path, capsys):
    lines = record.read_text().splitlines()
    fields = lines[1500].split(',')     # data row 1500: sample 1500
    fields[1] = '1000000'
    lines[1500] = ','.join(fields)
    spiked = tmp_path / 'spike.csv'
    spiked.write_text('\n'.join(lines) + '\n')
    found = warnings_of(capsys, 'identify', spiked)
    assert found[0].startswith('the voltage has an isolated outlier'), found
    assert '1e+06 V at sample 1500 (t = 0.1499 s)' in found[0], found[0]


def test_clean_and_stepped_signals_have_no_outliers():
    assert outlier_warnings(load(LOGGER)) == []
    assert outlier_warnings(load(BAG)) == []
    rng = np.random.default_rng(0)
    steps = np.repeat(rng.uniform(-10, 10, 50), 20) + 0.01 * rng.normal(size=1000)    # steps and noise
    assert isolated_outliers(steps).size == 0
    assert isolated_outliers(rng.normal(size=1000)).size == 0                         # noise alone
    steps[321] = 1e3
    assert list(isolated_outliers(steps)) == [321]


# 3. A line too long for the CSV reader

def test_a_line_longer_than_the_reader_takes_is_named(record, tmp_path, capsys):
    lines = record.read_text().splitlines()
    lines[10] += ',' + 'x' * (3 << 20)
    path = tmp_path / 'long.csv'
    path.write_text('\n'.join(lines) + '\n')
    err = refused(capsys, 'identify', path)
    assert f'line 11 has {len(lines[10]):,} bytes, more than the 1 MiB a line may have' in err, err
    assert 'straddl' not in err


# 4. An empty --topics, an empty bag

def test_an_empty_topics_flag_says_so(record, capsys):
    for flag, value, target in (('--topics', '', BAG), ('--topics', ' , ', BAG), ('--columns', '', record),
                                ('--units', '', record)):
        err = refused(capsys, 'identify', target, flag, value)
        assert f'{flag} {value!r} is empty' in err and 'unreadable' not in err, err


def _empty_bag(path, topics=()):
    from rosbags.rosbag2 import StoragePlugin, Writer

    from emla_core.bag.schema import typestore
    writer = Writer(path, version=8, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    for topic, msgtype in topics:
        writer.add_connection(topic, msgtype, typestore=typestore())
    writer.close()
    return path


def test_an_empty_bag_says_it_holds_nothing(tmp_path, capsys):
    empty = _empty_bag(tmp_path / 'empty')
    for args in ((), ('--topics', 'voltage=/v,current=/i,position=/x')):
        err = refused(capsys, 'identify', empty, *args)
        assert 'the bag holds no topics (and no messages)' in err and 'its topics: ;' not in err, err
    quiet = _empty_bag(tmp_path / 'quiet', [('/drive/u', 'std_msgs/msg/Float64')])
    err = refused(capsys, 'identify', quiet)
    assert 'the bag holds no messages' in err and 'map them' not in err, err
    frames = _empty_bag(tmp_path / 'frames', [(f'/emla/{n}', 'emla_msgs/msg/SampleFrame')
                                              for n in ('voltage', 'current', 'position')])
    for command in ('identify', 'discrepancy'):
        assert 'no SampleFrame messages under /emla/' in refused(capsys, command, frames)


# 5. A name too long, a closed stdout, a topic name too long

def test_a_path_with_a_name_too_long_is_one_line(tmp_path, capsys):
    long = 'a' * 300
    for path in (tmp_path / f'{long}.csv', tmp_path / long / 'run.csv'):
        for command in ('identify', 'discrepancy', 'play'):
            err = refused(capsys, command, path)
            assert 'a name in it has 30' in err and 'more than the 255 a file name may have' in err, err


def test_a_closed_stdout_is_one_line(record):
    def closed(*args):
        return subprocess.run([sys.executable, '-m', 'emla_cli.cli', *map(str, args)], stdout=None,
                              stderr=subprocess.PIPE, text=True, timeout=120, env=dict(os.environ),
                              preexec_fn=lambda: os.close(1))
    done = closed('identify', record)
    assert done.returncode == 2 and done.stderr == 'emla identify: error: cannot write to stdout: stdout is closed\n'
    done = closed('identify', record, '--json', record.with_name('out.json'))   # stdout not needed: fine
    assert done.returncode == 0 and 'Traceback' not in done.stderr and record.with_name('out.json').exists()


def test_a_topic_name_too_long_is_one_line(capsys):
    err = refused(capsys, 'echo', '/emla/' + 'x' * 300)
    assert '(306 characters) is not a topic name: topic length should not exceed 247 characters' in err, err


# 6. A candidate given twice is fitted once

def test_candidates_given_twice_are_taken_once(record, monkeypatch, capsys):
    import emla_identification.discrepancy as discrepancy
    from emla_core.errors import InputError
    taken = []

    def diagnose(recording, names, progress=None):
        taken.append(names)
        raise InputError('stopped before the workflow')
    monkeypatch.setattr(discrepancy, 'diagnose', diagnose)
    refused(capsys, 'discrepancy', record, '--candidates', ','.join(['coulomb_friction'] * 200))
    refused(capsys, 'discrepancy', record, '--candidates', 'return_spring,coulomb_friction,return_spring')
    assert taken == [['coulomb_friction'], ['return_spring', 'coulomb_friction']]
    assert '(none given)' in refused(capsys, 'discrepancy', record, '--candidates', '')
    from emla_identification.discrepancy.candidates import library
    data = SimpleNamespace(kinds=('electrical', 'mechanical'))
    assert [c.name for c in library(data, ['coulomb_friction'] * 5)] == ['coulomb_friction']
