"""Feature tracks: 2-D observations of unknown scene points, identified across frames by a track id.

What a visual–inertial odometer (:mod:`dualpose.estimation.msckf`) consumes: no 3-D landmark is known.

* :class:`TrackFrame` — the observations of one camera frame (streaming: one frame at a time);
* :class:`FeatureTracks` — all frames, flattened (frame ``k`` owns rows ``offsets[k]:offsets[k+1]``);
* :class:`TrackRecording` — IMU samples, feature tracks and the sensor set-up of one run.

Coordinates are *normalised* image coordinates ``(u, v) = (X/Z, Y/Z)`` of the undistorted ray in the camera frame
(dimensionless), the representation the estimator works in; :meth:`FeatureTracks.from_pixels` converts raw pixels
with a camera model (:mod:`dualpose.types.camera_models`, its ``unproject``).  Times in seconds.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dualpose.types.camera import PinholeModel
from dualpose.types.imu import ImuNoise

__all__ = ["TrackFrame", "FeatureTracks", "TrackRecording"]


@dataclass(frozen=True)
class TrackFrame:
    """The feature observations of one camera frame.

    ``t`` camera-clock stamp (s); ``track_id`` (m,) int64, unique within the frame; ``uv`` (m, 2) normalised image
    coordinates ``(X/Z, Y/Z)`` in the camera frame.
    """

    t: float
    track_id: np.ndarray
    uv: np.ndarray

    def __post_init__(self) -> None:
        ids = np.ascontiguousarray(self.track_id, dtype=np.int64).reshape(-1)
        uv = np.ascontiguousarray(self.uv, dtype=np.float64)
        if uv.ndim != 2 or uv.shape != (len(ids), 2):
            raise ValueError(f"uv must have shape ({len(ids)}, 2) to match track_id (m,); got {uv.shape}")
        if not math.isfinite(self.t):
            raise ValueError(f"t must be a finite time in seconds; got {self.t!r}")
        if not np.isfinite(uv).all():
            raise ValueError("uv must be finite")
        if len(np.unique(ids)) != len(ids):
            raise ValueError(f"track_id must be unique within a frame (frame at t={self.t})")
        object.__setattr__(self, "t", float(self.t))
        object.__setattr__(self, "track_id", ids)
        object.__setattr__(self, "uv", uv)


@dataclass
class FeatureTracks:
    """Feature observations of all frames, flattened.

    Attributes
    ----------
    t : ndarray (F,)
        Camera-clock frame stamps, s, strictly increasing.
    offsets : ndarray (F + 1,) int64
        Frame ``k`` owns rows ``offsets[k]:offsets[k+1]`` of ``track_id`` and ``uv``.
    track_id : ndarray (M,) int64
        Track of every observation (unique within a frame).
    uv : ndarray (M, 2)
        Normalised image coordinates ``(X/Z, Y/Z)``, camera frame.
    """

    t: np.ndarray
    offsets: np.ndarray
    track_id: np.ndarray
    uv: np.ndarray

    def __post_init__(self) -> None:
        self.t = np.ascontiguousarray(self.t, dtype=np.float64).reshape(-1)
        self.offsets = np.ascontiguousarray(self.offsets, dtype=np.int64).reshape(-1)
        self.track_id = np.ascontiguousarray(self.track_id, dtype=np.int64).reshape(-1)
        self.uv = np.ascontiguousarray(self.uv, dtype=np.float64)
        m = len(self.track_id)
        if self.offsets.shape != (len(self.t) + 1,):
            raise ValueError(f"offsets must have shape (F + 1,) = ({len(self.t) + 1},); got {self.offsets.shape}")
        if self.offsets[0] != 0 or self.offsets[-1] != m or np.any(np.diff(self.offsets) < 0):
            raise ValueError(f"offsets must rise from 0 to the number of observations {m}")
        if self.uv.shape != (m, 2):
            raise ValueError(f"uv must have shape ({m}, 2); got {self.uv.shape}")
        if np.any(np.diff(self.t) <= 0) or not np.isfinite(self.t).all():
            raise ValueError("frame stamps t must be finite and strictly increasing")
        if not np.isfinite(self.uv).all():
            raise ValueError("uv must be finite")

    def __len__(self) -> int:
        return len(self.t)

    def frame(self, k: int) -> TrackFrame:
        """Frame ``k`` as a :class:`TrackFrame`."""
        a, b = self.offsets[k], self.offsets[k + 1]
        return TrackFrame(float(self.t[k]), self.track_id[a:b], self.uv[a:b])

    def __iter__(self) -> Iterator[TrackFrame]:
        return (self.frame(k) for k in range(len(self)))

    @property
    def counts(self) -> NDArray[np.int64]:
        """Observations per frame (F,)."""
        return np.diff(self.offsets)

    @classmethod
    def from_frames(cls, frames: list[TrackFrame]) -> FeatureTracks:
        """Flatten a list of :class:`TrackFrame`."""
        counts = [len(f.track_id) for f in frames]
        offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        ids = np.concatenate([f.track_id for f in frames]) if frames else np.zeros(0, np.int64)
        uv = np.concatenate([f.uv for f in frames]) if frames else np.zeros((0, 2))
        return cls(np.array([f.t for f in frames], dtype=np.float64), offsets, ids, uv)

    @classmethod
    def from_pixels(cls, t: np.ndarray, offsets: np.ndarray, track_id: np.ndarray, pixels: np.ndarray,
                    camera: PinholeModel) -> FeatureTracks:  # fmt: skip
        """Tracks from raw pixels (M, 2) and a camera model with ``unproject(pixels, return_valid=True)`` returning
        normalised coordinates (:class:`~dualpose.types.RadTanCamera`, :class:`~dualpose.types.EquidistantCamera`) or
        a pinhole with ``fx, fy, cx, cy``.  Pixels the model cannot undistort raise a ``ValueError``."""
        pixels = np.asarray(pixels, dtype=np.float64)
        if pixels.ndim != 2 or pixels.shape[1] != 2:
            raise ValueError(f"pixels must have shape (M, 2); got {pixels.shape}")
        if hasattr(camera, "unproject"):
            uv, valid = camera.unproject(pixels, return_valid=True)
            if not np.all(valid):
                raise ValueError(f"pixel row {int(np.argmin(valid))} cannot be undistorted by the camera model")
        else:
            uv = np.stack([(pixels[:, 0] - camera.cx) / camera.fx, (pixels[:, 1] - camera.cy) / camera.fy], axis=1)
        return cls(t, offsets, track_id, uv)


@dataclass
class TrackRecording:
    """IMU samples, feature tracks and sensor set-up of one visual–inertial run (no 3-D scene).

    Attributes
    ----------
    t : ndarray (N,)
        IMU times, s (IMU clock), strictly increasing.
    gyro, accel : ndarray (N, 3)
        Body-frame angular rate (rad/s) and specific force (m/s²).
    tracks : FeatureTracks
        Camera-clock frame stamps and normalised observations.
    q_bc, p_bc : ndarray (4,), (3,)
        Camera axes in the body (IMU) frame (xyzw) and the camera centre in the body frame, m.
    imu_noise : ImuNoise
        Continuous-time noise densities and random walks (Kalibr conventions).
    feature_sigma : float
        Standard deviation of a normalised coordinate (dimensionless; pixel σ / focal length).
    time_offset : float
        ``t_imu = t_cam + time_offset``, s.
    focal_length : float
        Focal length in pixels (NaN if unknown), to report normalised errors in pixels.
    t0 : float
        Absolute time of ``t = 0`` (s, e.g. Unix time), to write absolute stamps; 0 if the file's are absolute.
    meta : dict
        Any further key–value settings of the source file.
    name : str
    """

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    tracks: FeatureTracks
    q_bc: np.ndarray
    p_bc: np.ndarray
    imu_noise: ImuNoise
    feature_sigma: float
    time_offset: float = 0.0
    focal_length: float = float("nan")
    t0: float = 0.0
    meta: dict[str, Any] = field(default_factory=dict)
    name: str = ""

    def __post_init__(self) -> None:
        self.t = np.ascontiguousarray(self.t, dtype=np.float64).reshape(-1)
        n = len(self.t)
        for name in ("gyro", "accel"):
            a = np.ascontiguousarray(getattr(self, name), dtype=np.float64)
            if a.shape != (n, 3):
                raise ValueError(f"{name} must have shape ({n}, 3) to match t; got {a.shape}")
            if not np.isfinite(a).all():
                raise ValueError(f"{name} must be finite")
            setattr(self, name, a)
        if n < 2 or np.any(np.diff(self.t) <= 0):
            raise ValueError("IMU times t must be at least two strictly increasing stamps")
        self.q_bc = np.asarray(self.q_bc, dtype=np.float64).reshape(4) / np.linalg.norm(self.q_bc)
        self.p_bc = np.asarray(self.p_bc, dtype=np.float64).reshape(3)
        if not (self.feature_sigma > 0 and math.isfinite(self.feature_sigma)):
            raise ValueError(f"feature_sigma must be a positive finite number; got {self.feature_sigma!r}")
