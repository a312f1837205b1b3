"""Checks of a :class:`~dualpose.types.recording.Recording` before and after the static alignment of
``dualpose fuse`` (docs/fusion.md, "Checks on the input").

Refused (:class:`dualpose.io.recording.RecordingError`, naming the recording): an IMU stream too short to hold a rest
period and some motion, and a ``gravity`` that points up (the specific force at rest, rotated to the world with the
first-frame attitude, must point opposite to gravity).  Warned (:class:`dualpose.types.recording.RecordingWarning`):
IMU gaps longer than a few sample periods, and a gravity vector more than 10° off the measured vertical or of the
wrong magnitude.
"""

from __future__ import annotations

import numpy as np

from dualpose.estimation.state import ESKF_STATE
from dualpose.io.recording import RecordingError
from dualpose.types import Recording

__all__ = ["MIN_IMU_SAMPLES", "MIN_IMU_SECONDS", "check_before_fuse", "check_gravity_after_alignment"]

#: ``dualpose fuse`` needs a rest period (the static alignment) and then motion: at least this much IMU data
MIN_IMU_SAMPLES = 50
MIN_IMU_SECONDS = 1.0


def check_before_fuse(run: Recording) -> None:
    """Refuse a recording too short to fuse; warn about IMU gaps (:meth:`Recording.check_imu_gaps`)."""
    if len(run.t) < MIN_IMU_SAMPLES or run.duration < MIN_IMU_SECONDS:
        raise RecordingError(
            f"{run.name or 'recording'}: imu: {len(run.t)} samples over {run.duration:.3f} s; fusing needs at least "
            f"{MIN_IMU_SAMPLES} samples and {MIN_IMU_SECONDS:g} s (a rest period for the static alignment, then motion)"
        )
    run.check_imu_gaps()


def check_gravity_after_alignment(run: Recording, x: np.ndarray) -> None:
    """:meth:`Recording.check_gravity` with the start attitude ``q_wb`` of the error-state filter state ``x``
    (:data:`~dualpose.estimation.state.ESKF_STATE`);
    a gravity that points up is a :class:`RecordingError`."""
    try:
        run.check_gravity(ESKF_STATE.get(x, "quat"))
    except ValueError as exc:
        raise RecordingError(str(exc)) from None
