"""Pose from correspondences (Walker, Shao & Volz 1991 §3): single problems, batches, robust fits, hand–eye.

Import explicitly (``import dualpose.registration``); ``import dualpose`` does not load it.  Layouts follow
dualpose: points and directions ``(..., n, 3)``, quaternions xyzw, dual quaternions ``[real xyzw, dual xyzw]``.
"""

from dualpose.registration.batch import PoseBatch, register_pose_batch
from dualpose.registration.estimate import PoseEstimate, classify_degeneracy, register_pose
from dualpose.registration.hand_eye import HandEyeResult, HandEyeWarning, calibrate_hand_eye, hand_eye_motions
from dualpose.registration.hand_eye_closed_form import (
    HAND_EYE_CLOSED_FORMS,
    hand_eye_andreff,
    hand_eye_daniilidis,
    hand_eye_horaud_dornaika,
    hand_eye_park_martin,
    hand_eye_translation,
    hand_eye_tsai_lenz,
)
from dualpose.registration.robust import RobustEstimate, ransac_iterations, register_pose_irls, register_pose_ransac

__all__ = [
    "HAND_EYE_CLOSED_FORMS",
    "HandEyeResult",
    "HandEyeWarning",
    "calibrate_hand_eye",
    "hand_eye_andreff",
    "hand_eye_daniilidis",
    "hand_eye_horaud_dornaika",
    "hand_eye_motions",
    "hand_eye_park_martin",
    "hand_eye_translation",
    "hand_eye_tsai_lenz",
    "PoseBatch",
    "PoseEstimate",
    "RobustEstimate",
    "classify_degeneracy",
    "ransac_iterations",
    "register_pose",
    "register_pose_batch",
    "register_pose_irls",
    "register_pose_ransac",
]
