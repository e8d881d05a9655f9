"""Process orchestration for `emla launch`: an isolated DDS domain, node processes, a clean stop.

A launch holds an advisory lock on one ROS_DOMAIN_ID (a lock file per id), so parallel launches on this host
never share a domain; discovery is limited to localhost. Each node is its own process group (own session),
runs with the batch scheduling policy (see _prepare_child) and gets SIGTERM if the launcher dies; stop()
ends them with SIGINT, then SIGTERM, then SIGKILL after timeouts. The Fast DDS files in /dev/shm of the
nodes' (and the launcher's) participants are noted while they run and removed at the end where no live
process uses them: a killed node leaves its files, and even nodes that end cleanly leave their ports' files,
which `fastdds shm clean` does not find. A launcher killed itself (SIGKILL) cannot remove them: the next
launch removes, before it starts, the Fast DDS files that have not changed for STALE_SHM_AGE s and that no live
process uses.
"""
import collections
import contextlib
import ctypes
import fcntl
import math
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import yaml

from emla_core import topics
from emla_core.bag import read_bag
from emla_core.errors import InputError
from emla_core.messages import header_stamp_ns
from emla_core.topics import stamp_to_ns

# Domain ids a launch may take: 215-232 first (clear of the ids tests and users pick), then 1-101.
DOMAINS = (*range(215, 233), *range(1, 102))
BIN = Path(sys.executable).parent
SHM = Path('/dev/shm')
SHM_LOOK_PERIOD = 0.25   # s between looks at the shared-memory files of the running nodes
STALE_SHM_AGE = 60.0     # s unchanged after which a Fast DDS file no process uses is a dead launch's


@contextlib.contextmanager
def reserved_domain():
    """A ROS_DOMAIN_ID no other launch on this host holds, held until the block ends."""
    for domain in DOMAINS:
        lock = open(Path(tempfile.gettempdir()) / f'emla-ros-domain-{domain}.lock', 'w')
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.close()
            continue
        try:
            yield domain
        finally:
            lock.close()
        return
    raise InputError(f'every ROS domain id a launch may use ({len(DOMAINS)}) is taken by other launches')


def domain_env(domain):
    """The environment of a graph in `domain`: this host only, unbuffered output."""
    return {**os.environ, 'ROS_DOMAIN_ID': str(domain), 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
            'PYTHONUNBUFFERED': '1'}


def _prepare_child():
    """In the child before exec: SIGTERM when the launcher dies (Linux PR_SET_PDEATHSIG), and the batch
    scheduling policy. A batch process is not preempted by the threads it wakes: a node publishing a period's
    frames finishes before its readers run, and they then take the frames in one wake-up (half the context
    switches of the graph, some 10 % less CPU time)."""
    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)
    os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))


class NodeProcess:
    """One node process; the last lines of its output (stdout and stderr) are kept for error messages."""

    def __init__(self, name, args, env, pass_fds=()):
        self.name = name
        self.popen = subprocess.Popen(args, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, text=True, start_new_session=True,
                                      preexec_fn=_prepare_child, pass_fds=pass_fds)
        self.tail = collections.deque(maxlen=20)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.popen.stdout:
            if line.strip():
                self.tail.append(line.rstrip())

    @property
    def pid(self):
        return self.popen.pid

    def running(self):
        return self.popen.poll() is None

    def signal(self, signum):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.pid, signum)

    def last_line(self):
        if not self.running():
            self._reader.join(timeout=1.0)     # the rest of the output of a process that just ended
        return self.tail[-1] if self.tail else '(no output)'

    def describe_exit(self):
        code = self.popen.returncode
        how = f'was killed by {signal.Signals(-code).name}' if code < 0 else f'exited with status {code}'
        return f'{self.name} (pid {self.pid}) {how}: {self.last_line()}'


