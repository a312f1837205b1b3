"""Run one pure function over many inputs on a dask scheduler, results in input order (docs/scaling.md, "Many runs").

:func:`run_tasks` is the plumbing under every many-run job of :mod:`dualpose.jobs`: ``func(item)`` for each item, on

* ``"serial"``: in this process, one after the other (no dask needed);
* ``None`` / ``"processes"`` (default): a local pool of worker processes started for the call -- the
  ``dask.distributed.LocalCluster`` of :func:`local_cluster` (one thread per worker process, worker settings
  :data:`LOCAL_CLUSTER_CONFIG`) when ``distributed`` is installed, otherwise dask's multiprocessing scheduler;
* an address (``"tcp://host:8786"``, ``"host:8786"``): an existing ``dask.distributed`` cluster;
* ``client=``: a connected ``distributed.Client`` of the caller's, used as it is.

**What a job owns.**  Given ``"processes"``, a job starts its cluster, connects its client and closes both before it
returns; given an address, it connects its own client and closes it (the cluster keeps running).  Given a
``client``, it owns only its tasks: it submits them on that client, collects their outcomes and releases them (the
cluster then forgets them), and leaves the client connected, so that many jobs in one session (a notebook, a sweep)
pay the connection once (a few tens of milliseconds a job; docs/scaling.md, "Where the time goes").

Guarantees, whatever the scheduler:

* **Order**: the outcome list is in the order of ``items``, however the tasks were scheduled.
* **Failures stay in their row**: an exception inside ``func`` becomes a :class:`TaskFailure` with its reason in that
  row; every other item still runs.
* **Pure tasks**: ``func`` must depend on its item only (seeds are part of the item; no shared random state), so a
  task recomputed on another process gives the same bits.  Nothing is written by a task: the client collects the
  outcomes and the caller writes the outputs once.
* **Lost workers** (distributed only): a task whose worker dies is recomputed on another worker by the dask
  scheduler; its outcome is collected once, by its key, so nothing is lost or counted twice.

On a cluster the items go to dask in chunks (:func:`chunk_bounds`: ``TASKS_PER_WORKER`` tasks per worker, a multiple
of the worker count, sizes differing by one item at most, at most ``MAX_CHUNK`` items a task), as the distributed
scheduler costs milliseconds per task; progress is then reported per chunk.

dask and distributed are optional (``pip install 'dualpose[dask]'``) and are imported only when a parallel
scheduler is asked for.
"""

from __future__ import annotations

import heapq
import logging
import math
import os
import traceback
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Generic, TypeVar

if TYPE_CHECKING:
    import distributed

__all__ = ["LOCAL_CLUSTER_CONFIG", "SCHEDULERS", "TaskFailure", "chunk_bounds", "chunk_indices", "default_scheduler",
           "file_bytes", "local_cluster", "run_tasks"]

_T = TypeVar("_T")
_R = TypeVar("_R")

#: the scheduler names :func:`run_tasks` knows besides a cluster address
SCHEDULERS: tuple[str, ...] = ("serial", "processes")

#: seconds to wait for a cluster address to answer
CONNECT_TIMEOUT_S = 20.0

#: most items one dask task runs (:func:`chunk_bounds`): bounds what a lost worker makes the cluster recompute
MAX_CHUNK = 64

#: dask tasks per worker (:func:`chunk_bounds`; docs/scaling.md, "Where the time goes"): two, so that a worker always
#: has its next task at hand (the scheduler hands a one-thread worker two tasks at a time) and a faster worker can take
#: over a slower one's second task; each task more costs the client about a millisecond of CPU and of wall time
TASKS_PER_WORKER = 2

