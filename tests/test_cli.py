"""The `emla` entry point of the venv."""
import subprocess

from ros_isolation import VENV_BIN


def emla(*args):
    return subprocess.run([str(VENV_BIN / 'emla'), *args], capture_output=True, text=True, timeout=120)


def test_version_and_help():
    assert emla('--version').stdout.startswith('emla 0.1.0')
    out = emla('--help')
    assert out.returncode == 0
    for command in ('identify', 'discrepancy', 'import', 'launch', 'simulate', 'scenario', 'play', 'echo', 'run'):
        assert command in out.stdout


def test_unknown_command_is_one_clear_error():
    out = emla('frobnicate')
    assert out.returncode != 0 and 'Traceback' not in out.stderr


def test_simulate_and_launch_refuse_to_write_over_a_directory_in_one_line(tmp_path):
    """A bag directory that is not empty is refused before anything runs; --force replaces a bag only."""
    bag, other = tmp_path / 'bag', tmp_path / 'notes'
    assert emla('simulate', '--duration', '0.02', '--bag', str(bag)).returncode == 0
    other.mkdir()
    (other / 'keep.txt').write_text('mine')
    for command in ('simulate', 'launch'):
        for directory, flags in ((bag, ()), (other, ('--force',))):
            out = emla(command, '--duration', '0.02', '--bag', str(directory), *flags)
            assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1, out.stderr
            assert str(directory) in out.stderr and 'Traceback' not in out.stderr
    assert (other / 'keep.txt').read_text() == 'mine'
    assert emla('simulate', '--duration', '0.02', '--bag', str(bag), '--force').returncode == 0
