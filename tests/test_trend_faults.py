"""`emla trend` when its cluster fails (issue 53, "Nothing lost, round 2"): a scheduler lost mid-run, an address
that accepts but never answers, the only worker killed, a tls:// address without certificates; and outputs
checked against every recording a glob expands to. Each ends in one line (exit 2) with the results so far in
the --table checkpoint, which --resume goes on from; nothing is listed as failed that did not fail.

Every cluster is a real `dask scheduler` and `dask worker` on 127.0.0.1 (random free ports), bounded by
timeouts and killed at the end of its test. The kill comes from inside the run (trend's progress hook in a
wrapper process) once two recordings are done, so that it is mid-run every time."""
import hashlib
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from contextlib import contextmanager

import pytest
from loopback import free_port, wait_for_port
from ros_isolation import REPO, VENV_BIN

from emla_identification.fleet import read_table

RECORD = REPO / 'docs' / 'examples' / 'logger.csv'   # a short moving-coil record (3000 samples)
COUNT = 6
ENV = {**os.environ, 'OPENBLAS_NUM_THREADS': '1', 'OMP_NUM_THREADS': '1', 'MKL_NUM_THREADS': '1'}

# `emla trend` with trend's progress hook killing EMLA_KILL_PID once EMLA_KILL_AT recordings are done, and
# WORKERS_TIMEOUT set from EMLA_WORKERS_TIMEOUT (the 60 s of a real run made short).
WRAPPER = """
import os, signal, sys
import emla_cli.commands.trend as command
import emla_identification.fleet.run as run
if os.environ.get('EMLA_WORKERS_TIMEOUT'):
    run.WORKERS_TIMEOUT = float(os.environ['EMLA_WORKERS_TIMEOUT'])
plain = command._progress

class killing(plain):
    def __call__(self, done, total, failed):
        super().__call__(done, total, failed)
        if done >= int(os.environ['EMLA_KILL_AT']) and not getattr(killing, 'killed', False):
            killing.killed = True
            os.kill(int(os.environ['EMLA_KILL_PID']), signal.SIGKILL)

command._progress = killing
from emla_cli.cli import main
sys.exit(main(['trend', *sys.argv[1:]]))
"""


