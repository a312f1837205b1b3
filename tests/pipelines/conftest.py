"""Fixtures of the target-tracking tests: the simulated calibration-target recording (``_target_sim``) and its
filter set-up, one per test module."""

from __future__ import annotations

import pytest
from _target_sim import simulated_target_recording

from dualpose.pipelines.track_target import TrackSetup, prepare_track


@pytest.fixture(scope="module")
def simulated():
    """``(TargetRecording, calibration, truth, reference extrinsics)`` of seed 0 (``simulated_target_recording``)."""
    return simulated_target_recording(0)


@pytest.fixture(scope="module")
def simulated_setup(simulated) -> TrackSetup:
    """:func:`~dualpose.pipelines.track_target.prepare_track` of :func:`simulated` for cam0, default options."""
    src, cal, _, _ = simulated
    return prepare_track(src, cal, "cam0")
