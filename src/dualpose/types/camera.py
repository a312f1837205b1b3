"""Camera models and 2-D–3-D point correspondences (what the vision front end hands the estimators).

Camera frame ``c``: z along the optical axis, x right, y down, metres; pixels ``(u, v)`` with the origin at the
top-left corner of the image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["PinholeModel", "PinholeCamera", "CameraIntrinsics", "CameraFrame", "FrameCorrespondences"]


class PinholeModel:
    """Projection shared by the pinhole cameras; a subclass provides ``fx``, ``fy``, ``cx``, ``cy`` (pixels) and
    ``width``, ``height``.  Pixel ``u = fx X/Z + cx``, ``v = fy Y/Z + cy`` (camera frame, metres)."""

    if TYPE_CHECKING:  # what every subclass provides (dataclass fields or properties), declared for type checkers

        @property
        def fx(self) -> float: ...
        @property
        def fy(self) -> float: ...
        @property
        def cx(self) -> float: ...
        @property
        def cy(self) -> float: ...
        @property
        def width(self) -> int: ...
        @property
        def height(self) -> int: ...

    @property
    def matrix(self) -> NDArray[np.float64]:
        """Intrinsic matrix ``K``, shape (3, 3), pixels."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def project(self, points_c: ArrayLike) -> NDArray[np.float64]:
        """Pixels ``(..., 2)`` of camera-frame points ``(..., 3)`` (metres; Z must be > 0)."""
        p = np.asarray(points_c, dtype=np.float64)
        if p.shape[-1:] != (3,):
            raise ValueError(f"points_c must have shape (..., 3); got {p.shape}")
        z = p[..., 2]
        return np.stack([self.fx * p[..., 0] / z + self.cx, self.fy * p[..., 1] / z + self.cy], axis=-1)


@dataclass(frozen=True)
class PinholeCamera(PinholeModel):
    """Pinhole camera without distortion.  Pixel ``u = fx X/Z + cx``, ``v = fy Y/Z + cy`` (camera frame, metres).

    Defaults: Hol's 320 × 240 camera with f = 3.2 mm and an assumed 15 µm pixel pitch (fx = fy = 213.3 px).
    """

    width: int = 320
    height: int = 240
    focal_length_m: float = 3.2e-3
    pixel_pitch_m: float = 15e-6

    @property
    def fx(self) -> float:
        return self.focal_length_m / self.pixel_pitch_m

    @property
    def fy(self) -> float:
        return self.focal_length_m / self.pixel_pitch_m

    @property
    def cx(self) -> float:
        return 0.5 * self.width

    @property
    def cy(self) -> float:
        return 0.5 * self.height


@dataclass(frozen=True)
class CameraIntrinsics(PinholeModel):
    """Pinhole camera given by its intrinsics in pixels (what a calibration file states), no distortion.

    Attributes
    ----------
    fx, fy : float
        Focal lengths, pixels (> 0).
    cx, cy : float
        Principal point, pixels.
    width, height : int
        Image size, pixels (> 0).
    """

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def __post_init__(self) -> None:
        for name in ("fx", "fy", "cx", "cy"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise ValueError(f"{name} must be a finite number of pixels; got {v!r}")
        if not (self.fx > 0 and self.fy > 0):
            raise ValueError(f"fx and fy must be > 0 pixels; got {self.fx}, {self.fy}")
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v <= 0:
                raise ValueError(f"{name} must be a positive whole number of pixels; got {v!r}")


@dataclass(frozen=True)
class CameraFrame:
    """The 2-D–3-D point correspondences of one camera frame.

    ``t`` the camera-clock stamp (s); ``pixels`` (M, 2) measured pixels; ``points`` (M, 3) the matching landmark
    positions in the world frame, metres.
    """

    t: float
    pixels: np.ndarray
    points: np.ndarray

    def __post_init__(self) -> None:
        pixels = np.ascontiguousarray(self.pixels, dtype=np.float64).reshape(-1, 2)
        points = np.ascontiguousarray(self.points, dtype=np.float64).reshape(-1, 3)
        if len(pixels) != len(points):
            raise ValueError(f"pixels (M, 2) and points (M, 3) differ in M: {len(pixels)} vs {len(points)}")
        if not math.isfinite(self.t):
            raise ValueError(f"t must be a finite time in seconds; got {self.t!r}")
        object.__setattr__(self, "t", float(self.t))
        object.__setattr__(self, "pixels", pixels)
        object.__setattr__(self, "points", points)


@dataclass
class FrameCorrespondences:
    """2-D–3-D point correspondences of all camera frames, flattened (what the filters consume).

    Frame ``k`` (camera-clock stamp ``t[k]``, s; ``t`` (F,)) owns rows ``offsets[k]:offsets[k+1]`` of ``pixels``
    (M, 2) and ``points`` (M, 3) world-frame landmark positions (metres); ``offsets`` (F + 1,) int64.
    """

    t: np.ndarray
    offsets: np.ndarray
    pixels: np.ndarray
    points: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    def frame(self, k: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(pixels (m, 2), points (m, 3))`` of frame ``k``."""
        a, b = self.offsets[k], self.offsets[k + 1]
        return self.pixels[a:b], self.points[a:b]

    def camera_frame(self, k: int) -> CameraFrame:
        """Frame ``k`` as a :class:`CameraFrame` (the measurement the estimators' ``update`` takes)."""
        return CameraFrame(float(self.t[k]), *self.frame(k))

    @property
    def counts(self) -> NDArray[np.int64]:
        """Number of correspondences per frame, shape (F,)."""
        return np.diff(self.offsets)