#: dask settings of the local cluster that :func:`run_tasks` starts (:func:`local_cluster`; docs/scaling.md, "Where the
#: time goes"), each changing only what a worker does besides running tasks:
#:
#: * ``MALLOC_TRIM_THRESHOLD_`` is not set in the workers (distributed's nanny sets it to 65536 by default, to hand
#:   freed memory back to the system at once).  Setting it also turns off glibc's adaptive mmap threshold, so every
#:   NumPy array above 128 KiB is mapped afresh and its pages faulted in again at each allocation: hundreds of page
#:   faults and a quarter more CPU per evaluation row.  The workers then allocate as the serial process does.  BLAS
#:   stays at one thread (the nanny's other default variables are kept).
#: * no statistical profiler (a thread sampling the task's stack every 10 ms for the dashboard);
#: * the event loop's health check every second instead of every 20 ms, and the system monitor every 5 s instead
#:   of 0.5 s (both only feed diagnostics).
LOCAL_CLUSTER_CONFIG: dict[str, object] = {
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
}

#: how often the distributed scheduler retries a task that raised (the task functions catch their errors: this only
#: covers failures outside them, such as a result that cannot be sent back)
_RETRIES = 2


@dataclass(frozen=True)
class TaskFailure:
    """The outcome of a task whose function raised: ``reason`` is ``"ExceptionType: message"`` (the message alone
    for ``ValueError`` and ``OSError``, whose messages name the file and line in dualpose)."""

    reason: str


@dataclass(frozen=True)
class _Guarded(Generic[_T, _R]):
    """``func(item)``, with an exception turned into a :class:`TaskFailure` (picklable: ``func`` is module-level)."""

    func: Callable[[_T], _R]

    def __call__(self, item: _T) -> _R | TaskFailure:
        try:
            return self.func(item)
        except (ValueError, OSError) as exc:
            return TaskFailure(" ".join(str(exc).split()) or type(exc).__name__)
        except Exception as exc:  # a failure of one row never stops the others; the type says what happened
            last = traceback.extract_tb(exc.__traceback__)[-1:]
            where = f" ({os.path.basename(last[0].filename)}:{last[0].lineno})" if last else ""
            return TaskFailure(f"{type(exc).__name__}: {' '.join(str(exc).split())}{where}")


def default_scheduler() -> str:
    """``"processes"`` when dask is installed, else ``"serial"``."""
    try:
        import dask  # noqa: F401
    except ImportError:
        return "serial"
    return "processes"


def _check(scheduler: str | None, workers: int | None) -> str:
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be an integer >= 1; got {workers!r}")
    if scheduler is None:
        return "processes"
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise ValueError(f"scheduler must be 'serial', 'processes' or a cluster address; got {scheduler!r}")
    return scheduler.strip()


