"""`emla trend` and emla_identification.fleet (issue 23): many recordings identified on Dask, against the known
parameters of an independent fleet (tests/fleet_data.py); the change detector on noise and steps; the same
answer from the embedded cluster and from a real `dask scheduler` with two `dask worker` processes (one killed
mid-run); failures, --resume, the table as Parquet and CSV, bad input in one line."""
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pyarrow.parquet as pq
import pytest
from fleet_data import fleet_truth, write_fleet
from loopback import free_port, wait_for_port
from ros_isolation import VENV_BIN

from emla_identification.fleet import detect_changes, read_table, trend
from emla_identification.fleet.changes import series_changes

COUNT, STEP_AT, RISE, STEP = 12, 6, 0.1, 1.3
NAMES = ('resistance', 'inductance', 'emf_constant', 'mass', 'damping', 'load_force')
WORKER_ENV = {**os.environ, 'OPENBLAS_NUM_THREADS': '1', 'OMP_NUM_THREADS': '1', 'MKL_NUM_THREADS': '1'}


def emla(*args, cwd=None, timeout=180):
    return subprocess.run([str(VENV_BIN / 'emla'), *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, cwd=cwd, env=WORKER_ENV)


def assert_one_line_error(out, name, command='trend'):
    assert out.returncode == 2, out
    assert out.stdout == ''
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f'emla {command}: error: '), out.stderr
    assert name in lines[0] and 'Traceback' not in out.stderr


@pytest.fixture(scope='module')
def fleet(tmp_path_factory):
    """12 recordings of 0.3 s at 5 kHz, one an hour: R rising 10 % (thermal time 30 h), damping x1.3 from #6."""
    truths = fleet_truth(COUNT, rise=RISE, step_at=STEP_AT, step=STEP)
    directory = tmp_path_factory.mktemp('fleet')
    return directory, write_fleet(directory, truths), truths


@pytest.fixture(scope='module')
def embedded(fleet):
    """The fleet trended on the embedded LocalCluster (2 workers)."""
    directory, _, _ = fleet
    return trend([directory], workers=2)


@pytest.fixture(scope='module')
def cluster(tmp_path_factory):
    """A real dask.distributed cluster on localhost: `dask scheduler` and two `dask worker` processes (no nanny,
    one thread each), random free ports; (address, worker processes); all killed at the end."""
    folder = tmp_path_factory.mktemp('cluster')
    port = free_port()
    address = f'tcp://127.0.0.1:{port}'
    dask = str(VENV_BIN / 'dask')
    log = open(folder / 'cluster.log', 'w')
    processes = [subprocess.Popen([dask, 'scheduler', '--host', '127.0.0.1', '--port', str(port), '--no-dashboard',
                                   '--idle-timeout', '300'], stdout=log, stderr=log, env=WORKER_ENV,
                                  start_new_session=True)]
    try:
        wait_for_port(port, timeout=30)
        workers = [subprocess.Popen([dask, 'worker', address, '--host', '127.0.0.1', '--nthreads', '1', '--no-nanny',
                                     '--no-dashboard', '--death-timeout', '60'], stdout=log, stderr=log,
                                    env=WORKER_ENV, start_new_session=True) for _ in range(2)]
        processes += workers
        from distributed import Client
        with Client(address, timeout=30, set_as_default=False) as client:
            client.wait_for_workers(2, timeout=60)
        yield address, workers
    finally:
        for process in reversed(processes):   # the workers killed outright (nothing of theirs to keep)
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGTERM if process is processes[0] else signal.SIGKILL)
        for process in processes:
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait(timeout=10)
        log.close()


def _parameters(result):
    return {r['path']: r['parameters'] for r in result['recordings']}


# ---- the change detector alone, on series of known truth (no Dask, fast) ----

