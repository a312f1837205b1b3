"""Shared test settings: seeded randomness, a hypothesis profile sized for CI, and the BROAD trial the data tests
share."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings

settings.register_profile("ci", max_examples=150, deadline=None, derandomize=True)
settings.load_profile("ci")


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


#: EuRoC's imu_april target recording beside the checkout (``<repo>/../shared/data/euroc/imu_april``;
#: ``DUALPOSE_SHARED_DATA`` names another ``shared/data`` directory)
EUROC_APRIL_DIR = (
    Path(os.environ.get("DUALPOSE_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))
    / "euroc"
    / "imu_april"
)


@pytest.fixture(scope="session")
def euroc_april() -> Path:
    """The imu_april directory (imu0.csv, cam0/cam1_aprilgrid.csv, sensors.yaml); skipped when it is missing."""
    if not (EUROC_APRIL_DIR / "cam0_aprilgrid.csv").is_file():
        pytest.skip(f"EuRoC imu_april data missing ({EUROC_APRIL_DIR})")
    return EUROC_APRIL_DIR