class Graph:
    """The node processes of one launch; use as a context manager (stops them all on exit)."""

    def __init__(self, env):
        self.env = env
        self.nodes = []
        self.shared_memory = set()   # names of the Fast DDS files in SHM the nodes had open or mapped
        self._closed = threading.Event()
        self._watcher = threading.Thread(target=self._watch, daemon=True)

    def start(self, name, args, pass_fds=()):
        node = NodeProcess(name, args, self.env, pass_fds)
        self.nodes.append(node)
        return node

    def __getitem__(self, name):
        return next(n for n in self.nodes if n.name == name)

    def cpu_times(self):
        """{process: CPU time so far, s} of the nodes and of this launcher (all threads of each)."""
        return {**{node.name: cpu_seconds(node.pid) for node in self.nodes}, 'launcher': time.process_time()}

    def stop(self, names=None, timeouts=(5.0, 3.0, 3.0)):
        """End the named nodes (all by default): SIGINT, SIGTERM, SIGKILL, each after the previous timed out."""
        nodes = [n for n in self.nodes if names is None or n.name in names]
        for signum, timeout in zip((signal.SIGINT, signal.SIGTERM, signal.SIGKILL), timeouts):
            alive = [n for n in nodes if n.running()]
            if not alive:
                break
            for node in alive:
                node.signal(signum)
            deadline = time.monotonic() + timeout
            for node in alive:
                with contextlib.suppress(subprocess.TimeoutExpired):
                    node.popen.wait(timeout=max(0.0, deadline - time.monotonic()))

    def _watch(self):
        """Note the shared-memory files of the nodes while they run (once a node is gone, they can no longer be
        told), and of this process (its participant's files outlive it too)."""
        while not self._closed.wait(SHM_LOOK_PERIOD):
            for pid in [node.pid for node in self.nodes if node.running()] + [os.getpid()]:
                self.shared_memory |= own_shm_files(pid)

    def __enter__(self):
        self._watcher.start()
        return self

    def __exit__(self, *exc):
        self.stop()
        self._closed.set()
        self._watcher.join()
        remove_unused_shm(self.shared_memory)
        return False


def cpu_seconds(pid):
    """User + system CPU time of process `pid` so far, s (NaN once it is gone)."""
    try:
        fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    except OSError:
        return math.nan
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def shm_files(pid):
    """Names of the Fast DDS files in SHM that process `pid` has open or mapped (none once it is gone)."""
    proc = Path('/proc', str(pid))
    paths = set()
    with contextlib.suppress(OSError):  # gone, or another user's
        for fd in (proc / 'fd').iterdir():
            with contextlib.suppress(OSError):  # closed meanwhile
                paths.add(os.readlink(fd))
    with contextlib.suppress(OSError):
        paths.update(line.split(maxsplit=5)[-1] for line in (proc / 'maps').read_text().splitlines())
    return {path[len(f'{SHM}/'):] for path in paths if path.startswith((f'{SHM}/fastrtps_', f'{SHM}/sem.fastrtps_'))}


def own_shm_files(pid):
    """Names of the Fast DDS files in SHM of process `pid`'s own participant (none once it is gone): the lock
    files it holds open (X_el, while X lives) and the segments and ports X they lock, which it only maps. A
    tenth of the cost of shm_files: /proc/PID/maps lists every mapping of the process."""
    proc = Path('/proc', str(pid))
    names = set()
    with contextlib.suppress(OSError):  # gone, or another user's
        for fd in (proc / 'fd').iterdir():
            with contextlib.suppress(OSError):  # closed meanwhile
                path = os.readlink(fd)
                if path.startswith(f'{SHM}/fastrtps_'):
                    names.add(path[len(f'{SHM}/'):])
    return names | {name.removesuffix('_el') for name in names}


def stale_shm_files(age=STALE_SHM_AGE):
    """Names of the Fast DDS files in SHM not modified for `age` s (a participant that is starting has new ones)."""
    now, names = time.time(), set()
    for path in SHM.glob('fastrtps_*'):
        with contextlib.suppress(OSError):  # removed meanwhile
            if now - path.stat().st_mtime > age:
                names.add(path.name)
    return names


def remove_unused_shm(names):
    """Remove the Fast DDS files `names` in SHM (with the mutex of each port) that no live process has open or
    mapped."""
    in_use = set().union(*(shm_files(proc.name) for proc in Path('/proc').iterdir() if proc.name.isdigit()))
    for name in names - in_use:
        files = [name]
        if re.fullmatch(r'fastrtps_port\d+', name) and f'sem.{name}_mutex' not in in_use:
            files.append(f'sem.{name}_mutex')  # the port's mutex, which its users open only briefly
        for file in files:
            with contextlib.suppress(OSError):  # gone already, or another user's
                (SHM / file).unlink()


# ---- a launch: the four nodes and the recorder, until the identifier's final estimate is recorded ----

NODES = ('plant', 'sensor', 'identifier', 'controller')
START_SUBSCRIBERS = 1        # of /emla/position before the plant starts: the recorder
FRAMES_SUBSCRIBERS = 2       # and of /emla/frames: the controller and the identifier (measured_frames)
DONE_SUBSCRIBERS = 3         # of /emla/plant/done: identifier, recorder and the launcher itself (a discovery
                             # late by one announcement period would otherwise miss the whole run)
STALL_TIMEOUT = 60.0         # s without simulated progress (start-up included) before the launch gives up
FINAL_TIMEOUT = 30.0         # s from the done signal to the identifier's final estimate
DONE_GRACE = 2.0             # s for the done signal of a plant that exited 0 to arrive; without it, it was stopped