def test_no_change_is_found_in_noise_even_with_the_std_too_small():
    rng = np.random.default_rng(11)
    found = 0
    for trial in range(60):
        std = 0.01 * rng.uniform(0.8, 1.2, 200)
        scale = (1.0, 2.0, 4.0)[trial % 3]            # the scatter 1, 2 or 4 times the reported std
        found += len(series_changes(1.0 + scale * std * rng.standard_normal(200), std))
    assert found == 0


@pytest.mark.parametrize('size', [5.0, 20.0, 300.0])
def test_a_step_is_found_where_it_happened_and_measured(size):
    rng = np.random.default_rng(int(size))
    std = np.full(200, 0.01)
    values = 2.0 + std * rng.standard_normal(200)
    values[137:] += size * 0.01
    changes = series_changes(values, std)
    assert len(changes) == 1
    at, before, after, sigma = changes[0]
    assert abs(at - 137) <= 2
    assert after - before == pytest.approx(size * 0.01, abs=4 * 0.01)
    assert sigma == pytest.approx(size, abs=4)


def test_a_steady_drift_is_followed_not_reported():
    rng = np.random.default_rng(3)
    std = np.full(150, 0.01)
    values = 1.0 + 0.02 * np.arange(150) + std * rng.standard_normal(150)   # 2 sigma per recording, for ever
    assert series_changes(values, std) == []
    values[90:] += 0.5                                                      # and a step on top of it
    assert [c[0] for c in series_changes(values, std)] == [90]


# ---- the fleet, identified (a): truth, the step, no change where there is none ----

def test_each_recording_is_identified_within_half_a_percent_in_time_order(fleet, embedded):
    _, paths, truths = fleet
    assert [r['path'] for r in embedded.recordings] == [str(p) for p in paths]
    assert [r['start'] for r in embedded.recordings] == pytest.approx([3600.0 * k for k in range(COUNT)])
    for record, truth in zip(embedded.recordings, truths):
        assert record['duration'] == pytest.approx(0.3)
        for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping'):
            assert record['parameters'][name] == pytest.approx(truth[name], rel=5e-3), (record['path'], name)
        assert record['warnings'] == []
        assert set(record['fit']) == {'electrical', 'mechanical'}
    assert embedded.failed == [] and embedded.workers == 2 and embedded.scheduler == 'local'


def test_the_damping_step_is_the_one_change_found(fleet, embedded):
    changes = embedded.changes
    assert [c['parameter'] for c in changes] == ['damping']
    change = changes[0]
    assert abs(change['index'] - STEP_AT) <= 2
    assert change['path'] == embedded.recordings[change['index']]['path']
    assert change['before'] == pytest.approx(3.0, rel=5e-3)
    assert change['after'] == pytest.approx(3.0 * STEP, rel=5e-3)
    assert change['sigma'] > 10


def test_no_change_on_the_recordings_without_one(embedded):
    assert detect_changes(embedded.recordings[:STEP_AT]) == []     # R rising, the rest steady: nothing to report


def test_the_table_has_a_row_per_recording(embedded):
    table = embedded.table
    assert table.num_rows == COUNT
    assert table.column('path').to_pylist() == [r['path'] for r in embedded.recordings]
    for name in NAMES:
        assert table.column(name).to_pylist() == [r['parameters'][name] for r in embedded.recordings]
        assert table.column(f'{name}_std').to_pylist() == [r['std'][name] for r in embedded.recordings]
    assert table.column('warnings_count').to_pylist() == [0] * COUNT
    assert 'fit.electrical.ratio' in table.column_names


# ---- (c) the same answer on a real dask.distributed cluster, a worker killed mid-run ----

