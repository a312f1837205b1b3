"""Calibration from recorded data: hand–eye calibration with time offset on unsynchronised pose streams.

Import explicitly (``import dualpose.calibration``); ``import dualpose`` does not load it.  Frames and residuals are
described in ``docs/hand-eye.md``.
"""

from dualpose.calibration.hand_eye_joint import HandEyeStreamResult, calibrate_hand_eye_streams
from dualpose.calibration.hand_eye_residual import (
    LoopResidual,
    fit_hand_eye,
    loop_residual,
    pair_motions,
    pair_residuals,
    select_pairs,
)
from dualpose.calibration.hand_eye_streams import (
    CleaningReport,
    PoseStream,
    clean_pose_stream,
    default_max_gap,
    interpolate_stream,
)
from dualpose.calibration.hand_eye_time import CoarseOffset, angular_rate_signal, coarse_time_offset

__all__ = [
    "CleaningReport",
    "CoarseOffset",
    "HandEyeStreamResult",
    "LoopResidual",
    "PoseStream",
    "angular_rate_signal",
    "calibrate_hand_eye_streams",
    "clean_pose_stream",
    "coarse_time_offset",
    "default_max_gap",
    "fit_hand_eye",
    "interpolate_stream",
    "loop_residual",
    "pair_motions",
    "pair_residuals",
    "select_pairs",
]