class LaunchError(Exception):
    """A launch that failed; the message is one line for the user."""


class Monitor:
    """The launcher's view of the graph: simulated time, the done signal and the latest estimate, and the CPU
    time the processes spent in between (`cpu_times`: a Graph's)."""

    def __init__(self, node, cpu_times, estimates=topics.PARAMETERS_TOPIC):
        from builtin_interfaces.msg import Time

        from emla_core.messages import message_class
        from emla_core.nodes.qos import LATCHED_QOS
        from emla_msgs.msg import ParameterEstimate

        # Progress comes from the plant's true parameters, published at its start (t = 0) and every 10 ms of
        # simulated time: /clock ticks every control period, which would cost this process a wake-up each.
        # The real-time factor and the CPU time are measured from the first tick after the start: the first
        # frames pay for the start-up of the connections (a reader may only then learn of its writer).
        self.first_tick = self.last_tick = None    # (wall s, simulated ns) of the true parameters
        self.done = None                           # simulated ns of the plant's end
        self.done_wall = None
        self.estimate = None                       # stamp (ns) of the latest estimate
        self._cpu_times = cpu_times
        self.cpu_at_start = self.cpu_at_done = None  # {process: CPU s} at the first tick and at the done signal
        # the estimates as bytes: their stamps are all it needs (the bag has the values), a tenth of the cost
        node.create_subscription(ParameterEstimate, topics.TRUE_PARAMETERS_TOPIC, self._on_tick, LATCHED_QOS,
                                 raw=True)
        node.create_subscription(Time, topics.DONE_TOPIC, self._on_done, LATCHED_QOS)
        node.create_subscription(message_class(topics.RECORDED[estimates][0]), estimates, self._on_estimate,
                                 LATCHED_QOS, raw=True)

    def _on_tick(self, cdr):
        self.last_tick = (time.monotonic(), header_stamp_ns(cdr))
        if self.first_tick is None and self.last_tick[1] > 0:
            self.first_tick, self.cpu_at_start = self.last_tick, self._cpu_times()

    def _on_done(self, msg):
        self.done, self.done_wall, self.cpu_at_done = stamp_to_ns(msg), time.monotonic(), self._cpu_times()

    def _on_estimate(self, cdr):
        self.estimate = header_stamp_ns(cdr)

    @property
    def now(self):
        """Simulated time reached, s (0 before the start)."""
        return (self.done if self.done is not None else self.last_tick[1] if self.last_tick else 0) * 1e-9

    def final(self):
        """The stamp of the identifier's final estimate (the plant's end time) once it has come."""
        if self.done is not None and self.estimate is not None and self.estimate >= self.done:
            return self.estimate
        return None

    def realtime_factor(self):
        """Simulated over wall time from the first tick after the start to the done signal (None without
        one)."""
        if self.first_tick is None or self.done_wall <= self.first_tick[0]:
            return None
        wall, sim = self.first_tick
        return round((self.done - sim) * 1e-9 / (self.done_wall - wall), 4)

    def cpu_per_simulated_second(self):
        """{process: CPU s per simulated s} over the same span, and their 'total' ({} without ticks)."""
        if self.first_tick is None or self.cpu_at_done is None or self.done <= self.first_tick[1]:
            return {}
        simulated = (self.done - self.first_tick[1]) * 1e-9
        cpu = {name: round((self.cpu_at_done[name] - self.cpu_at_start[name]) / simulated, 3)
               for name in self.cpu_at_start}
        return {**cpu, 'total': round(sum(cpu.values()), 3)}


def write_params(directory, node, parameters):
    """A ROS 2 params file for /emla/<node>; its path."""
    path = Path(directory) / f'{node}.yaml'
    path.write_text(yaml.safe_dump({f'/emla/{node}': {'ros__parameters': parameters}}, sort_keys=False))
    return path


