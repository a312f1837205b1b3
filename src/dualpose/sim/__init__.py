"""The seeded simulator (Hol 2008 set-up) and the calibration scenarios built on it.

* :mod:`~dualpose.sim.motion`: closed-form smooth body motions (:class:`SmoothMotion`, Hol's eight).
* :mod:`~dualpose.sim.camera_imu`: IMU samples and camera correspondences along a motion (:func:`simulate`,
  :func:`simulate_eight`), with exact truth; :func:`recording_from_simulation` turns a run into the
  :class:`~dualpose.types.Recording` the estimators and pipelines take.
* :mod:`~dualpose.sim.calibration_scenarios`: static calibration poses and random extrinsics.
* :mod:`~dualpose.sim.hand_eye_recordings`: seeded hand–eye pose-stream pairs (arm, hand-held rig, sparse motion
  capture) with known ``X`` and time offset (:func:`simulate_hand_eye`).
* :mod:`~dualpose.sim.broad_vision`: pseudo-vision rendered along a real BROAD trial's reference motion.

Frames: world ``w``, IMU body ``b``, camera ``c``; quaternions xyzw (``q_wb`` body -> world).
"""

from dualpose.sim.camera_imu import (
    CameraFrames,
    SimulatedRun,
    camera_points,
    observe_landmarks,
    recording_from_simulation,
    simulate,
    simulate_eight,
    two_plane_landmarks,
)
from dualpose.sim.hand_eye_recordings import HAND_EYE_KINDS, HandEyeRecording, simulate_hand_eye
from dualpose.sim.motion import (
    CAMERA_HOME,
    SCENE_TARGET,
    SmoothMotion,
    default_extrinsic,
    eight_motion,
    look_at_quat,
    random_motion,
)

__all__ = [
    "CAMERA_HOME",
    "HAND_EYE_KINDS",
    "HandEyeRecording",
    "SCENE_TARGET",
    "CameraFrames",
    "SimulatedRun",
    "SmoothMotion",
    "camera_points",
    "default_extrinsic",
    "eight_motion",
    "look_at_quat",
    "observe_landmarks",
    "random_motion",
    "recording_from_simulation",
    "simulate",
    "simulate_eight",
    "simulate_hand_eye",
    "two_plane_landmarks",
]
