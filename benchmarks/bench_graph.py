"""The launched ROS 2 graph: real-time factor of `emla launch` at 10 kHz sampling, and the identifier node's
CPU use when a recorded 10 kHz run is played into it at real time."""
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from benchmarks.harness import Row
from emla_cli.launcher import domain_env, reserved_domain

EMLA = str(Path(sys.executable).parent / 'emla')
DURATION = 2.0    # s simulated in the launch
PLAYED = 5.0      # s of recording played into the identifier


def cpu_seconds(pid):
    """User + system CPU time of a process so far (Linux /proc)."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    ticks = int(fields[11]) + int(fields[12])
    return ticks / __import__('os').sysconf('SC_CLK_TCK')


def launch_rows(work):
    summary = work / 'launch.json'
    subprocess.run([EMLA, 'launch', 'default', '--duration', str(DURATION), '--bag', str(work / 'launch'),
                    '--json', str(summary)], check=True, capture_output=True, timeout=600)
    result = json.loads(summary.read_text())
    rtf = result['realtime_factor']
    return [Row('ROS graph, emla launch (4 nodes + recorder), 10 kHz, 1 ms control period', rtf, 'x real time',
                target='>= 1x', met=rtf >= 1,
                note=f'{DURATION:g} s simulated, {result["wall_time"]:.1f} s wall with start-up and stop')]


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