def launch(scenario, duration, bag, node_parameters, actuator='moving_coil', workdir=None, recorder_fds=()):
    """Run the graph: NODES as processes with `node_parameters` {node: {name: value}} (the plant's duration
    and start barrier are set here), and the recorder writing `bag`. Returns the contract's summary dict;
    raises LaunchError when a node dies or the run stalls. Every process is stopped on return.

    The nodes' params files are written to `workdir` (default: a temporary directory). The recorder keeps the
    descriptors `recorder_fds` open (the locks of the output it writes: emla_cli.commands.staging).

    The identifier's final estimate is a moving coil's /emla/parameters, or with `actuator` 'solenoid' the coil's
    R on /emla/effects (emla_identification.nodes.identifier_node)."""
    from emla_core.nodes.run import ros_node

    started = time.monotonic()
    remove_unused_shm(stale_shm_files())  # what a launcher killed earlier left
    parameters = {**node_parameters, 'plant': {**node_parameters.get('plant', {}), 'duration': float(duration),
                                               'start_subscribers': START_SUBSCRIBERS,
                                               'frames_subscribers': FRAMES_SUBSCRIBERS,
                                               'done_subscribers': DONE_SUBSCRIBERS},
                  'recorder': {'bag': str(bag), 'scenario': scenario, 'hold_start': True, 'actuator': actuator}}
    solenoid = actuator == 'solenoid'
    with reserved_domain() as domain, _workdir(workdir) as tmp, \
            Graph(domain_env(domain)) as graph, ros_node('emla_launch', domain) as (node, executor), \
            simulated_time_bar(duration, f'{scenario} (domain {domain})', sys.stderr) as bar:
        monitor = Monitor(node, graph.cpu_times, topics.EFFECTS_TOPIC if solenoid else topics.PARAMETERS_TOPIC)
        for name in ('recorder', *NODES):
            graph.start(name, [str(BIN / 'emla'), 'run', name, '--params-file',
                               str(write_params(tmp, name, parameters.get(name, {})))],
                        recorder_fds if name == 'recorder' else ())
        _wait_for_final(graph, monitor, executor, bar)
        # All at once: every message was published before the final estimate came; the recorder records until
        # its topics are quiet (drain_time) and meanwhile acknowledges what the stopping nodes wait for.
        graph.stop()
        if graph['recorder'].popen.returncode != 0:
            raise LaunchError(f'the recorder failed: {graph["recorder"].describe_exit()}')
        final, rtf, cpu = monitor.final(), monitor.realtime_factor(), monitor.cpu_per_simulated_second()
        nodes = [{'name': n.name, 'pid': n.pid} for n in graph.nodes]
    contents = read_bag(bag)
    estimates = contents.effects if solenoid else contents.estimates
    if not estimates or estimates[-1][0] != final * 1e-9:
        raise LaunchError(f'{bag}: the recorder missed the final estimate')
    return {'scenario': scenario, 'duration': duration, 'wall_time': round(time.monotonic() - started, 3),
            'realtime_factor': rtf, 'cpu_per_simulated_second': cpu, 'final_parameters': estimates[-1][1],
            'true_parameters': contents.truth[-1][1] if contents.truth else {}, 'bag': str(bag), 'nodes': nodes}


def simulated_time_bar(duration, label, stream):
    """A tqdm bar of the simulated time (s of `duration`) on `stream`, shown only where that is a terminal: its
    redraws ('\\r' lines) would fill a log file that stderr is redirected to."""
    from tqdm import tqdm
    return tqdm(total=round(duration, 6), desc=label, file=stream, disable=not stream.isatty(),
                bar_format='{desc}: {n:.3f}/{total} s simulated [{elapsed}]')


def _workdir(directory):
    """A context of `directory`, or of a new temporary directory removed at its end."""
    if directory is None:
        return tempfile.TemporaryDirectory(prefix='emla-launch-')
    return contextlib.nullcontext(directory)


def _wait_for_final(graph, monitor, executor, bar):
    """Spin the monitor until the final estimate came; LaunchError when a node dies, the plant leaves before its
    end (stopped by a signal: status 0, but no done signal) or nothing moves."""
    progress_at, reached, plant_left = time.monotonic(), -1.0, None
    while monitor.final() is None:
        executor.spin_once(timeout_sec=0.05)
        now = time.monotonic()
        for node in graph.nodes:
            if not node.running() and not (node.name == 'plant' and node.popen.returncode == 0):
                raise LaunchError(f'{node.describe_exit()}')
        if monitor.done is None and not graph['plant'].running():
            plant_left = plant_left or now
            if now - plant_left > DONE_GRACE:
                raise LaunchError(f'{graph["plant"].describe_exit()}; it stopped before the end of the run '
                                  f'(at t = {monitor.now:.4f} s; stopped by a signal?)')
        if monitor.now > reached:
            progress_at, reached = now, monitor.now
            bar.update(round(reached - bar.n, 6))
        limit = FINAL_TIMEOUT if monitor.done is not None else STALL_TIMEOUT
        if now - progress_at > limit:
            what = 'no final estimate after the plant finished' if monitor.done is not None else \
                'the simulation did not start' if reached <= 0 else f'the simulation stalled at t = {reached:.4f} s'
            raise LaunchError(f'{what} (nothing for {limit:g} s; '
                              f'last output: {"; ".join(f"{n.name}: {n.last_line()}" for n in graph.nodes)})')

