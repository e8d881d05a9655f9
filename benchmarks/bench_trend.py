"""emla trend: recordings identified per second on the embedded Dask cluster with 1 and 2 workers, their ratio,
and each worker's peak memory (RSS). 40 recordings of 0.5 s at 10 kHz (Table 1 under a PID loop, emla_sim), R
rising over them; the cluster's start-up is timed apart."""
import logging
import os
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.harness import Row
from emla_core.parameters import TABLE1
from emla_sim.datasets import closed_loop

RECORDINGS = 40


def _peak_rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _fleet(directory):
    for k in range(RECORDINGS):
        recording, _ = closed_loop(TABLE1.scaled(resistance=1.0 + 0.2 * k / RECORDINGS), duration=0.5,
                                   dither=0.2, seed=k)
        s = recording.signals
        table = np.column_stack((3600.0 * k + recording.time, s['voltage'], s['current'], s['position']))
        np.savetxt(directory / f'run_{k:03d}.csv', table, delimiter=',', header='t,voltage,current,position',
                   comments='', fmt='%.15g')


def _measure(directory, workers):
    from distributed import Client, LocalCluster

    from emla_identification.fleet import trend
    start = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host='127.0.0.1',
                      dashboard_address=None, scheduler_kwargs={'dashboard': False},
                      silence_logs=logging.ERROR) as cluster, Client(cluster, set_as_default=False) as client:
        client.run(lambda: __import__('emla_identification.greybox'))   # imports outside the timing
        startup = time.perf_counter() - start
        result = trend([directory], client=client)
        rss = client.run(_peak_rss_mb)
    assert not result.failed and len(result.recordings) == RECORDINGS
    return RECORDINGS / result.seconds, startup, max(rss.values())


def run():
    with tempfile.TemporaryDirectory() as folder:
        directory = Path(folder)
        _fleet(directory)
        one, start_one, rss_one = _measure(directory, 1)
        two, start_two, rss_two = _measure(directory, 2)
    cores = len(os.sched_getaffinity(0))
    return [
        Row(f'emla trend, {RECORDINGS} recordings of 0.5 s at 10 kHz, 1 worker', one, 'recordings/s',
            note=f'cluster start {start_one:.1f} s (apart); peak RSS per worker {rss_one:.0f} MB'),
        Row(f'emla trend, the same, 2 workers ({cores} cores)', two, 'recordings/s', baseline=one,
            baseline_name='1 worker', note=f'cluster start {start_two:.1f} s; peak RSS per worker {rss_two:.0f} MB'),
    ]
