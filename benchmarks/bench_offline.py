"""Offline re-identification of a long record (issue #7): 10 minutes at 10 kHz (6 M samples), full model (electrical
and mechanical regressions, parameters and uncertainties), part by part (emla_identification.streaming) from a bag
and from arrays in memory, against the per-sample loop (OnlineIdentifier fed frames of 100 samples) and the
whole-record path (read_bag + greybox.identify); memory for 1 M and 6 M samples.

Data: TABLE1's plant (Plant.run, exact ZOH) in open loop under a zero-mean random-step voltage (each level held
2 ms, then its negative, so the position stays bounded), sensed by Sensor (5 mA, 1 um); generated once and cached in
CACHE as bags of 100-sample frames and .npy arrays.

Every figure comes from a fresh process with one BLAS thread (as `emla` runs): throughput is samples per CPU second
(time.process_time, best of REPEATS; the machine is shared, wall time in the note); memory is that process's peak
RSS (VmHWM) and, in a second run, the tracemalloc peak of the identification itself (numpy reports its arrays).
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from benchmarks.harness import Row

VERSION = 'v1'  # change when the data below change
CACHE = Path(tempfile.gettempdir()) / f'emla-bench-offline-{VERSION}'
SAMPLES, SMALL = 6_000_000, 1_000_000
SAMPLE_PERIOD = 1e-4
FRAME = 100
REPEATS = 3
TARGET = 5e6  # samples/s


def run():
    _prepare()
    # One throw-away run fills numba's on-disk cache (empty after a reinstall): otherwise the first measured
    # process also compiles, and its RSS carries the compiler's memory.
    _child('stream-bag', SMALL, repeats=1, trace=False)
    stream_bag = _child('stream-bag', SAMPLES)
    stream_memory = _child('stream-memory', SAMPLES)
    online = _child('online', SMALL, repeats=1)
    whole = {n: _child('whole', n, repeats=1, trace=n == SMALL) for n in (SMALL, SAMPLES)}
    small_bag = _child('stream-bag', SMALL)
    anchor = 'OnlineIdentifier, frames of 100'

    def rate(result):
        return result['samples'] / result['cpu']

    def timing(result):
        return f'{result["samples"] / result["wall"] / 1e6:.2f} M samples/s wall'

    rows = [Row(f'offline re-identification, full model, {label}, 6 M samples', rate(r) / 1e6, 'M samples/s',
                rate(online) / 1e6, anchor, '>= 5 M samples/s', rate(r) >= TARGET, timing(r))
            for label, r in (('streamed from a bag (100-sample frames)', stream_bag),
                             ('streamed from arrays in memory', stream_memory))]
    rows.append(Row('per-sample loop: OnlineIdentifier, frames of 100, 1 M samples', rate(online) / 1e6,
                    'M samples/s', note=timing(online)))
    rows += [Row(f'whole record: read_bag + greybox.identify, {n // 10**6} M samples', rate(r) / 1e6, 'M samples/s',
                 rate(online) / 1e6, anchor, note=timing(r)) for n, r in whole.items()]
    growth = stream_bag['rss'] / small_bag['rss']
    rows += [
        Row('peak RSS, streamed from a bag, 1 M samples', small_bag['rss'], 'MB',
            note=f'tracemalloc peak {small_bag["traced"]:.1f} MB'),
        Row('peak RSS, streamed from a bag, 6 M samples', stream_bag['rss'], 'MB', small_bag['rss'], '1 M samples',
            'bounded memory (6 M / 1 M <= 1.1)', growth <= 1.1,
            f'tracemalloc peak {stream_bag["traced"]:.1f} MB (1 M: {small_bag["traced"]:.1f} MB)'),
        Row('peak RSS, streamed from arrays in memory, 6 M samples', stream_memory['rss'], 'MB',
            note=f'holds the 144 MB of arrays; identification tracemalloc peak {stream_memory["traced"]:.1f} MB'),
        Row('peak RSS, per-sample loop (OnlineIdentifier), 1 M samples', online['rss'], 'MB',
            note='holds the 24 MB of arrays'),
    ]
    rows += [Row(f'peak RSS, whole record (read_bag + greybox.identify), {n // 10**6} M samples', r['rss'], 'MB',
                 note=f'tracemalloc peak {r["traced"]:.0f} MB' if r['traced'] else 'grows with the record')
             for n, r in whole.items()]
    return rows


def _prepare():
    """The cached data, generated if missing (into a temporary directory renamed when complete)."""
    if CACHE.exists():
        return
    from emla_core.bag import write_recording
    from emla_core.parameters import TABLE1
    from emla_core.recording import Recording
    from emla_sim.plant import Plant
    from emla_sim.sensor import Sensor, SensorConfig

    print(f'[bench] offline: generating {SAMPLES} samples into {CACHE} (once)', file=sys.stderr, flush=True)
    levels = np.random.default_rng(0).normal(0.0, 3.0, SAMPLES // 40 + 1)
    voltage = np.repeat(np.column_stack((levels, -levels)).ravel(), 20)[:SAMPLES]  # 2 ms steps, zero mean
    states = Plant(TABLE1).run(voltage, SAMPLE_PERIOD, sampling='start')
    current, position = Sensor(SensorConfig(sample_period=SAMPLE_PERIOD)).measure(states['current'],
                                                                                   states['position'])
    signals = {'voltage': states['voltage'], 'current': current, 'position': position}
    staging = Path(tempfile.mkdtemp(dir=CACHE.parent, prefix=f'.{CACHE.name}.'))
    try:
        for name, values in signals.items():
            np.save(staging / f'{name}.npy', values)
        for n in (SMALL, SAMPLES):
            part = Recording(SAMPLE_PERIOD, {k: v[:n] for k, v in signals.items()}, source='bench')
            write_recording(part, staging / f'bag-{n}', frame_size=FRAME)
        os.rename(staging, CACHE)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _child(mode, samples, repeats=REPEATS, trace=True):
    """{samples, cpu, wall, rss (MB), traced (MB or None)} of `mode` on `samples` samples, in fresh processes."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS='1')
    command = [sys.executable, '-m', 'benchmarks.bench_offline', mode, str(samples)]
    root = Path(__file__).resolve().parents[1]
    timed = json.loads(subprocess.run(command + [str(repeats)], env=env, cwd=root, check=True,
                                      capture_output=True, text=True).stdout)
    timed['traced'] = json.loads(subprocess.run(command + ['trace'], env=env, cwd=root, check=True,
                                                capture_output=True, text=True).stdout)['traced'] if trace else None
    return timed


