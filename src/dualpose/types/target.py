"""Calibration-target detections and a camera rig's sensor description (what :mod:`dualpose.io` reads for them).

* :class:`TargetDetections`: per camera frame, the detected target corners (pixels, as measured, with distortion)
  and their positions in the target frame.
* :class:`RigSensors`: distorted cameras, their rates and relative poses, the IMU noise, the target geometry.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose.types import _inputs
from dualpose.types.camera import FrameCorrespondences
from dualpose.types.camera_models import DistortedCamera
from dualpose.types.imu import ImuNoise

__all__ = ["TargetDetections", "RigSensors"]


@dataclass(frozen=True)
class TargetDetections:
    """Detected calibration-target corners of a camera, frame by frame (flattened like
    :class:`~dualpose.types.camera.FrameCorrespondences`).

    Attributes
    ----------
    stamps_ns : ndarray of int64, shape (F,)
        Exact frame timestamps, nanoseconds, strictly increasing.
    t : ndarray, shape (F,)
        The same in float64 seconds (:func:`~dualpose.types.trajectory.seconds_from_ns`; refused when they
        disagree).
    offsets : ndarray of int64, shape (F + 1,)
        Frame ``k`` owns corner rows ``offsets[k]:offsets[k+1]`` (frames without detections own none).
    pixels : ndarray, shape (M, 2)
        Measured (distorted) pixel coordinates ``u, v``.
    points : ndarray, shape (M, 3)
        The corners' positions in the target frame, metres.
    tag_id, corner_id : ndarray of int64, shape (M,)
        Tag and corner index of each row.
    path : str
        Source file ("" when built in memory).
    """

    stamps_ns: np.ndarray
    t: np.ndarray
    offsets: np.ndarray
    pixels: np.ndarray
    points: np.ndarray
    tag_id: np.ndarray
    corner_id: np.ndarray
    path: str = ""

    def __post_init__(self) -> None:
        f = len(self.stamps_ns)
        m = self.pixels.shape[0]
        checks = (
            (self.t.shape == (f,), "t", f"({f},)"),
            (self.offsets.shape == (f + 1,), "offsets", f"({f + 1},)"),
            (self.pixels.shape == (m, 2), "pixels", "(M, 2)"),
            (self.points.shape == (m, 3), "points", f"({m}, 3)"),
            (self.tag_id.shape == (m,), "tag_id", f"({m},)"),
            (self.corner_id.shape == (m,), "corner_id", f"({m},)"),
        )
        for ok, name, want in checks:
            if not ok:
                raise ValueError(f"{name} must have shape {want}; got {getattr(self, name).shape}")
        if f and (self.offsets[0] != 0 or self.offsets[-1] != m or (np.diff(self.offsets) < 0).any()):
            raise ValueError("offsets must rise from 0 to M (the number of corner rows)")
        _inputs.check_stamps_agree(self.t, self.stamps_ns, "t")

    def __len__(self) -> int:
        return len(self.stamps_ns)

    @property
    def counts(self) -> NDArray[np.int64]:
        """Corners per frame, shape (F,) int64."""
        return np.diff(self.offsets)

    def frame(self, k: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(pixels (m, 2), points (m, 3))`` of frame ``k``."""
        a, b = self.offsets[k], self.offsets[k + 1]
        return self.pixels[a:b], self.points[a:b]

    def correspondences(
        self, camera: DistortedCamera | None = None, *, drop_invalid: bool = False
    ) -> FrameCorrespondences:
        """All frames as :class:`~dualpose.types.camera.FrameCorrespondences` (``points`` in the target frame).

        With ``camera``, the pixels are converted to the undistorted pinhole camera ``camera.pinhole()`` by
        ``camera.ideal_pixels``; a detection outside the camera's invertible region is a ``ValueError``, or, with
        ``drop_invalid=True``, left out (its frame keeps the others).  Without ``camera``, the measured pixels are
        used as they are.
        """
        if camera is None:
            return FrameCorrespondences(self.t.copy(), self.offsets.copy(), self.pixels.copy(), self.points.copy())
        pixels, valid = camera.ideal_pixels(self.pixels, return_valid=True)
        if valid.all():
            return FrameCorrespondences(self.t.copy(), self.offsets.copy(), pixels, self.points.copy())
        if not drop_invalid:
            k = int(np.argmax(~valid))
            raise ValueError(
                f"{int((~valid).sum())} detections (first: row {k}, pixel {self.pixels[k].tolist()}) are outside the "
                "invertible region of the camera's distortion; pass drop_invalid=True to leave them out"
            )
        frame_of_row = np.repeat(np.arange(len(self)), self.counts)
        offsets = np.concatenate([[0], np.cumsum(np.bincount(frame_of_row[valid], minlength=len(self)))])
        return FrameCorrespondences(self.t.copy(), offsets.astype(np.int64), pixels[valid], self.points[valid])

    def select(self, frames: ArrayLike) -> TargetDetections:
        """A new :class:`TargetDetections` with the frames where the boolean mask ``frames`` (F,) is true."""
        mask = np.asarray(frames)
        if mask.dtype != bool or mask.shape != (len(self),):
            raise ValueError(f"frames must be a boolean mask of shape ({len(self)},); got {mask.dtype} {mask.shape}")
        counts = self.counts[mask]
        rows = np.repeat(mask, self.counts)
        offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        return TargetDetections(
            self.stamps_ns[mask], self.t[mask], offsets, self.pixels[rows], self.points[rows],
            self.tag_id[rows], self.corner_id[rows], self.path,
        )  # fmt: skip


