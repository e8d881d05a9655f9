"""trend(): every recording of a fleet identified on a dask.distributed cluster (an embedded LocalCluster by
default, or a running scheduler), in time order, with the changes of each parameter.

Nothing lost: a recording that fails is listed with its one-line error and the rest go on; a worker that dies
has its recordings redone by the others (the scheduler's own bookkeeping); one that kills its workers again and
again (KilledWorker) is listed as failed. A cluster that is gone (the scheduler lost, or no worker left for
WORKERS_TIMEOUT s) ends the run in ClusterLost, after a last checkpoint of every recording finished: its recordings
not done are never listed as failed. Nothing redone: recordings already identified (`done`, from an earlier
run's table) are skipped. Memory per worker is one recording's (long bags are identified part by part, as
`emla identify` does), and the client holds only the small results.

Time order is by each recording's time (recordings.recording_time: by default its first sample's); recordings that
all have the same one (CSV files whose time columns all begin at 0) are warned about (Trend.warnings), as
their order and the plot's abscissa then say nothing: `time_from` gives each its own.
"""
import contextlib
import logging
import os
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow as pa

from emla_core.errors import InputError
from emla_core.parameters import FAMILIES

from .changes import detect_changes
from .recordings import DATA_FLAGS, GREYBOX_MODELS, TIME_FROM, check_time_from, find_recordings, identify_recording
from .table import recordings_table

CONNECT_TIMEOUT = 10.0   # s to reach a scheduler and have its answer (the TCP connect and dask's handshake)
WORKERS_TIMEOUT = 60.0   # s for a scheduler's first worker to be there, and with no worker (or no answer) mid-run
HEALTH_INTERVAL = 1.0    # s between looks at the cluster while no result comes
SCHEDULER_SCHEMES = ('tcp://', 'tls://')
JSON_KEYS = ('path', 'start', 'duration', 'parameters', 'std', 'fit', 'warnings')


class ClusterLost(InputError):
    """The cluster went away mid-run (the scheduler lost, or no worker left): `done` of `total` recordings
    finished (identified or failed), the rest not done; `recordings` the ones identified (checkpointed already)."""

    def __init__(self, message, done, total, recordings):
        super().__init__(message)
        self.done, self.total, self.recordings = done, total, recordings


@dataclass
class Trend:
    """The result of `trend`: the recordings identified (time order), the changes, the failures, where it ran.

    `table` is the pyarrow Table of the recordings (emla_identification.fleet.table); `to_dict()` the JSON of
    `emla trend`; `warnings` the lines about the trend as a whole (every recording at one time), for stderr."""

    recordings: list
    changes: list
    failed: list
    scheduler: str
    workers: int
    seconds: float
    skipped: int = 0   # recordings taken from `done` instead of identified again
    table: pa.Table = field(default=None, repr=False)
    warnings: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """{"recordings": [{path, start, duration, parameters, std, fit, warnings}], "changes", "failed",
        "scheduler", "workers", "seconds"}."""
        return {'recordings': [{key: r[key] for key in JSON_KEYS} for r in self.recordings],
                'changes': self.changes, 'failed': self.failed, 'scheduler': self.scheduler,
                'workers': self.workers, 'seconds': self.seconds}