def run_tasks(
    func: Callable[[_T], _R],
    items: Sequence[_T],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    client: distributed.Client | None = None,
    cost: Callable[[_T], float] | None = None,
) -> list[_R | TaskFailure]:
    """``[func(item) for item in items]`` on a scheduler, failures kept per item.

    Parameters
    ----------
    func : callable
        A module-level function of one item (pickled by reference for worker processes), pure: its result depends
        on the item only.
    items : sequence
        The task inputs (picklable).
    scheduler : {"serial", "processes"}, address or None
        Where to run (module docstring); None is ``"processes"``.
    workers : int, optional
        Worker processes of the local pool (default: the machine's CPU count); not used with ``"serial"`` or an
        address.
    progress : callable, optional
        ``progress(done, total)`` after each finished task, in the calling thread.
    client : distributed.Client, optional
        A connected (synchronous) client of a running cluster, instead of ``scheduler`` and ``workers``: the job runs
        there and leaves the client connected (module docstring, "What a job owns").
    cost : callable, optional
        ``cost(item)``: an estimate (>= 0, any unit, e.g. the bytes of its files) of what computing the item takes,
        called on the client for each item on a cluster only.  The items are then grouped into the dask tasks by it
        (:func:`chunk_indices`), so that the tasks take about as long as each other; without it, consecutive items of
        equal count (:func:`chunk_bounds`).  The outcomes are in item order either way.

    Returns
    -------
    list
        One outcome per item, in the order of ``items``: ``func``'s result or a :class:`TaskFailure`.

    Raises
    ------
    ValueError
        An unknown scheduler name or a bad ``workers``; ``client`` together with ``scheduler`` or ``workers``, or a
        closed ``client``; a ``cost`` that is negative or not finite.
    TypeError
        ``client`` is not a synchronous ``distributed.Client``.
    ImportError
        A parallel scheduler without dask (``pip install 'dualpose[dask]'``), or an address without distributed.
    OSError
        A cluster address that cannot be reached.
    """
    if client is not None:
        _check_client(client, scheduler, workers)
    kind = _check(scheduler, workers)
    items = list(items)
    guarded: _Guarded[_T, _R] = _Guarded(func)
    total = len(items)
    if total == 0:
        return []
    if client is not None:
        return _on_client(guarded, items, client, progress, cost)
    if kind == "serial":
        out: list[_R | TaskFailure] = []
        for item in items:
            out.append(guarded(item))
            if progress is not None:
                progress(len(out), total)
        return out
    if kind == "processes":
        try:
            import distributed
        except ImportError:
            return _dask_processes(guarded, items, workers, progress)
        n = workers or os.cpu_count() or 1
        with local_cluster(min(n, total)) as cluster:
            return _distributed(guarded, items, cluster, progress, cost)
    if kind in SCHEDULERS or "://" not in kind and ":" not in kind:
        raise ValueError(f"scheduler must be 'serial', 'processes' or a cluster address (tcp://HOST:PORT); "
                         f"got {kind!r}")
    try:
        import distributed  # noqa: F401
    except ImportError as exc:
        raise ImportError(f"scheduler {kind!r} needs dask.distributed: pip install 'dualpose[dask]'") from exc
    return _distributed(guarded, items, kind, progress, cost)


def local_cluster(workers: int | None = None) -> distributed.LocalCluster:
    """A ``dask.distributed.LocalCluster`` of ``workers`` processes (default: the CPU count), one thread each, no
    dashboard, with :data:`LOCAL_CLUSTER_CONFIG`: the pool ``run_tasks(..., scheduler="processes")`` starts for one job.

    Use it as a context manager; its ``scheduler_address`` can be given to several jobs as ``scheduler``, so that
    they share one start (about a second).

    Raises
    ------
    ValueError
        A bad ``workers``.
    ImportError
        distributed is not installed (``pip install 'dualpose[dask]'``).
    """
    _check("processes", workers)
    try:
        import dask
        from distributed import LocalCluster
    except ImportError as exc:
        raise ImportError("a local cluster needs dask.distributed: pip install 'dualpose[dask]'") from exc
    # the config is read by the nannies before they spawn and sent to the workers; the scheduler's small HTTP server
    # listens on a free port, without the dashboard (bokeh) on it
    with dask.config.set(LOCAL_CLUSTER_CONFIG):
        cluster: distributed.LocalCluster = LocalCluster(
            n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True, silence_logs=logging.ERROR,
            dashboard_address=":0", scheduler_kwargs={"dashboard": False})  # type: ignore[no-untyped-call]  # fmt: skip
    return cluster


@dataclass(frozen=True)
class _Chunk(Generic[_T, _R]):
    """``[guarded(item) for item in items]``: one dask task for a few items (picklable)."""

    guarded: _Guarded[_T, _R]

    def __call__(self, items: list[_T]) -> list[_R | TaskFailure]:
        return [self.guarded(item) for item in items]


