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