def emla(*args, cwd=None, timeout=60):
    return subprocess.run([str(VENV_BIN / 'emla'), 'trend', *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, cwd=cwd, env=ENV)


def killing_emla(*args, pid, at=2, workers_timeout=None, cwd=None, timeout=60):
    env = {**ENV, 'EMLA_KILL_PID': str(pid), 'EMLA_KILL_AT': str(at)}
    if workers_timeout is not None:
        env['EMLA_WORKERS_TIMEOUT'] = str(workers_timeout)
    return subprocess.run([sys.executable, '-c', WRAPPER, *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, cwd=cwd, env=env)


def one_line_error(out, *words):
    """The one stderr line of a refusal (exit 2, nothing on stdout, no traceback), checked for `words`."""
    assert out.returncode == 2, out
    assert out.stdout == '', out
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('emla trend: error: '), out.stderr
    assert 'Traceback' not in out.stderr
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


@pytest.fixture
def records(tmp_path):
    """COUNT copies of the short record in tmp_path/runs."""
    runs = tmp_path / 'runs'
    runs.mkdir()
    for k in range(COUNT):
        shutil.copy(RECORD, runs / f'r{k}.csv')
    return runs


@contextmanager
def dask_cluster(folder):
    """`dask scheduler` and one `dask worker` (no nanny: a killed worker stays dead) on 127.0.0.1; (address,
    scheduler process, worker process); both killed at the end, whatever happened."""
    port = free_port()
    address = f'tcp://127.0.0.1:{port}'
    dask = str(VENV_BIN / 'dask')
    log = open(folder / 'cluster.log', 'w')
    processes = []
    try:
        processes.append(subprocess.Popen([dask, 'scheduler', '--host', '127.0.0.1', '--port', str(port),
                                           '--no-dashboard', '--idle-timeout', '120'], stdout=log, stderr=log,
                                          env=ENV, start_new_session=True))
        wait_for_port(port, timeout=30)
        processes.append(subprocess.Popen([dask, 'worker', address, '--host', '127.0.0.1', '--nthreads', '1',
                                           '--no-nanny', '--no-dashboard', '--death-timeout', '30'], stdout=log,
                                          stderr=log, env=ENV, start_new_session=True))
        from distributed import Client
        with Client(address, timeout=30, set_as_default=False) as client:
            client.wait_for_workers(1, timeout=60)
        yield address, processes[0], processes[1]
    finally:
        for process in processes:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
        for process in processes:
            process.wait(timeout=10)
        log.close()


@contextmanager
def silent_server():
    """A TCP server on 127.0.0.1 that accepts every connection and never says a word; its address."""
    server = socket.socket()
    server.bind(('127.0.0.1', 0))
    server.listen(16)
    server.settimeout(0.2)
    held, stop = [], threading.Event()

    def accept():
        while not stop.is_set():
            try:
                held.append(server.accept()[0])
            except OSError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        yield server.getsockname()[1]
    finally:
        stop.set()
        thread.join(timeout=5)
        for connection in held:
            connection.close()
        server.close()


def _kept(out, table):
    """The count of recordings the one line says are done, checked against the table: every one identified there,
    none of them listed as failed, the rest 'not done'."""
    line = one_line_error(out, 'not done', f'--table {table}', '--resume')
    assert 'failed' not in line.lower() and 'Cancelled' not in line
    counts = re.search(rf'; (\d+) of {COUNT} recordings done, (\d+) not done; ', line)
    assert counts, line
    done = int(counts[1])
    assert int(counts[2]) == COUNT - done
    assert 2 <= done < COUNT
    rows = read_table(table)
    assert rows.num_rows == done
    return done


# ---- 1: the scheduler dies mid-run ----

def test_a_scheduler_lost_mid_run_ends_in_one_line_with_the_table_kept_and_resume_goes_on(records, tmp_path):
    table = tmp_path / 't.csv'
    with dask_cluster(tmp_path) as (address, scheduler, _worker):
        started = time.monotonic()
        out = killing_emla(records, '--scheduler', address, '--table', table, '--json', tmp_path / 'o.json',
                           pid=scheduler.pid)
        seconds = time.monotonic() - started
    assert scheduler.returncode == -signal.SIGKILL
    done = _kept(out, table)
    assert 'the scheduler was lost' in out.stderr and f'--scheduler {address}' in out.stderr
    assert not (tmp_path / 'o.json').exists()     # no result claiming to be the whole
    assert seconds < 40
    out = emla(records, '--workers', '1', '--resume', '--table', table, '--json', tmp_path / 'o.json')
    assert out.returncode == 0, out.stderr
    assert f'{COUNT} recordings identified, 0 failed, {done} from the table (--resume)' in out.stderr
    assert read_table(table).num_rows == COUNT


# ---- 2: an address that accepts and never answers ----

def test_a_scheduler_that_accepts_but_never_answers_ends_in_one_line_within_the_connect_timeout(records):
    with silent_server() as port:
        started = time.monotonic()
        out = emla(records, '--scheduler', f'tcp://127.0.0.1:{port}', timeout=60)
        seconds = time.monotonic() - started
    one_line_error(out, f'--scheduler tcp://127.0.0.1:{port}', 'no answer within 10 s')
    assert seconds < 30


# ---- 3: the only worker killed mid-run ----

def test_the_only_worker_killed_ends_after_the_no_worker_timeout_with_the_table_kept(records, tmp_path):
    table = tmp_path / 't.parquet'
    with dask_cluster(tmp_path) as (address, _scheduler, worker):
        started = time.monotonic()
        out = killing_emla(records, '--scheduler', address, '--table', table, pid=worker.pid, workers_timeout=3)
        seconds = time.monotonic() - started
        assert worker.wait(timeout=10) == -signal.SIGKILL
    _kept(out, table)
    assert 'no worker has been connected for 3 s' in out.stderr
    assert seconds < 40


# ---- 4: tls:// ----

def test_tls_with_nothing_listening_is_one_line():
    started = time.monotonic()
    out = emla(RECORD, '--scheduler', 'tls://127.0.0.1:1', timeout=60)
    one_line_error(out, '--scheduler tls://127.0.0.1:1', 'cannot connect')
    assert time.monotonic() - started < 10


def test_tls_without_certificates_is_one_line():
    with silent_server() as port:
        started = time.monotonic()
        out = emla(RECORD, '--scheduler', f'tls://127.0.0.1:{port}', timeout=60)
        assert time.monotonic() - started < 30
    one_line_error(out, f'--scheduler tls://127.0.0.1:{port}', 'TLS needs certificates')


# ---- 5: an output on a recording a glob matches ----

def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.parametrize('flag', ['--table', '--json', '--plot'])
def test_an_output_on_a_file_a_glob_matches_is_refused_before_any_work(tmp_path, flag):
    folder = tmp_path / 'g'
    folder.mkdir()
    for name in ('r0.csv', 'r1.csv'):
        shutil.copy(RECORD, folder / name)
    before = _digest(folder / 'r1.csv')
    started = time.monotonic()
    out = emla('g/*.csv', flag, 'g/r1.csv', '--force', cwd=tmp_path)
    one_line_error(out, f'{flag} g/r1.csv', 'the input g/r1.csv')
    assert time.monotonic() - started < 20      # refused before any work (no cluster started)
    assert _digest(folder / 'r1.csv') == before
    assert sorted(p.name for p in folder.iterdir()) == ['r0.csv', 'r1.csv']


def test_an_output_inside_a_directory_a_glob_matches_is_refused(tmp_path):
    (tmp_path / 'fleet' / 'a').mkdir(parents=True)
    shutil.copy(RECORD, tmp_path / 'fleet' / 'a' / 'r0.csv')
    out = emla('fleet/*', '--table', 'fleet/a/new.parquet', cwd=tmp_path)
    one_line_error(out, '--table fleet/a/new.parquet', 'inside the input fleet/a')
    assert not (tmp_path / 'fleet' / 'a' / 'new.parquet').exists()


if __name__ == '__main__':
    sys.exit(pytest.main([__file__, '-q']))
