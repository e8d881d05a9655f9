"""Helpers for tests that start ROS 2 processes: an isolated DDS domain, bounded runs, clean-up."""
import os
import signal
import subprocess
import sys
from contextlib import ExitStack, contextmanager
from pathlib import Path

from emla_cli.launcher import reserved_domain

REPO = Path(__file__).resolve().parents[1]
VENV_BIN = Path(sys.executable).parent
_held = ExitStack()      # the test run's domain lock, released when the process ends
_domain = []


def session_domain():
    """A ROS_DOMAIN_ID locked for this test run (no launch or other test run on the host takes it)."""
    if not _domain:
        _domain.append(_held.enter_context(reserved_domain()))
    return _domain[0]


def isolated_env(**extra):
    """The environment for ROS processes of this test run: own domain, discovery on this host only."""
    env = dict(os.environ)
    env['ROS_DOMAIN_ID'] = str(session_domain())
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['PYTHONUNBUFFERED'] = '1'
    env.update({k: str(v) for k, v in extra.items()})
    return env


@contextmanager
def processes():
    """Start processes with `start(args, **popen_kw)`; all are killed (SIGKILL after SIGTERM) on exit."""
    started = []

    def start(args, **kw):
        kw.setdefault('env', isolated_env())
        proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                start_new_session=True, **kw)
        started.append(proc)
        return proc

    try:
        yield start
    finally:
        for proc in started:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGTERM)
        for proc in started:
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=5)
        fastdds = VENV_BIN / 'fastdds'
        if fastdds.exists():
            subprocess.run([str(fastdds), 'shm', 'clean'], capture_output=True, timeout=30)