def trend(paths: Iterable[str | Path], *, actuator: str = 'moving_coil', model: str | None = None,
          structure: object = None,
          model_file: str | None = None, columns: str | None = None, units: str | None = None,
          topics: str | None = None, sample_period: float | None = None, delimiter: str | None = None,
          decimal: str | None = None, start: float | None = None, end: float | None = None,
          time_from: str = 'start', workers: int | None = None, scheduler: str | None = None,
          client: object = None, done: Sequence[dict] = (),
          progress: Callable[[int, int, int], object] | None = None,
          checkpoint: Callable[[list], object] | None = None, checkpoint_interval: float = 60.0) -> Trend:
    """Identify every recording of a fleet or a long run in parallel on Dask and trend the parameters.

    Parameters
    ----------
    paths : iterable of str or Path
        Recordings, directories of them or glob patterns (see find_recordings).
    actuator : {'moving_coil', 'solenoid'}, optional
        The actuator family: a solenoid's recordings are identified as `emla identify --actuator solenoid`
        does (R, L0, a, g0, m, B, k, F0; emla_identification.solenoid), with no `model` or `structure`.
    model : {'full', 'electrical', 'mechanical'}, optional
        The grey-box model (default: from the signals, as `emla identify`).
    structure : emla_core.model_file.Model, optional
        A model file's structure: its effects are identified too (their parameters beside the nominal ones).
    model_file : str, optional
        The model file's name, for messages.
    columns, units, topics, sample_period, delimiter, decimal : optional
        The data flags of `emla identify` (emla_core.load), the same for every recording.
    start, end : float, optional
        The window (s, on each record's own time axis, as `emla identify --start --end`): the same part of
        every recording is identified.
    time_from : str, optional
        Where each recording's time comes from (recordings.recording_time's `how`): 'start' (default: its
        first sample's), 'mtime' (its file's modification time), 'column:NAME' (a CSV column of absolute time,
        its first value) or 'pattern:FORMAT' (a date in its name, e.g. 'pattern:run_%Y%m%dT%H%M%S').
    workers : int, optional
        Worker processes of the embedded LocalCluster (default: the cores this process may use).
    scheduler : str, optional
        'tcp://HOST:PORT' of a running dask.distributed scheduler to send the work to instead.
    client : distributed.Client, optional
        A client of your own to use instead of either (it is left open).
    done : sequence of dict
        Recordings identified already (table_recordings of an earlier run's table): those paths are skipped and
        these results kept.
    progress : callable, optional
        progress(done, total, failed) after each recording.
    checkpoint : callable, optional
        checkpoint(recordings) with every recording identified so far, at most every `checkpoint_interval` s
        and when interrupted (Ctrl-C), so that a long run can resume.
    checkpoint_interval : float, optional
        Seconds between checkpoints.

    Returns
    -------
    Trend
        recordings (time order: by start, the time `time_from` gives, then path; those without one last),
        changes (fleet.changes.detect_changes), failed ([{path, error}]), scheduler ('local' or its address),
        workers, seconds, skipped, `table`: the pyarrow Table of the recordings, and `warnings`: a line when
        every recording has the same time (naming --time-from).

    Raises
    ------
    InputError
        No recordings, a bad option (a window that ends before it starts, a `time_from` pattern a recording's
        name does not match), or a scheduler that cannot be reached, does not answer within CONNECT_TIMEOUT
        or has no workers.
    ClusterLost
        (an InputError) The scheduler lost mid-run, or no worker there for WORKERS_TIMEOUT s: `checkpoint` has
        been given every recording finished; .done, .total, .recordings.

    Examples
    --------
    >>> from emla_identification import trend
    >>> result = trend(['fleet/'], workers=2)                           # doctest: +SKIP
    >>> result.table.select(['path', 'resistance', 'resistance_std'])   # doctest: +SKIP
    >>> [(c['parameter'], c['path']) for c in result.changes]           # doctest: +SKIP
    [('damping', 'fleet/run_0060')]
    """
    started = time.monotonic()
    if actuator not in FAMILIES:
        raise InputError(f'--actuator {actuator!r}: choose one of {", ".join(FAMILIES)}')
    if actuator != 'moving_coil' and (model is not None or structure is not None):
        raise InputError(f'--model and --model-file apply to the moving coil, not to --actuator {actuator}')
    if model is not None and model not in GREYBOX_MODELS:
        raise InputError(f'--model {model!r}: a trend follows physical parameters; choose one of '
                         f'{", ".join(GREYBOX_MODELS)}')
    if workers is not None and workers < 1:
        raise InputError(f'--workers {workers}: must be at least 1')
    if start is not None and end is not None and not start < end:
        raise InputError(f'--start {start:g} s must be before --end {end:g} s')
    found = find_recordings(paths)
    previous = {os.path.realpath(r['path']): r for r in done}
    kept = [previous[os.path.realpath(p)] for p in found if os.path.realpath(p) in previous]
    todo = [p for p in found if os.path.realpath(p) not in previous]
    check_time_from(time_from, todo)
    options = {'actuator': actuator, 'model': model, 'structure': structure, 'model_file': model_file,
               'start': start, 'end': end, 'time_from': time_from,
               **dict(zip(DATA_FLAGS, (columns, units, topics, sample_period, delimiter, decimal)))}
    identified: list = list(kept)
    failed: list[dict] = []   # [{path, error}]
    where, count = 'none', 0
    if todo:
        with _cluster(workers, scheduler, client) as (dask_client, where, count):
            _identify_all(dask_client, todo, options, identified, failed, len(found), progress, checkpoint,
                          checkpoint_interval)
    elif progress:
        progress(len(found), len(found), 0)
    identified.sort(key=_time_order)
    failed.sort(key=lambda f: f['path'])
    return Trend(recordings=identified, changes=detect_changes(identified), failed=failed, scheduler=where,
                 workers=count, seconds=time.monotonic() - started, skipped=len(kept),
                 table=recordings_table(identified), warnings=_one_time(identified, time_from))