def test_a_real_cluster_gives_the_same_answer_though_a_worker_dies(fleet, embedded, cluster):
    directory, _, _ = fleet
    address, workers = cluster
    killed = []

    def progress(done, total, failed):
        if done >= 2 and not killed:        # mid-run: the other recordings are queued or running
            os.kill(workers[0].pid, signal.SIGKILL)
            killed.append(done)

    remote = trend([directory / 'run_00[0-7].csv'], scheduler=address, progress=progress)
    assert killed and killed[0] < 8
    assert workers[0].wait(timeout=10) == -signal.SIGKILL
    assert remote.failed == [] and len(remote.recordings) == 8
    assert remote.scheduler == address and remote.workers == 2
    first = embedded.recordings[:8]      # the embedded run's (all taken from `done`: nothing identified again)
    local = trend([r['path'] for r in first], done=first).to_dict()
    there = remote.to_dict()
    assert _parameters(there).keys() == _parameters(local).keys()
    for path, parameters in _parameters(local).items():
        for name, value in parameters.items():
            assert _parameters(there)[path][name] == pytest.approx(value, rel=1e-12, abs=1e-15)
    assert [(c['parameter'], c['path'], c['index']) for c in there['changes']] == \
        [(c['parameter'], c['path'], c['index']) for c in local['changes']]
    for mine, theirs in zip(local['changes'], there['changes']):
        for key in ('before', 'after', 'sigma'):
            assert theirs[key] == pytest.approx(mine[key], rel=1e-9)
    assert there['recordings'] == local['recordings'] or all(
        a['warnings'] == b['warnings'] and a['start'] == b['start'] for a, b in zip(there['recordings'],
                                                                                    local['recordings']))


# ---- (b, d) the command: a corrupt recording, --resume, Parquet and CSV, bad input ----

def test_trend_command_failures_resume_and_tables(fleet, tmp_path, cluster):
    _, paths, truths = fleet
    runs = tmp_path / 'runs'
    runs.mkdir()
    for path in paths[:3]:
        shutil.copy(path, runs)
    (runs / 'broken.csv').write_text('t,voltage,current,position\n0,1,2\n0.0002,x\n')
    out = emla('trend', runs, '--workers', '1', '--json', tmp_path / 'one.json', '--table', tmp_path / 't.parquet',
               '--plot', tmp_path / 'p.png', '--reference', '3.2@20')
    assert out.returncode == 0, out.stderr
    assert 'Traceback' not in out.stderr and 'emla trend: 3 recordings identified, 1 failed' in out.stderr
    first = json.loads((tmp_path / 'one.json').read_text())
    assert set(first) == {'recordings', 'changes', 'failed', 'scheduler', 'workers', 'seconds'}
    assert [r['path'] for r in first['recordings']] == [str(runs / p.name) for p in paths[:3]]
    assert set(first['recordings'][0]) == {'path', 'start', 'duration', 'parameters', 'std', 'fit', 'warnings'}
    assert [f['path'] for f in first['failed']] == [str(runs / 'broken.csv')]
    assert '\n' not in first['failed'][0]['error'] and 'broken.csv' in first['failed'][0]['error']
    assert pq.read_table(tmp_path / 't.parquet').num_rows == 3
    assert (tmp_path / 'p.png').stat().st_size > 10_000

    # resume: a done recording made unreadable is not identified again; a new one is; the broken one is retried
    (runs / paths[0].name).write_text('garbage\n')
    shutil.copy(paths[3], runs)
    shutil.copy(tmp_path / 't.parquet', tmp_path / 't2.parquet')
    out = emla('trend', runs, '--scheduler', cluster[0], '--resume', '--table', tmp_path / 't2.parquet',
               '--json', tmp_path / 'two.json')
    assert out.returncode == 0, out.stderr
    assert '3 from the table (--resume)' in out.stderr
    second = json.loads((tmp_path / 'two.json').read_text())
    assert [r['path'] for r in second['recordings']] == [str(runs / p.name) for p in paths[:4]]
    assert second['recordings'][:3] == first['recordings']
    assert second['recordings'][3]['parameters']['resistance'] == pytest.approx(truths[3]['resistance'], rel=5e-3)
    assert [f['path'] for f in second['failed']] == [str(runs / 'broken.csv')]
    assert read_table(tmp_path / 't2.parquet').num_rows == 4

    # the same rows as CSV, read back as the table
    out = emla('trend', runs, '--resume', '--table', tmp_path / 't.csv', '--json', tmp_path / 'three.json',
               '--scheduler', cluster[0])
    assert out.returncode == 0, out.stderr          # no table yet: every recording identified (the garbage fails)
    csv = read_table(tmp_path / 't.csv')
    assert csv.num_rows == 3
    assert csv.column('damping').to_pylist() == pytest.approx(
        [r['parameters']['damping'] for r in second['recordings'][1:]], rel=1e-15)