@dataclass(frozen=True)
class RigSensors:
    """A camera–IMU rig's sensors as a calibration file states them.

    Attributes
    ----------
    cameras : dict[str, RadTanCamera | EquidistantCamera]
        By name (``"cam0"``, ...), in file order.
    camera_rates : dict[str, float]
        Frame rates, Hz (NaN where the file gives none).
    imu_noise : ImuNoise
        Kalibr noise densities and random walks; ``update_rate`` the IMU rate.
    imu_rate : float
        Hz (NaN where the file gives none).
    gravity_magnitude : float
        m/s² (NaN where the file gives none).
    camera_extrinsics : dict[(str, str), ndarray (4, 4)]
        ``camera_extrinsics[(a, b)]`` is ``T_a_b``, the pose of camera ``b`` in camera ``a`` (``x_a = T_a_b x_b``),
        as given by the file (see :meth:`relative_pose` for any pair).
    T_cam_imu : dict[str, ndarray (4, 4)]
        ``T_cam_imu[c]``: IMU frame -> camera ``c`` (``x_c = T x_imu``), where the file gives it (Kalibr camchain).
    time_offsets : dict[str, float]
        Kalibr ``timeshift_cam_imu`` (s, ``t_imu = t_cam + shift``) where given.
    target : dict
        The target geometry as the file states it (e.g. ``type``, ``tag_rows``, ``tag_size_m``).
    path : str
    """

    cameras: dict[str, DistortedCamera]
    camera_rates: dict[str, float]
    imu_noise: ImuNoise | None
    imu_rate: float
    gravity_magnitude: float
    camera_extrinsics: dict[tuple[str, str], NDArray[np.float64]]
    T_cam_imu: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    time_offsets: dict[str, float] = field(default_factory=dict)
    target: dict[str, Any] = field(default_factory=dict)
    path: str = ""

    def camera(self, name: str) -> DistortedCamera:
        """The camera called ``name``; a ``ValueError`` listing the available ones otherwise."""
        if name not in self.cameras:
            raise ValueError(f"unknown camera {name!r}; available: {list(self.cameras)}")
        return self.cameras[name]

    @property
    def T_cam0_cam1(self) -> NDArray[np.float64]:
        """Pose of ``cam1`` in ``cam0``, (4, 4) (``x_cam0 = T x_cam1``)."""
        return self.relative_pose("cam0", "cam1")

    def relative_pose(self, a: str, b: str) -> NDArray[np.float64]:
        """``T_a_b`` (4, 4): the pose of camera ``b`` in camera ``a`` (``x_a = T_a_b x_b``), from the stated
        extrinsics (directly, inverted, or chained through the cameras' ``T_cam_imu``)."""
        for name in (a, b):
            self.camera(name)
        if a == b:
            return np.eye(4)
        if (a, b) in self.camera_extrinsics:
            return np.array(self.camera_extrinsics[(a, b)])
        if (b, a) in self.camera_extrinsics:
            return _inverse(self.camera_extrinsics[(b, a)])
        if a in self.T_cam_imu and b in self.T_cam_imu:
            return self.T_cam_imu[a] @ _inverse(self.T_cam_imu[b])
        # chain along stated pairs (breadth-first over the camera graph)
        edges: dict[str, list[tuple[str, NDArray[np.float64]]]] = {}
        for (p, q), t in self.camera_extrinsics.items():
            edges.setdefault(p, []).append((q, np.asarray(t, dtype=np.float64)))
            edges.setdefault(q, []).append((p, _inverse(t)))
        frontier: list[tuple[str, NDArray[np.float64]]] = [(a, np.eye(4))]
        seen = {a}
        while frontier:
            nxt = []
            for node, t_a_node in frontier:
                for other, t_node_other in edges.get(node, []):
                    if other in seen:
                        continue
                    t = t_a_node @ t_node_other
                    if other == b:
                        return t
                    seen.add(other)
                    nxt.append((other, t))
            frontier = nxt
        raise ValueError(f"no relative pose between cameras {a!r} and {b!r} in {self.path or 'the sensor file'}")


def _inverse(t: np.ndarray) -> NDArray[np.float64]:
    t = np.asarray(t, dtype=np.float64)
    r = t[:3, :3]
    out = np.eye(4)
    out[:3, :3] = r.T
    out[:3, 3] = -r.T @ t[:3, 3]
    return out
