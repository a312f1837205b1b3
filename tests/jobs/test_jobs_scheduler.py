"""run_tasks on every scheduler: results in item order, a failing item kept in its row with its reason, the same
outcomes serially and on a real LocalCluster of worker processes, and a worker killed mid-job losing and
duplicating nothing."""

from __future__ import annotations

import math
import os
import signal
import sqlite3
import time
from pathlib import Path

import numpy as np
import pytest

from dualpose.jobs import scheduler
from dualpose.jobs.monte_carlo import run_monte_carlo
from dualpose.jobs.scheduler import (
    MAX_CHUNK,
    TASKS_PER_WORKER,
    TaskFailure,
    chunk_bounds,
    chunk_indices,
    default_scheduler,
    file_bytes,
    run_tasks,
)

ITEMS = [4.0, -1.0, 9.0, 2.25, "x", 0.0]
#: math.sqrt on ITEMS: the domain error and the type error stay in their rows
EXPECTED = [2.0, TaskFailure("math domain error"), 3.0, 1.5, None, 0.0]


def _check(out: list) -> None:
    assert len(out) == len(ITEMS)
    for got, want in zip(out, EXPECTED, strict=True):
        if want is None:
            assert isinstance(got, TaskFailure) and got.reason.startswith("TypeError: must be real number")
        else:
            assert got == want


def test_serial_order_failures_and_progress() -> None:
    seen: list[tuple[int, int]] = []
    _check(run_tasks(math.sqrt, ITEMS, scheduler="serial", progress=lambda d, t: seen.append((d, t))))
    assert seen == [(k, len(ITEMS)) for k in range(1, len(ITEMS) + 1)]
    assert run_tasks(math.sqrt, [], scheduler="serial") == []


@pytest.mark.parametrize("n_items", [0, 1, 5, 16, 100, 101, 200, 1000, 4099])
@pytest.mark.parametrize("n_workers", [1, 2, 3, 8])
def test_chunks_cover_every_item_once_balanced_over_the_workers(n_items: int, n_workers: int) -> None:
    bounds = chunk_bounds(n_items, n_workers)
    assert [i for a, b in bounds for i in range(a, b)] == list(range(n_items))  # contiguous, in order, once each
    sizes = [b - a for a, b in bounds]
    if n_items:
        assert max(sizes) - min(sizes) <= 1 and min(sizes) >= 1 and max(sizes) <= MAX_CHUNK
        assert len(bounds) == n_items or len(bounds) % n_workers == 0
        assert len(bounds) >= min(n_items, TASKS_PER_WORKER * n_workers)


@pytest.mark.parametrize("n_items", [0, 1, 5, 16, 64, 101, 1000, 4099])
@pytest.mark.parametrize("n_workers", [1, 2, 3, 8])
def test_cost_chunks_cover_every_item_once_with_balanced_costs(n_items: int, n_workers: int) -> None:
    rng = np.random.default_rng(n_items * 10 + n_workers)
    costs = list(rng.lognormal(0.0, 1.0, n_items))
    tasks = chunk_indices(n_items, n_workers, costs)
    assert sorted(i for t in tasks for i in t) == list(range(n_items)) and all(t == sorted(t) for t in tasks)
    assert len(tasks) == len(chunk_bounds(n_items, n_workers)) and all(0 < len(t) <= MAX_CHUNK for t in tasks)
    loads = [sum(costs[i] for i in t) for t in tasks]
    if tasks and max(len(t) for t in tasks) < MAX_CHUNK:  # no task full: the longest-first bound
        assert max(loads) - min(loads) <= max(costs) * (1 + 1e-12)
    for equal in (1.0, 0.0):  # equal costs (zero too) deal the items out in turn
        sizes = [len(t) for t in chunk_indices(n_items, n_workers, [equal] * n_items)]
        assert not sizes or max(sizes) - min(sizes) <= 1
    assert chunk_indices(n_items, n_workers) == [list(range(a, b)) for a, b in chunk_bounds(n_items, n_workers)]


def test_cost_chunks_balance_sorted_lengths() -> None:
    """Items sorted by length, 4 tasks: consecutive chunks would give one task 7 times another's cost."""
    costs = [float(k) for k in range(1, 41)]
    loads = [sum(costs[i] for i in t) for t in chunk_indices(40, 2, costs)]
    assert max(loads) - min(loads) <= 1.0
    consecutive = [sum(costs[a:b]) for a, b in chunk_bounds(40, 2)]
    assert max(consecutive) / min(consecutive) > 6


def test_file_bytes(tmp_path: Path) -> None:
    (tmp_path / "a.txt").write_bytes(b"x" * 10)
    (tmp_path / "b.bag").write_bytes(b"y" * 7)
    assert file_bytes(str(tmp_path / "a.txt"), str(tmp_path / "b.bag") + ":/pose") == 17.0
    assert file_bytes(str(tmp_path / "missing.txt")) == 0.0