def chunk_bounds(n_items: int, n_workers: int) -> list[tuple[int, int]]:
    """``(start, stop)`` of each dask task's items: ``TASKS_PER_WORKER`` tasks per worker, or more so that none
    exceeds ``MAX_CHUNK`` items, their count a multiple of ``n_workers`` (at most one per item), their sizes differing
    by one item at most -- so equal workers finish together (the distributed scheduler costs milliseconds a task)."""
    n_items, n_workers = max(int(n_items), 0), max(int(n_workers), 1)
    if n_items == 0:
        return []
    n_tasks = max(TASKS_PER_WORKER * n_workers, -(-n_items // MAX_CHUNK))
    n_tasks = min(n_items, -(-n_tasks // n_workers) * n_workers)
    size, extra = divmod(n_items, n_tasks)
    stops = [(k + 1) * size + min(k + 1, extra) for k in range(n_tasks)]
    return list(zip([0, *stops[:-1]], stops, strict=True))


def _distributed(
    guarded: _Guarded[_T, _R],
    items: list[_T],
    where: object,
    progress: Callable[[int, int], None] | None,
    cost: Callable[[_T], float] | None,
) -> list[_R | TaskFailure]:
    """On a ``distributed`` cluster (a ``LocalCluster`` object or an address), through a client of its own."""
    from distributed import Client

    try:
        client = Client(where, set_as_default=False, timeout=f"{CONNECT_TIMEOUT_S}s")  # type: ignore[no-untyped-call]
    except (OSError, TimeoutError) as exc:
        raise OSError(f"cannot reach the dask scheduler at {where}: {exc}") from None
    with client:
        return _on_client(guarded, items, client, progress, cost)


def _check_client(client: object, scheduler: str | None, workers: int | None) -> None:
    """Refuse a ``client`` that is not a connected synchronous ``distributed.Client``, or comes with a scheduler."""
    if scheduler is not None or workers is not None:
        raise ValueError(f"give either client or scheduler/workers, not both; got client and "
                         f"scheduler={scheduler!r}, workers={workers!r}")  # fmt: skip
    from distributed import Client

    if not isinstance(client, Client) or client.asynchronous:
        raise TypeError(f"client must be a synchronous distributed.Client; got {client!r}")
    if client.status != "running":
        raise ValueError(f"client must be connected; got a client whose status is {client.status!r}")


def _on_client(
    guarded: _Guarded[_T, _R],
    items: list[_T],
    client: distributed.Client,
    progress: Callable[[int, int], None] | None,
    cost: Callable[[_T], float] | None,
) -> list[_R | TaskFailure]:
    """The chunks of ``items`` (:func:`chunk_indices`) as futures of ``client``, collected once each and put back in
    item order; the futures are released on return (the client stays connected)."""
    from distributed import as_completed

    costs = None if cost is None else [_checked_cost(cost(item)) for item in items]
    chunks = chunk_indices(len(items), sum(client.nthreads().values()), costs)  # type: ignore[no-untyped-call]
    prefix = f"dualpose-task-{uuid.uuid4().hex}"
    # one message to the scheduler for all chunks (the client sends its messages in batches at most every
    # 10 ms, so chunks submitted one by one can reach the workers in two rounds)
    futures = client.map(_Chunk(guarded), [[items[i] for i in idx] for idx in chunks],
                         key=[f"{prefix}-{j}" for j in range(len(chunks))], pure=False, retries=_RETRIES)  # fmt: skip
    # progress as each chunk finishes on the cluster; the outcomes are then fetched in one gather (one round
    # trip per worker) rather than one ``result()`` per chunk (a call into the client's event loop and a round
    # trip each: about 2 ms a chunk).  Only if that gather fails (a result that cannot be sent back, or a chunk
    # lost more often than the scheduler allows) is each chunk fetched on its own, so the failure stays in its
    # rows.  as_completed(with_results=True) would hang on a result that cannot be sent back (its fetch raises
    # inside the client's event loop, and the chunk never comes out).
    size = {f.key: len(idx) for idx, f in zip(chunks, futures, strict=True)}
    done = 0
    for future in as_completed(futures, loop=client.loop):  # type: ignore[no-untyped-call]
        done += size[future.key]
        if progress is not None:
            progress(done, len(items))
    try:
        outcomes: list[list[_R | TaskFailure]] = client.gather(futures)  # type: ignore[no-untyped-call]
    except Exception:
        outcomes = [_chunk_outcome(future, len(idx)) for future, idx in zip(futures, chunks, strict=True)]
    out: list[_R | TaskFailure | None] = [None] * len(items)
    for idx, chunk in zip(chunks, outcomes, strict=True):
        for i, outcome in zip(idx, chunk, strict=True):
            out[i] = outcome
    return out  # type: ignore[return-value]  # every index is in exactly one chunk


def _checked_cost(value: float) -> float:
    c = float(value)
    if not math.isfinite(c) or c < 0:
        raise ValueError(f"cost must return a finite number >= 0; got {value!r}")
    return c


def file_bytes(*paths: str) -> float:
    """The total size in bytes of the files ``paths`` (of ``FILE`` for a bag topic ``FILE:/topic``; 0 for a path that
    cannot be read, whose task fails at once): a ``cost`` estimate for :func:`run_tasks` when a task's work grows with
    its input files, as reading and evaluating a trajectory does."""
    total = 0
    for path in paths:
        for candidate in (path, path.rsplit(":/", 1)[0]) if ":/" in path else (path,):
            try:
                total += os.path.getsize(candidate)
                break
            except OSError:
                continue
    return float(total)


def chunk_indices(n_items: int, n_workers: int, costs: Sequence[float] | None = None) -> list[list[int]]:
    """The item indices of each dask task, ascending within a task: as many tasks as :func:`chunk_bounds` makes.

    Without ``costs``, the consecutive runs of :func:`chunk_bounds`.  With ``costs`` (one estimate >= 0 per item),
    the longest-processing-time-first rule (Graham 1969): items in decreasing cost (ties: the lower index first), each
    to the task with the least cost so far among those below ``MAX_CHUNK`` items (ties: the fewer items, then the lower
    task).  So, while no task is full, the tasks' costs differ by at most the largest item's, and the workers, taking
    equal tasks, finish together however the items are ordered.  Equal costs deal the items out in turn (sizes
    differing by one item at most).
    """
    bounds = chunk_bounds(n_items, n_workers)
    if costs is None:
        return [list(range(a, b)) for a, b in bounds]
    if len(costs) != n_items:
        raise ValueError(f"costs must have one value per item ({n_items}); got {len(costs)}")
    tasks: list[list[int]] = [[] for _ in bounds]
    heap = [(0.0, 0, j) for j in range(len(bounds))]
    for i in sorted(range(n_items), key=lambda i: (-costs[i], i)):
        load, count, j = heapq.heappop(heap)
        tasks[j].append(i)
        if count + 1 < MAX_CHUNK:
            heapq.heappush(heap, (load + costs[i], count + 1, j))
    return [sorted(t) for t in tasks]


def _chunk_outcome(future: distributed.Future[list[_R | TaskFailure]], n: int) -> list[_R | TaskFailure]:
    """The outcomes of one chunk's future, or ``n`` copies of its failure."""
    try:
        outcomes = future.result()
    except Exception as exc:  # lost more often than the scheduler allows (KilledWorker), or unpicklable
        return [TaskFailure(f"{type(exc).__name__}: {' '.join(str(exc).split())}")] * n
    return outcomes


def _dask_processes(
    guarded: _Guarded[_T, _R], items: list[_T], workers: int | None, progress: Callable[[int, int], None] | None
) -> list[_R | TaskFailure]:
    """dask's multiprocessing scheduler (no ``distributed``): one delayed call per item, computed together."""
    try:
        from dask.base import compute
        from dask.callbacks import Callback
        from dask.delayed import delayed
    except ImportError as exc:
        raise ImportError("the 'processes' scheduler needs dask: pip install 'dualpose[dask]' "
                          "(or use the 'serial' scheduler)") from exc  # fmt: skip
    tasks = [delayed(guarded, pure=False)(item) for item in items]
    total = len(items)

    class _Count(Callback):
        def __init__(self) -> None:
            super().__init__()  # type: ignore[no-untyped-call]
            self.done = 0

        def _posttask(self, key: object, result: object, dsk: object, state: object, worker_id: object) -> None:
            self.done += 1
            if progress is not None:
                progress(min(self.done, total), total)

    with _Count():
        results = compute(*tasks, scheduler="processes", num_workers=workers or os.cpu_count() or 1)  # type: ignore[no-untyped-call]
    return list(results)
