"""Fixtures of the many-run job tests: a real ``dask.distributed.LocalCluster`` with two worker processes, the one
``run_tasks`` starts (:func:`dualpose.jobs.scheduler.local_cluster`; skipped,
with the reason, when distributed is not installed) and trajectory files laid out as a manifest and as an
rpg_trajectory_evaluation results folder."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from jobfiles import write_eval_manifest, write_rpg_results


@pytest.fixture(scope="module")
def cluster_address() -> Iterator[str]:
    """The address of a LocalCluster of 2 worker processes (1 thread each), closed after the module."""
    pytest.importorskip("distributed", reason="dask.distributed is not installed (pip install 'dualpose[dask]'; the "
                        "test extra installs it)")  # fmt: skip
    from dualpose.jobs.scheduler import local_cluster

    with local_cluster(2) as cluster:
        yield cluster.scheduler_address


@pytest.fixture
def eval_manifest(tmp_path: Path) -> Path:
    """:func:`jobfiles.write_eval_manifest` in ``tmp_path``."""
    return write_eval_manifest(tmp_path)


@pytest.fixture
def rpg_results(tmp_path: Path) -> Path:
    """:func:`jobfiles.write_rpg_results` in ``tmp_path``."""
    return write_rpg_results(tmp_path)