def _time_order(record):
    start = record.get('start')
    return (start is None, start if start is not None else 0.0, record['path'])


def _one_time(recordings, time_from):
    """[the warning] when two recordings or more all have the same time (CSV files whose time columns all begin
    at 0): they are then in the order of their paths and at one abscissa of the plot, which say nothing of
    time; else []."""
    times = {record.get('start') for record in recordings}
    if len(recordings) < 2 or len(times) != 1 or None in times:
        return []
    where = "each one's first sample" if time_from == 'start' else f'--time-from {time_from}'
    return [f'all {len(recordings)} recordings have the same time, {times.pop():.9g} s ({where}): they are '
            f'ordered by path and plotted at one time; give each its own with --time-from ({TIME_FROM})']


def _identify_all(client, todo, options, identified, failed, total, progress, checkpoint, interval):
    """Submit every path of `todo`, collect each result as it comes into `identified` or `failed`; ClusterLost
    (after a checkpoint) when the cluster goes away."""
    from distributed import as_completed

    futures = client.map(identify_recording, [os.path.abspath(p) for p in todo],
                         [{**options, 'source': p} for p in todo], key=[_key(p) for p in todo])
    source = {future.key: p for future, p in zip(futures, todo)}
    pending = as_completed(futures, loop=client.loop)
    del futures    # (`pending` holds them until collected, and each is released then)
    health = _Health(client, total)
    last = time.monotonic()
    try:
        while not pending.is_empty():
            batch = pending.next_batch(block=False)
            if not batch:
                health.check(len(identified) + len(failed))
                time.sleep(0.05)
                continue
            health.seen()
            cancelled = 0
            for future in batch:
                try:
                    result = None if future.cancelled() else future.result()
                except Exception as exc:  # noqa: BLE001 - KilledWorker and the like: this recording's failure
                    result = None if _cancelled(exc) else {'path': source[future.key], 'error': _lost(exc)}
                future.release()
                if result is None:   # cancelled: the scheduler's state lost (with its connection); not done
                    cancelled += 1
                    continue
                (failed if 'error' in result else identified).append(result)
                if progress:
                    progress(len(identified) + len(failed), total, len(failed))
            if cancelled:
                health.lost(len(identified) + len(failed))
            if checkpoint and time.monotonic() - last >= interval:
                checkpoint(list(identified))
                last = time.monotonic()
    except ClusterLost as exc:
        exc.recordings = list(identified)
        if checkpoint:
            checkpoint(list(identified))
        raise
    except KeyboardInterrupt:
        if checkpoint:
            checkpoint(list(identified))
        raise