@pytest.mark.parametrize('args, name', [
    (['nowhere/'], 'nowhere/'),
    (['nowhere/*.csv'], 'nowhere/*.csv'),
    (['{fleet}', '--model', 'arx'], '--model'),
    (['{fleet}', '--workers', '0'], '--workers'),
    (['{fleet}', '--workers', '2', '--scheduler', 'tcp://127.0.0.1:1'], '--scheduler'),
    (['{fleet}', '--scheduler', '127.0.0.1:8786'], '--scheduler'),
    (['{fleet}', '--resume'], '--resume'),
    (['{fleet}', '--reference', '4'], '--reference'),
    (['{fleet}', '--alpha', '0.004'], '--alpha'),
    (['{fleet}', '--table', '{tmp}/t.txt'], '--table'),
    (['{fleet}', '--json', '{fleet}/run_000.csv'], '--json'),
    (['{fleet}', '--json', '{tmp}/missing/out.json'], '--json'),
])
def test_bad_input_is_one_line_and_exit_2(fleet, tmp_path, args, name):
    directory, _, _ = fleet
    args = [a.format(fleet=directory, tmp=tmp_path) for a in args]
    assert_one_line_error(emla('trend', *args, timeout=60), name)


def test_an_unreachable_scheduler_is_one_line(fleet):
    directory, _, _ = fleet
    started = time.monotonic()
    out = emla('trend', directory, '--scheduler', f'tcp://127.0.0.1:{free_port()}', timeout=120)
    assert_one_line_error(out, 'cannot connect')
    assert time.monotonic() - started < 100


if __name__ == '__main__':
    sys.exit(pytest.main([__file__, '-q']))


def test_simulate_fleet_writes_a_long_run_stamped_by_hour_with_its_truth(tmp_path):
    import yaml

    from emla_bench.fleet import long_run
    from emla_core.data import load
    from emla_core.parameters import TABLE1
    schedule = long_run(TABLE1, 3, 1, resistance_rise=0.2, thermal_time=2.0, steps=())
    assert [start for start, _ in schedule] == [0.0, 3600.0, 7200.0]
    assert [p.resistance for _, p in schedule] == pytest.approx([4.0 * (1 + 0.2 * (1 - np.exp(-h / 2)))
                                                                 for h in range(3)])
    out = emla('simulate', '--fleet', tmp_path / 'fleet', '--hours', '2', '--duration', '0.05', '--thermal-time', '2',
               '--resistance-rise', '0.2', '--step', 'damping=1.5@1')
    assert out.returncode == 0, out.stderr
    manifest = yaml.safe_load((tmp_path / 'fleet' / 'fleet.yaml').read_text())
    assert [r['truth']['damping'] for r in manifest['recordings']] == pytest.approx([2.0, 3.0])
    assert [r['truth']['resistance'] for r in manifest['recordings']] == pytest.approx(
        [p.resistance for _, p in schedule[:2]])
    for k, entry in enumerate(manifest['recordings']):
        recording = load(tmp_path / 'fleet' / entry['bag'])
        assert recording.start_time == pytest.approx(3600.0 * k, abs=1e-6)
        assert float(recording.metadata['true_resistance']) == pytest.approx(entry['truth']['resistance'])
    assert_one_line_error(emla('simulate', '--bag', tmp_path / 'b', '--step', 'damping=2@1'), '--step', 'simulate')