def _work(mode, samples):
    """The function to measure; its data are loaded (not measured) and its compiled code is warmed up."""
    from emla_core.bag import iter_chunks, read_bag
    from emla_core.recording import Recording
    from emla_identification.greybox import identify
    from emla_identification.online import OnlineIdentifier
    from emla_identification.streaming import identify_chunks, split

    bag = CACHE / f'bag-{samples}'
    identify_chunks(iter_chunks(CACHE / f'bag-{SMALL}', chunk_samples=5000), points=1)  # compile, load caches
    if mode == 'stream-bag':
        return lambda: identify_chunks(iter_chunks(bag), points=1)
    if mode == 'whole':
        return lambda: identify(read_bag(bag).recording)
    signals = {name: np.load(CACHE / f'{name}.npy')[:samples] for name in ('voltage', 'current', 'position')}
    if mode == 'stream-memory':
        recording = Recording(SAMPLE_PERIOD, signals, source='bench')
        return lambda: identify_chunks(split(recording), points=1)

    def online():
        identifier = OnlineIdentifier(SAMPLE_PERIOD)
        for start in range(0, samples, FRAME):
            identifier.update(*(signals[name][start:start + FRAME] for name in ('voltage', 'current', 'position')))
        return identifier.estimate()
    return online


def _measure(mode, samples, how):
    """Run in a child: print the JSON _child reads."""
    work = _work(mode, int(samples))
    if how == 'trace':
        tracemalloc.start()
        work()
        print(json.dumps({'traced': tracemalloc.get_traced_memory()[1] / 2**20}))
        return
    cpu, wall = [], []
    for _ in range(int(how)):
        start_cpu, start_wall = time.process_time(), time.perf_counter()
        work()
        cpu.append(time.process_time() - start_cpu)
        wall.append(time.perf_counter() - start_wall)
    print(json.dumps({'samples': int(samples), 'cpu': min(cpu), 'wall': min(wall), 'rss': _peak_rss()}))


def _peak_rss():
    """This process's peak RSS in MB: VmHWM (getrusage's ru_maxrss would carry the parent's over fork and exec)."""
    with open('/proc/self/status') as status:
        return next(int(line.split()[1]) for line in status if line.startswith('VmHWM:')) / 1024


if __name__ == '__main__':
    _measure(*sys.argv[1:])
