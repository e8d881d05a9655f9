"""What a new user met on the command line: a mistyped option or command gets the nearest one, `emla simulate
--seed` gives another record of the same run, the launcher's progress bar stays out of log files, and data
named in the user's own way are either read or refused with what the file holds."""
import io
import subprocess
import sys

import numpy as np
import pytest
import scipy.io

from emla_cli.cli import main
from emla_cli.launcher import simulated_time_bar
from emla_core.data import load

DURATION = '0.02'   # s of a simulated scenario: 200 samples, a fraction of a second


def emla(capsys, *args):
    """(exit status, stdout, stderr) of `emla ARGS` run in this process."""
    status = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return status, out, err


def test_a_mistyped_option_is_one_line_with_the_option_meant():
    out = subprocess.run([sys.executable, '-m', 'emla_cli.cli', 'identify', 'rec.csv', '--modle', 'electrical'],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and out.stdout == ''
    assert out.stderr.endswith('\n') and len(out.stderr.splitlines()) == 1, out.stderr
    assert out.stderr.startswith('emla identify: error: unrecognized arguments: --modle electrical')
    assert 'did you mean --model?' in out.stderr and 'Traceback' not in out.stderr


@pytest.mark.parametrize('args, meant', [
    (('identfy', 'rec.csv'), 'identify'),                             # a command
    (('--verison',), '--version'),                                    # emla's own option
    (('simulate', '--durtion', '1', '--bag', 'b'), '--duration'),     # another command's option
    (('identify', 'rec.csv', '--modle=full'), '--model'),             # an option with its value
    (('identify', 'rec.csv', '--spring', 'aoto'), 'auto'),            # a choice of an option
])
def test_each_mistyped_word_gets_the_nearest_known_one(capsys, args, meant):
    status, out, err = emla(capsys, *args)
    assert status == 2 and out == '' and len(err.splitlines()) == 1, err
    assert f'did you mean {meant}?' in err, err


def test_two_mistyped_options_get_both_meant_and_a_word_like_none_gets_no_guess(capsys):
    status, _, err = emla(capsys, 'identify', 'rec.csv', '--modle', 'full', '--plto')
    assert status == 2 and 'did you mean --model, --plot?' in err, err
    status, _, err = emla(capsys, 'identify', 'rec.csv', '--zzzzzz')
    assert status == 2 and len(err.splitlines()) == 1 and 'did you mean' not in err, err
    assert 'unrecognized arguments: --zzzzzz' in err


def simulated(capsys, directory, *flags):
    """The measured record of the default scenario that `emla simulate` writes with `flags`."""
    status, _, err = emla(capsys, 'simulate', '--duration', DURATION, '--bag', directory, *flags)
    assert status == 0, err
    return load(directory)


def same(a, b):
    """Whether two records hold the same measured samples."""
    return all(np.array_equal(a.signals[name], b.signals[name]) for name in ('voltage', 'current', 'position'))


def test_another_seed_is_another_record_and_the_same_seed_the_same(capsys, tmp_path):
    one, again, two = (simulated(capsys, tmp_path / name, '--seed', seed)
                       for name, seed in (('one', 1), ('again', 1), ('two', 2)))
    assert same(one, again)
    assert not np.array_equal(one.signals['current'], two.signals['current'])
    assert not np.array_equal(one.signals['position'], two.signals['position'])


def test_without_a_seed_the_record_is_the_scenarios_as_before(capsys, tmp_path):
    """No --seed: the catalogue's scenario as it is (seed 0), so the records made before --seed are made again."""
    from emla_bench.scenarios import get
    from emla_core.topics import ESTIMATE_PERIOD
    default = simulated(capsys, tmp_path / 'default')
    assert same(default, simulated(capsys, tmp_path / 'zero', '--seed', 0))
    assert not same(default, simulated(capsys, tmp_path / 'other', '--seed', 7))
    scenario = get('default')
    run = scenario.run_case(scenario.graph_case, float(DURATION) + scenario.sample_period,
                            frame_samples=round(ESTIMATE_PERIOD / scenario.sample_period))
    measured = default.signals['current']   # the bag's samples: the run's up to its last one
    assert len(measured) > 150 and np.array_equal(measured, run.recording.signals['current'][:len(measured)])


def test_the_solenoids_seed_changes_its_excitation_and_noise_and_none_keeps_records(capsys, tmp_path):
    from emla_core.recording import write_csv
    from emla_sim.solenoid import record
    paths = {name: tmp_path / f'{name}.csv' for name in ('default', 'three', 'again')}
    for name, flags in (('default', ()), ('three', ('--seed', 3)), ('again', ('--seed', 3))):
        status, _, err = emla(capsys, 'simulate', '--actuator', 'solenoid', '--duration', '0.1',
                              '--csv', paths[name], *flags)
        assert status == 0, err
    write_csv(record(duration=0.1, sample_period=2e-4)[0], tmp_path / 'library.csv')
    assert paths['default'].read_bytes() == (tmp_path / 'library.csv').read_bytes()
    assert paths['three'].read_bytes() == paths['again'].read_bytes() != paths['default'].read_bytes()


@pytest.mark.parametrize('seed', ['-1', '1.5', 'x'])
def test_a_seed_that_is_no_natural_number_is_one_line(capsys, tmp_path, seed):
    status, _, err = emla(capsys, 'simulate', '--duration', DURATION, '--bag', tmp_path / 'b', '--seed', seed)
    assert status == 2 and len(err.splitlines()) == 1 and f'--seed {seed}: must be an integer' in err, err
    assert not (tmp_path / 'b').exists()


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_the_launchers_bar_is_drawn_on_a_terminal_only():
    """stderr redirected to a log file gets no '\\r' redraws; a terminal gets the bar."""
    for stream in (io.StringIO(), Terminal()):
        with simulated_time_bar(0.5, 'default (domain 7)', stream) as bar:
            assert bar.disable == (not stream.isatty())
            bar.update(0.25)
        assert (stream.getvalue() == '') == (not stream.isatty()), stream.getvalue()
    assert 's simulated' in stream.getvalue() and '\r' in stream.getvalue()


def test_a_mat_file_without_the_signals_names_its_vectors_and_their_lengths(capsys, tmp_path):
    t = np.arange(200) * 1e-4
    path = tmp_path / 'bench.mat'
    scipy.io.savemat(path, {'t': t, 'u_coil': np.sin(t), 'i_coil': np.cos(t), 'stroke': t[:150], 'gain': 2.0})
    for command in ('identify', 'import'):
        status, out, err = emla(capsys, command, path, *([tmp_path / 'bag'] if command == 'import' else []))
        assert status == 2 and out == '' and len(err.splitlines()) == 1, err
        assert 'no variable holds voltage, current, position or force' in err
        for shown in ('t (200 values, read as the time)', 'u_coil (200 values)', 'i_coil (200 values)',
                      'stroke (150 values)'):
            assert shown in err, err
        assert 'gain' not in err and '--columns voltage=NAME' in err


@pytest.mark.parametrize('column', ['U_coil', 'U_coil [V]'])
def test_a_column_is_mapped_by_its_header_with_or_without_its_unit(capsys, tmp_path, column):
    rows = np.column_stack([np.arange(300) * 1e-4, np.sin(np.arange(300) / 7), np.cos(np.arange(300) / 5),
                            np.arange(300) * 1e-3])
    path = tmp_path / 'logger.csv'
    np.savetxt(path, rows, delimiter=',', header='t [s],U_coil [V],I [A],x [mm]', comments='', fmt='%.10g')
    status, out, err = emla(capsys, 'import', path, tmp_path / 'bag', '--columns', f'voltage={column}')
    assert status == 0, err
    assert 'samples of voltage, current, position at' in out and 'U_coil' not in out
    imported = load(tmp_path / 'bag')
    assert np.allclose(imported.signals['voltage'], rows[:, 1])
    assert np.allclose(imported.signals['position'], rows[:, 3] * 1e-3)   # x [mm] in m
