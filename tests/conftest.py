"""Shared test settings: seeded randomness, a hypothesis profile sized for CI, the real-data directories
(:mod:`realdata`: the full recordings beside the checkout or the cuts in ``tests/data/``) and the BROAD trial the data
tests share."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import settings

from realdata import data_dir

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


#: the BROAD trials beside the checkout (``<repo>/../shared/data/broad``), else their cuts in ``tests/data/broad``
BROAD_DIR = data_dir("broad")


@pytest.fixture(scope="session")
def real_data():
    """:func:`realdata.data_dir`: ``real_data("handeye")`` is the full recordings' directory or the shipped cut,
    ``real_data("broad", full=True)`` the full one only."""
    return data_dir


@pytest.fixture(scope="session")
def trial():
    """BROAD trial 06 (fast rotation; the full trial, or its cut in a plain clone), loaded once; skipped when
    neither is there."""
    if not BROAD_DIR.is_dir():
        pytest.skip("BROAD data directory missing")
    from dualpose.io import load_broad

    return load_broad(BROAD_DIR / "06_undisturbed_fast_rotation_A.mat")


#: 30 s of EuRoC V1_01_easy as GTSAM ships it, and its ground truth (GPL-3.0: read from here, never copied)
EUROC_V101_DIR = data_dir("euroc/v101_30s", full=True)


@pytest.fixture(scope="session")
def euroc_v101():
    """``(eqvio csv path, ground-truth csv path)`` of the EuRoC V1_01 segment; skipped when the data are missing."""
    csv, gt = EUROC_V101_DIR / "eqvio_processed_30s.csv", EUROC_V101_DIR / "groundtruth.csv"
    if not (csv.is_file() and gt.is_file()):
        pytest.skip("EuRoC v101_30s data directory missing")
    return csv, gt


#: EuRoC's imu_april target recording (the full one: the tests on it check whole-recording numbers)
EUROC_APRIL_DIR = data_dir("euroc/imu_april", full=True)


@pytest.fixture(scope="session")
def euroc_april():
    """The imu_april directory (imu0.csv, cam0/cam1_aprilgrid.csv, sensors.yaml); skipped when it is missing."""
    if not (EUROC_APRIL_DIR / "cam0_aprilgrid.csv").is_file():
        pytest.skip(f"EuRoC imu_april data missing ({EUROC_APRIL_DIR})")
    return EUROC_APRIL_DIR
