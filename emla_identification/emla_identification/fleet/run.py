"""trend(): every recording of a fleet identified on a dask.distributed cluster (an embedded LocalCluster by
default, or a running scheduler), in time order, with the changes of each parameter.

Nothing lost: a recording that fails is listed with its one-line error and the rest go on; a worker that dies
has its recordings redone by the others (the scheduler's own bookkeeping); one that kills its workers again and
again (KilledWorker) is listed as failed. Nothing redone: recordings already identified (`done`, from an earlier
run's table) are skipped. Memory per worker is one recording's (long bags are identified part by part, as
`emla identify` does), and the client holds only the small results.
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
from .recordings import DATA_FLAGS, GREYBOX_MODELS, find_recordings, identify_recording
from .table import recordings_table

CONNECT_TIMEOUT = 10.0   # s to reach a scheduler
WORKERS_TIMEOUT = 60.0   # s for a scheduler's first worker to be there
SCHEDULER_SCHEMES = ('tcp://', 'tls://')
JSON_KEYS = ('path', 'start', 'duration', 'parameters', 'std', 'fit', 'warnings')


@dataclass
class Trend:
    """The result of `trend`: the recordings identified (time order), the changes, the failures, where it ran.

    `table` is the pyarrow Table of the recordings (emla_identification.fleet.table); `to_dict()` the JSON of
    `emla trend`."""

    recordings: list
    changes: list
    failed: list
    scheduler: str
    workers: int
    seconds: float
    skipped: int = 0   # recordings taken from `done` instead of identified again
    table: pa.Table = field(default=None, repr=False)

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
          decimal: str | None = None, workers: int | None = None, scheduler: str | None = None,
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
        recordings (time order: by start, then path; those without a start last), changes
        (fleet.changes.detect_changes), failed ([{path, error}]), scheduler ('local' or its address), workers,
        seconds, skipped, and `table`: the pyarrow Table of the recordings.

    Raises
    ------
    InputError
        No recordings, a bad option, or a scheduler that cannot be reached or has no workers.

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
    found = find_recordings(paths)
    previous = {os.path.realpath(r['path']): r for r in done}
    kept = [previous[os.path.realpath(p)] for p in found if os.path.realpath(p) in previous]
    todo = [p for p in found if os.path.realpath(p) not in previous]
    options = {'actuator': actuator, 'model': model, 'structure': structure, 'model_file': model_file,
               **dict(zip(DATA_FLAGS, (columns, units, topics, sample_period, delimiter, decimal)))}
    identified, failed = list(kept), []
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
                 table=recordings_table(identified))


def _time_order(record):
    start = record.get('start')
    return (start is None, start if start is not None else 0.0, record['path'])


def _identify_all(client, todo, options, identified, failed, total, progress, checkpoint, interval):
    """Submit every path of `todo`, collect each result as it comes into `identified` or `failed`."""
    from distributed import as_completed

    futures = client.map(identify_recording, [os.path.abspath(p) for p in todo],
                         [{**options, 'source': p} for p in todo], key=[_key(p) for p in todo])
    source = {future.key: p for future, p in zip(futures, todo)}
    last = time.monotonic()
    try:
        for future in as_completed(futures, loop=client.loop):
            try:
                result = future.result()
            except Exception as exc:  # noqa: BLE001 - KilledWorker and the like: this recording's failure
                result = {'path': source[future.key], 'error': _lost(exc)}
            future.release()
            (failed if 'error' in result else identified).append(result)
            if progress:
                progress(len(identified) + len(failed), total, len(failed))
            if checkpoint and time.monotonic() - last >= interval:
                checkpoint(list(identified))
                last = time.monotonic()
    except KeyboardInterrupt:
        if checkpoint:
            checkpoint(list(identified))
        raise


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
        try:
            remote = Client(scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise InputError(f'--scheduler {scheduler}: cannot connect within {CONNECT_TIMEOUT:g} s '
                             f'({" ".join(str(exc).split()) or type(exc).__name__})') from None
        with remote:
            try:
                remote.wait_for_workers(1, timeout=WORKERS_TIMEOUT)
            except TimeoutError:
                raise InputError(f'--scheduler {scheduler}: no worker joined within {WORKERS_TIMEOUT:g} s; start '
                                 f'some with `dask worker {scheduler}`') from None
            yield remote, scheduler, len(remote.nthreads())
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
    """InputError at once when nothing listens at a tcp:// scheduler's address (the client would retry until its
    timeout)."""
    if not scheduler.startswith('tcp://'):
        return
    import socket
    host, _, port = scheduler[len('tcp://'):].rpartition(':')
    try:
        with socket.create_connection((host.strip('[]'), int(port)), timeout=CONNECT_TIMEOUT):
            pass
    except (OSError, ValueError) as exc:
        raise InputError(f'--scheduler {scheduler}: cannot connect ({getattr(exc, "strerror", None) or exc}); is '
                         f'`dask scheduler` running there?') from None


def _address(client):
    try:
        return client.scheduler.address
    except AttributeError:
        return 'client'