class _Health:
    """The cluster's state while the results come: ClusterLost when the client has lost its scheduler, or when
    no worker has been there (or the scheduler has not answered) for WORKERS_TIMEOUT s."""

    def __init__(self, client, total):
        self.client, self.total = client, total
        self.looked = self.worker_seen = time.monotonic()

    def seen(self):
        """A result came: there are workers."""
        self.looked = self.worker_seen = time.monotonic()

    def check(self, done):
        """ClusterLost if the cluster is gone (see the class); a look at its workers every HEALTH_INTERVAL s."""
        if not self._connected():
            self.lost(done)
        if time.monotonic() - self.looked < HEALTH_INTERVAL:
            return
        try:
            workers = len(self.client.nthreads(callback_timeout=CONNECT_TIMEOUT))
            answered = True
        except Exception:  # noqa: BLE001 - no answer in time, or the connection closed meanwhile
            if not self._connected():
                self.lost(done)
            workers, answered = 0, False
        self.looked = time.monotonic()
        if workers:
            self.worker_seen = self.looked
        elif self.looked - self.worker_seen >= WORKERS_TIMEOUT:
            what = 'no worker has been connected' if answered else 'the scheduler has not answered'
            raise ClusterLost(f'{_where(self.client)}: {what} for {WORKERS_TIMEOUT:g} s; {self._counts(done)}',
                              done, self.total, [])

    def lost(self, done):
        raise ClusterLost(f'{_where(self.client)}: the scheduler was lost mid-run (its connection closed); '
                          f'{self._counts(done)}', done, self.total, [])

    def _connected(self):
        return self.client.status in ('running', 'newly-created')

    def _counts(self, done):
        return f'{done} of {self.total} recordings done, {self.total - done} not done'


def _where(client):
    """'--scheduler ADDRESS' of a scheduler's client, else 'the cluster' (for messages)."""
    address = _address(client)
    return f'--scheduler {address}' if '://' in str(address) else 'the cluster'


def _cancelled(exc):
    """Whether `exc` is a future's cancellation (distributed's FutureCancelledError and its kin), not a failure."""
    import asyncio
    import concurrent.futures
    return isinstance(exc, (asyncio.CancelledError, concurrent.futures.CancelledError))


def _key(path):
    """A task key unique to this run and path (results are never shared with another run's)."""
    import uuid
    return f'emla-trend-{uuid.uuid4().hex}-{Path(path).name}'


def _lost(exc):
    from distributed import KilledWorker
    if isinstance(exc, KilledWorker):
        return ('the workers running it died each time it was tried (KilledWorker): out of memory, or a crash '
                'in a native library')
    text = ' '.join(str(exc).split()) or 'no message'
    return f'{type(exc).__name__}: {text}'


