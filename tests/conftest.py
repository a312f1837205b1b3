"""Shared test settings: seeded randomness, a hypothesis profile sized for CI, and the BROAD trial the data tests
share."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings

settings.register_profile("ci", max_examples=150, deadline=None, derandomize=True)
settings.load_profile("ci")


@pytest.fixture
def dask_task_counter():
    """A context manager whose ``tasks`` counts the dask tasks run inside it (skips without dask)."""
    callbacks = pytest.importorskip("dask.callbacks")

    class TaskCounter(callbacks.Callback):
        def __init__(self) -> None:
            super().__init__()
            self.tasks = 0

        def _pretask(self, key, dask, state) -> None:
            self.tasks += 1

    return TaskCounter()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261122)


#: the BROAD trials beside the checkout (``<repo>/../shared/data/broad``)
BROAD_DIR = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"


@pytest.fixture(scope="session")
def trial():
    """BROAD trial 06 (fast rotation), loaded once; skipped when the data directory is missing."""
    if not BROAD_DIR.is_dir():
        pytest.skip("BROAD data directory missing")
    from dualpose.io import load_broad

    return load_broad(BROAD_DIR / "06_undisturbed_fast_rotation_A.mat")


#: 30 s of EuRoC V1_01_easy as GTSAM ships it, and its ground truth (GPL-3.0: read from here, never copied)
EUROC_V101_DIR = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "euroc" / "v101_30s"


@pytest.fixture(scope="session")
def euroc_v101():
    """``(eqvio csv path, ground-truth csv path)`` of the EuRoC V1_01 segment; skipped when the data are missing."""
    csv, gt = EUROC_V101_DIR / "eqvio_processed_30s.csv", EUROC_V101_DIR / "groundtruth.csv"
    if not (csv.is_file() and gt.is_file()):
        pytest.skip("EuRoC v101_30s data directory missing")
    return csv, gt
