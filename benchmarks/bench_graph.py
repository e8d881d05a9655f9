"""The launched ROS 2 graph: real-time factor of `emla launch` at 10 kHz sampling and the CPU time all its
processes spend per simulated second (medians over LAUNCHES launches, start-up excluded: see `emla launch`), and
the identifier node's CPU use when a recorded 10 kHz run is played into it at real time."""
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from benchmarks.harness import Row
from emla_cli.launcher import cpu_seconds, domain_env, reserved_domain

EMLA = str(Path(sys.executable).parent / 'emla')
DURATION = 2.0    # s simulated in each launch
LAUNCHES = 3      # the machine's speed wanders from run to run: the median of these, with the spread
PLAYED = 5.0      # s of recording played into the identifier


def launch_rows(work):
    runs = []
    for k in range(LAUNCHES):
        summary = work / f'launch{k}.json'
        subprocess.run([EMLA, 'launch', 'default', '--duration', str(DURATION), '--bag', str(work / f'launch{k}'),
                        '--json', str(summary)], check=True, capture_output=True, timeout=600)
        runs.append(json.loads(summary.read_text()))
    rtf = [run['realtime_factor'] for run in runs]
    cpu = [run['cpu_per_simulated_second'] for run in runs]
    total = [c['total'] for c in cpu]
    processes = ', '.join(f'{name} {statistics.median(c[name] for c in cpu):.2f}' for name in cpu[0] if name != 'total')
    graph = 'ROS graph, emla launch (4 nodes + recorder), 10 kHz, 1 ms control period'
    return [Row(f'{graph}: real-time factor', statistics.median(rtf), 'x real time', target='>= 1x',
                met=statistics.median(rtf) >= 1,
                note=f'median of {LAUNCHES} launches of {DURATION:g} s simulated, {min(rtf):.2f}-{max(rtf):.2f}x; '
                     f'{statistics.median(run["wall_time"] for run in runs):.1f} s wall with start-up and stop'),
            Row(f'{graph}: CPU time of all its processes', statistics.median(total), 's per simulated s',
                target='<= 1.5', met=statistics.median(total) <= 1.5,
                note=f'{min(total):.2f}-{max(total):.2f} over the launches; median per process: {processes}')]


def identifier_rows(work):
    bag = work / 'played'
    subprocess.run([EMLA, 'simulate', '--duration', str(PLAYED), '--bag', str(bag)], check=True,
                   capture_output=True, timeout=600)
    params = work / 'identifier.yaml'
    params.write_text(yaml.safe_dump({'/emla/identifier': {'ros__parameters': {'use_sim_time': True}}}))
    with reserved_domain() as domain:
        env = domain_env(domain)
        node = subprocess.Popen([EMLA, 'run', 'identifier', '--params-file', str(params)], env=env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            time.sleep(3.0)                       # imports and discovery, outside the measurement
            before, start = cpu_seconds(node.pid), time.monotonic()
            subprocess.run([EMLA, 'play', str(bag), '--rate', '1', '--wait', '30', '--topics', '/emla/voltage',
                            '/emla/current', '/emla/position'], env=env, check=True, capture_output=True,
                           timeout=600)
            cpu, wall = cpu_seconds(node.pid) - before, time.monotonic() - start
        finally:
            node.terminate()
            node.wait(timeout=30)
    share = 100 * cpu / wall
    return [Row('identifier node CPU at 10 kHz input (bag played at real time)', share, '% of a core',
                note=f'{cpu:.2f} s CPU over {wall:.1f} s of play ({PLAYED:g} s of 10 kHz data, 1 ms frames)')]


def run():
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        return launch_rows(work) + identifier_rows(work)