@contextlib.contextmanager
def _cluster(workers, scheduler, client):
    """(client, scheduler description, worker count) of the client given, a running scheduler, or an embedded
    LocalCluster of `workers` single-threaded processes on this machine."""
    if client is not None:
        yield client, _address(client), len(client.nthreads())
        return
    from distributed import Client, LocalCluster
    if scheduler is not None:
        if not scheduler.startswith(SCHEDULER_SCHEMES) or ':' not in scheduler.split('://', 1)[1]:
            raise InputError(f'--scheduler {scheduler}: give the address as tcp://HOST:PORT')
        _reachable(scheduler)
        connection = _connection_args(scheduler)
        _answers(scheduler, connection)
        with _quiet():   # (the client's reconnect attempts log tracebacks: a lost scheduler is trend's one line)
            try:
                remote = Client(scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
            except (OSError, TimeoutError) as exc:
                raise InputError(f'--scheduler {scheduler}: cannot connect within {CONNECT_TIMEOUT:g} s '
                                 f'({" ".join(str(exc).split()) or type(exc).__name__})') from None
            with remote:
                try:
                    remote.wait_for_workers(1, timeout=WORKERS_TIMEOUT)
                    count = len(remote.nthreads(callback_timeout=CONNECT_TIMEOUT))
                except TimeoutError:
                    raise InputError(f'--scheduler {scheduler}: no worker joined within {WORKERS_TIMEOUT:g} s; '
                                     f'start some with `dask worker {scheduler}`') from None
                except OSError as exc:
                    raise InputError(f'--scheduler {scheduler}: the scheduler was lost before the run began '
                                     f'({" ".join(str(exc).split()) or type(exc).__name__})') from None
                yield remote, scheduler, count
        return
    count = workers or len(os.sched_getaffinity(0))
    with warnings.catch_warnings():   # (a busy dashboard port and the like: nothing the user asked about)
        warnings.simplefilter('ignore')
        cluster = LocalCluster(n_workers=count, threads_per_worker=1, processes=True, host='127.0.0.1',
                               dashboard_address=None, scheduler_kwargs={'dashboard': False},
                               silence_logs=logging.CRITICAL)   # (a worker's heartbeat racing the close logs an
                                                                # ERROR with a traceback; failures reach the user
                                                                # as trend's own failed items)
    with cluster, Client(cluster, set_as_default=False) as local:
        yield local, 'local', count


def _reachable(scheduler):
    """InputError at once when nothing listens at a scheduler's address (the client would retry until its
    timeout)."""
    import socket
    host, _, port = scheduler.split('://', 1)[1].rpartition(':')
    try:
        with socket.create_connection((host.strip('[]'), int(port)), timeout=CONNECT_TIMEOUT):
            pass
    except (OSError, ValueError) as exc:
        raise InputError(f'--scheduler {scheduler}: cannot connect ({getattr(exc, "strerror", None) or exc}); is '
                         f'`dask scheduler` running there?') from None


def _connection_args(scheduler):
    """The client's connection arguments (dask's configuration: distributed.comm.tls.*); InputError for a tls://
    address without a TLS certificate configured."""
    from distributed.security import Security
    connection = Security().get_connection_args('client')
    if scheduler.startswith('tls://') and connection.get('ssl_context') is None:
        raise InputError(f'--scheduler {scheduler}: TLS needs certificates in dask\'s configuration '
                         f'(distributed.comm.tls.ca-file, distributed.comm.tls.client.cert and .key, or '
                         f'DASK_DISTRIBUTED__COMM__TLS__CA_FILE ...), and none is set; or give a tcp:// address')
    return connection


def _answers(scheduler, connection):
    """InputError unless a dask scheduler answers at `scheduler` within CONNECT_TIMEOUT s: the TCP connect, dask's
    handshake and one request (distributed bounds only the connect: a server that accepts and stays silent would
    hold the client for ever). Run on an event loop of its own, in a thread of its own."""
    import asyncio
    import threading

    from distributed.comm import connect

    async def ask():
        comm = await connect(scheduler, timeout=CONNECT_TIMEOUT, **connection)
        try:
            await comm.write({'op': 'identity', 'n_workers': 0})
            return await comm.read()
        finally:
            comm.abort()

    outcome = {}

    def run():
        try:
            outcome['answer'] = asyncio.run(asyncio.wait_for(ask(), CONNECT_TIMEOUT))
        except BaseException as exc:  # noqa: BLE001 - reported below, in the caller's thread
            outcome['error'] = exc

    with _quiet():
        thread = threading.Thread(target=run, name='emla-trend-connect', daemon=True)
        thread.start()
        thread.join(CONNECT_TIMEOUT + 5.0)
    error, answer = outcome.get('error'), outcome.get('answer')
    if error is None and answer is None:
        error = TimeoutError()
    if isinstance(error, (TimeoutError, asyncio.TimeoutError)):
        raise InputError(f'--scheduler {scheduler}: accepts a connection but gives no answer within '
                         f'{CONNECT_TIMEOUT:g} s; is it a `dask scheduler`?') from None
    if error is not None:
        raise InputError(f'--scheduler {scheduler}: cannot connect ({type(error).__name__}: '
                         f'{" ".join(str(error).split()) or "no message"}); is `dask scheduler` running '
                         f'there?') from None
    kind = answer.get('type') if isinstance(answer, dict) else None
    if kind != 'Scheduler':
        raise InputError(f'--scheduler {scheduler}: answers as {kind or "something else"}, not as a dask scheduler '
                         f'(`dask scheduler` prints its address as it starts)')


@contextlib.contextmanager
def _quiet():
    """distributed's own log lines held back (raised to CRITICAL) for the while: what goes wrong reaches the user
    as trend's one line or its failed items."""
    names = ['distributed'] + [name for name, logger in logging.root.manager.loggerDict.items()
                               if name.startswith('distributed.') and isinstance(logger, logging.Logger)
                               and logger.level != logging.NOTSET]   # (distributed.client has a level of its own)
    levels = {name: logging.getLogger(name).level for name in names}
    for name in names:
        logging.getLogger(name).setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)


def _address(client):
    try:
        return client.scheduler.address
    except AttributeError:
        return 'client'