def test_bad_scheduler_and_workers_are_refused() -> None:
    with pytest.raises(ValueError, match="scheduler must be 'serial', 'processes' or a cluster address"):
        run_tasks(math.sqrt, [1.0], scheduler="threads")
    with pytest.raises(ValueError, match="workers must be an integer >= 1"):
        run_tasks(math.sqrt, [1.0], scheduler="serial", workers=0)
    assert default_scheduler() in ("serial", "processes")


def test_unreachable_address_is_an_oserror(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("distributed", reason="dask.distributed is not installed")
    monkeypatch.setattr(scheduler, "CONNECT_TIMEOUT_S", 1.0)
    with pytest.raises(OSError, match="cannot reach the dask scheduler at tcp://127.0.0.1:9"):
        run_tasks(math.sqrt, [1.0], scheduler="tcp://127.0.0.1:9")


def test_cluster_with_costs_gives_the_serial_outcomes_in_order(cluster_address: str) -> None:
    """Grouped by cost, the items leave their order in the dask tasks; the outcomes come back in item order."""
    costs = {id(item): c for item, c in zip(ITEMS, [1.0, 9.0, 2.0, 8.0, 3.0, 7.0], strict=True)}
    assert chunk_indices(len(ITEMS), 2, list(costs.values()))[0] != [0, 1]
    seen: list[int] = []
    _check(run_tasks(math.sqrt, ITEMS, scheduler=cluster_address, cost=lambda item: costs[id(item)],
                     progress=lambda d, t: seen.append(d)))  # fmt: skip
    assert seen[-1] == len(ITEMS)
    with pytest.raises(ValueError, match="cost must return a finite number >= 0; got -1.0"):
        run_tasks(math.sqrt, ITEMS, scheduler=cluster_address, cost=lambda item: -1.0)
    assert run_tasks(math.sqrt, ITEMS, scheduler="serial", cost=lambda item: -1.0)[0] == 2.0  # not called serially


def test_cluster_gives_the_serial_outcomes_in_order(cluster_address: str) -> None:
    seen: list[int] = []
    out = run_tasks(math.sqrt, ITEMS, scheduler=cluster_address, progress=lambda d, t: seen.append(d))
    _check(out)
    # one report per dask task, as each finishes (in any order): the rows done so far, up to all of them
    sizes = sorted(b - a for a, b in chunk_bounds(len(ITEMS), 2))
    assert sorted(b - a for a, b in zip([0, *seen[:-1]], seen, strict=True)) == sizes and seen[-1] == len(ITEMS)


def _job_keys(dask_scheduler: object) -> list[str]:
    """The job tasks the scheduler still holds (run on the scheduler)."""
    return [str(k) for k in dask_scheduler.tasks if str(k).startswith("dualpose-task-")]  # type: ignore[attr-defined]


def test_a_connected_client_runs_many_jobs_and_stays_connected(cluster_address: str) -> None:
    """``client=``: the jobs run on the caller's client, which stays connected; each job releases its tasks (the
    scheduler forgets them) and closes nothing."""
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")
    with distributed.Client(cluster_address, set_as_default=False) as client:
        for _ in range(2):
            seen: list[int] = []
            _check(run_tasks(math.sqrt, ITEMS, client=client, progress=lambda d, t, seen=seen: seen.append(d)))
            assert seen[-1] == len(ITEMS) and len(seen) == len(chunk_bounds(len(ITEMS), 2))
            assert client.status == "running"
        assert run_tasks(math.sqrt, [], client=client) == []
        for _ in range(100):  # releasing is a message to the scheduler: wait for it
            if not client.run_on_scheduler(_job_keys):
                break
            time.sleep(0.05)
        assert client.run_on_scheduler(_job_keys) == []


def test_a_bad_client_is_refused(cluster_address: str) -> None:
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")
    with pytest.raises(TypeError, match="client must be a synchronous distributed.Client; got 'tcp"):
        run_tasks(math.sqrt, ITEMS, client=cluster_address)  # type: ignore[arg-type]
    client = distributed.Client(cluster_address, set_as_default=False)
    with pytest.raises(ValueError, match="give either client or scheduler/workers, not both"):
        run_tasks(math.sqrt, ITEMS, client=client, scheduler=cluster_address)
    with pytest.raises(ValueError, match="give either client or scheduler/workers, not both"):
        run_tasks(math.sqrt, ITEMS, client=client, workers=2)
    client.close()
    with pytest.raises(ValueError, match="client must be connected; got a client whose status is 'closed'"):
        run_tasks(math.sqrt, ITEMS, client=client)


def _worker_settings() -> dict[str, object]:
    import dask.config

    return {"trim": os.environ.get("MALLOC_TRIM_THRESHOLD_"), "blas": os.environ.get("OPENBLAS_NUM_THREADS"),
            "omp": os.environ.get("OMP_NUM_THREADS"), "profile": dask.config.get("distributed.worker.profile.enabled"),
            "tick": dask.config.get("distributed.admin.tick.interval")}  # fmt: skip


def test_local_cluster_workers_allocate_as_the_serial_process(cluster_address: str) -> None:
    """The workers of ``local_cluster`` run without the nanny's ``MALLOC_TRIM_THRESHOLD_`` (glibc then keeps its
    adaptive mmap threshold) and without the profiler, with one BLAS thread."""
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")
    with distributed.Client(cluster_address, set_as_default=False) as client:
        settings = client.run(_worker_settings)
    assert len(settings) == 2
    for got in settings.values():
        assert got == {"trim": None, "blas": "1", "omp": "1", "profile": False, "tick": "1s"}


def test_a_result_that_cannot_be_sent_back_is_that_rows_failure(cluster_address: str) -> None:
    """``sqlite3.connect`` returns a connection, which cannot be pickled back to the client: the row fails with the
    reason, and the job ends."""
    out = run_tasks(sqlite3.connect, [":memory:"], scheduler=cluster_address)
    assert len(out) == 1 and isinstance(out[0], TaskFailure) and "serialize" in out[0].reason


def test_a_chunk_that_cannot_be_sent_back_leaves_the_other_chunks_outcomes(cluster_address: str) -> None:
    """The outcomes are fetched in one gather; when one chunk's cannot be sent back (an sqlite3 connection), each chunk
    is fetched on its own: that chunk's rows fail with the reason, the other rows keep their own outcomes (here
    ``sqlite3.connect``'s refusal of an int)."""
    items = [":memory:", 1, 2, 3]
    bounds = chunk_bounds(len(items), 2)
    assert len(bounds) > 1 and bounds[0] == (0, 1)
    out = run_tasks(sqlite3.connect, items, scheduler=cluster_address)
    assert isinstance(out[0], TaskFailure) and "serialize" in out[0].reason
    serial = run_tasks(sqlite3.connect, items[1:], scheduler="serial")
    assert out[1:] == serial and all(isinstance(got, TaskFailure) and "int" in got.reason for got in serial)


def test_own_local_cluster_gives_the_serial_outcomes() -> None:
    """The default scheduler starts its own cluster (:func:`scheduler.local_cluster`) for the job and closes it."""
    pytest.importorskip("distributed", reason="dask.distributed is not installed")
    _check(run_tasks(math.sqrt, ITEMS, scheduler="processes", workers=2))


def test_local_cluster_refuses_bad_workers() -> None:
    with pytest.raises(ValueError, match="workers must be an integer >= 1"):
        scheduler.local_cluster(0)


def test_dask_process_pool_without_a_cluster() -> None:
    """The fallback when distributed is missing: dask's multiprocessing scheduler (called directly here)."""
    pytest.importorskip("dask", reason="dask is not installed")
    from dualpose.jobs.scheduler import _dask_processes, _Guarded

    done: list[int] = []
    _check(_dask_processes(_Guarded(math.sqrt), ITEMS, 2, lambda d, t: done.append(d)))
    assert done and done[-1] == len(ITEMS)


def test_killed_worker_loses_and_duplicates_nothing(cluster_address: str) -> None:
    """SIGKILL one worker process while it holds unfinished tasks: the scheduler recomputes them elsewhere and the
    table equals the serial one, row for row, bit for bit."""
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")
    n = 16
    serial = run_monte_carlo(n, 40, scheduler="serial")
    with distributed.Client(cluster_address, set_as_default=False) as client:
        pids = client.run(os.getpid)
        killed: dict[str, list[str]] = {}

        def kill_busy_worker(done: int, total: int) -> None:
            if killed or done < 2:
                return
            busy = {addr: keys for addr, keys in client.processing().items() if keys}
            if busy:
                addr, keys = next(iter(busy.items()))
                os.kill(pids[addr], signal.SIGKILL)
                killed[addr] = [str(k) for k in keys]

        parallel = run_monte_carlo(n, 40, scheduler=cluster_address, progress=kill_busy_worker)
        assert killed, "no worker held a task when the job was two tasks in"
        lost = next(iter(killed.values()))

        def processing_starts(dask_scheduler, keys):
            return {k: sum(1 for e in dask_scheduler.story(k) if len(e) > 2 and e[2] == "processing") for k in keys}

        starts = client.run_on_scheduler(processing_starts, keys=lost)
        client.wait_for_workers(2, timeout=60)
    assert any(v >= 2 for v in starts.values()), f"no task of the killed worker was computed again: {starts}"
    assert parallel.failed == 0
    assert parallel.table.column("seed") == list(range(40, 40 + n))
    assert parallel.table.to_csv_text() == serial.table.to_csv_text()
    assert parallel.average_nees.tobytes() == serial.average_nees.tobytes()
