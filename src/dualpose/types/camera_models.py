"""Pinhole cameras with lens distortion: radial–tangential ("radtan") and equidistant ("equi", Kannala–Brandt).

Frames and units as in :mod:`dualpose.types.camera`: camera frame ``c`` with z along the optical axis, x right,
y down (metres); pixels ``(u, v)`` from the top-left image corner.  Every method takes float64 arrays with the
components on the last axis and broadcasts over the leading axes.

Normalised coordinates are ``(x, y) = (X/Z, Y/Z)``; *distorted* normalised coordinates ``(x_d, y_d)`` map to pixels
by ``u = fx x_d + cx``, ``v = fy y_d + cy``.

* ``radtan`` (Brown–Conrady as in OpenCV ``cv2.projectPoints`` with ``distCoeffs = [k1, k2, p1, p2]`` and Kalibr's
  ``pinhole-radtan``), with ``r² = x² + y²``::

      x_d = x (1 + k1 r² + k2 r⁴) + 2 p1 x y + p2 (r² + 2 x²)
      y_d = y (1 + k1 r² + k2 r⁴) + p1 (r² + 2 y²) + 2 p2 x y

* ``equi`` (Kannala & Brandt 2006, OpenCV ``cv2.fisheye``, Kalibr ``pinhole-equi``), with ``ρ = √(X² + Y²)``,
  ``θ = atan2(ρ, Z)`` the angle from the optical axis::

      θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸),   (x_d, y_d) = θ_d (X, Y) / ρ

  ``θ_d / ρ = atan2c(ρ, Z) (1 + k1 θ² + ...)`` goes through the guarded series
  :func:`dualpose.algebra.series.atan2c`, so the optical axis (ρ = 0) is exact.  The equidistant model projects any
  point off the negative optical axis (also Z <= 0, for lenses beyond 180°).

Inverse (undistortion): Newton's method on the 2 × 2 distortion Jacobian (radtan), on ``θ_d(θ) = |(x_d, y_d)|``
(equi, radially symmetric), to a residual below :data:`UNDISTORT_TOLERANCE`.  A point is *invertible* when Newton
converges there on the branch that starts at the image centre: radtan needs ``r`` below the first zero of the
radial derivative ``d/dr [r (1 + k1 r² + k2 r⁴)]`` and a positive Jacobian determinant; equi needs ``θ`` below the
first zero of ``dθ_d/dθ`` (and below π/2 for normalised coordinates, which do not exist beyond).  Points outside
raise a ``ValueError`` (or, with ``return_valid=True``, come back as NaN with ``valid`` False).
"""

from __future__ import annotations

import abc
import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import ClassVar, Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose import _native
from dualpose.types import _inputs
from dualpose.types.camera import CameraIntrinsics, PinholeModel

__all__ = [
    "UNDISTORT_TOLERANCE",
    "DistortedCamera",
    "RadTanCamera",
    "EquidistantCamera",
    "camera_from_parameters",
    "CAMERA_MODEL_NAMES",
]

#: largest accepted residual of an undistorted point, in distorted normalised units (``|distort(x) - x_d|``, max norm)
UNDISTORT_TOLERANCE = 1e-12
#: Newton's iterations before a point counts as not converged; a step below 1e-14 (normalised units / radians)
#: ends the iteration for that point (``src/native/common/camera_models.hpp``)
UNDISTORT_MAX_ITERATIONS = 50
# outputs of the compiled inversion (src/native/types/cameras.cpp)
_UNDISTORTED, _RAY, _IDEAL_PIXELS = 0, 1, 2
#: the inverse with ``return_valid=True``: the values (NaN where invalid) and the bool mask of the valid points
_WithValid = tuple[NDArray[np.float64], NDArray[np.bool_]]


def _points(points_c: object, name: str = "points_c") -> NDArray[np.float64]:
    p = np.asarray(points_c, dtype=np.float64)
    if p.shape[-1:] != (3,):
        raise ValueError(f"{name} must have shape (..., 3) (camera-frame X, Y, Z in metres); got {p.shape}")
    if not np.isfinite(p).all():
        raise ValueError(f"{name} must be finite")
    return p


def _planar(xy: object, name: str, what: str) -> NDArray[np.float64]:
    a = np.asarray(xy, dtype=np.float64)
    if a.shape[-1:] != (2,):
        raise ValueError(f"{name} must have shape (..., 2) ({what}); got {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite")
    return a


def _first_bad(bad: np.ndarray) -> str:
    idx = np.unravel_index(int(np.argmax(bad)), bad.shape)
    return f"{int(bad.sum())} of {bad.size} (first at index {tuple(int(i) for i in idx)})"


class _KernelRow(PinholeModel):
    """What :class:`DistortedCamera` sets in ``__post_init__`` besides its dataclass fields (declared here, in a
    class that is not a dataclass, so that they stay out of the fields): the kernels' parameter row and the bound
    of the invertible region."""

    _params: NDArray[np.float64]
    _bound: float


@dataclass(frozen=True)
class DistortedCamera(_KernelRow, abc.ABC):
    """What the distorted pinhole cameras share (the projection API); see the module docstring for the models.

    A subclass is a frozen dataclass that adds the fields ``<4 distortion coefficients>, width, height`` to
    ``fx, fy, cx, cy`` (pixels),
    class attributes ``model`` (the name), ``DISTORTION_NAMES``, ``_KERNELS`` (the prefix of its compiled
    gufuncs in ``dualpose._native``, ``src/native/types/cameras.cpp``) and ``_MODEL_ID`` (its number for
    ``_native.camera_invert``), and ``_limit()``, the bound of its invertible region.  The per-point work runs in
    those kernels; this class checks the input and shapes the output.
    """

    fx: float
    fy: float
    cx: float
    cy: float

    model: ClassVar[str]
    DISTORTION_NAMES: ClassVar[tuple[str, str, str, str]]
    _KERNELS: ClassVar[str]
    _PROJECTABLE: ClassVar[str]
    _MODEL_ID: ClassVar[int]

    def __post_init__(self) -> None:
        for name in ("fx", "fy", "cx", "cy", *self.DISTORTION_NAMES):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) or not math.isfinite(v):
                raise ValueError(f"{name} must be a finite number; got {v!r}")
            object.__setattr__(self, name, float(v))
        for name in ("fx", "fy"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 pixels; got {getattr(self, name)!r}")
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or v <= 0:
                raise ValueError(f"{name} must be a positive whole number of pixels; got {v!r}")
            object.__setattr__(self, name, int(v))
        _inputs.check_camera(self, self.model)  # the principal point and the image size must agree
        object.__setattr__(self, "_params", np.array([self.fx, self.fy, self.cx, self.cy, *self.distortion]))
        object.__setattr__(self, "_bound", self._limit())

    def _kernel(self, name: str) -> np.ufunc:
        result: np.ufunc = getattr(_native, f"{self._KERNELS}_{name}")
        return result

    # ------------------------------------------------------------------ parameters
    @property
    def distortion(self) -> tuple[float, float, float, float]:
        """The four distortion coefficients, in the order of ``DISTORTION_NAMES``."""
        d1, d2, d3, d4 = (getattr(self, n) for n in self.DISTORTION_NAMES)
        return d1, d2, d3, d4

    @property
    def parameters(self) -> NDArray[np.float64]:
        """``[fx, fy, cx, cy, d1, d2, d3, d4]``, shape (8,): the order of :meth:`intrinsics_jacobian`'s columns."""
        result: NDArray[np.float64] = self._params.copy()
        return result

    def pinhole(self) -> CameraIntrinsics:
        """The undistorted pinhole camera with the same ``fx, fy, cx, cy, width, height``."""
        return CameraIntrinsics(self.fx, self.fy, self.cx, self.cy, self.width, self.height)

    # ------------------------------------------------------------------ projection
    def project(self, points_c: ArrayLike) -> NDArray[np.float64]:
        """Pixels ``(..., 2)`` of camera-frame points ``points_c`` ``(..., 3)`` (metres).

        Raises
        ------
        ValueError
            Shape not ``(..., 3)``, non-finite values, or points the model cannot project (radtan: Z <= 0;
            equi: on the optical axis behind or at the centre, ``X = Y = 0, Z <= 0``), naming ``points_c``.
        """
        result: NDArray[np.float64] = self._kernel("project")(self._params, self._checked_points(points_c))
        return result

    def project_jacobian(self, points_c: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Pixels ``(..., 2)`` and their derivative with respect to the camera-frame point, ``(..., 2, 3)``
        (pixels per metre; rows ``u, v``, columns ``X, Y, Z``).  Same input rules as :meth:`project`."""
        result: tuple[NDArray[np.float64], NDArray[np.float64]] = (
            self._kernel("project_jacobian")(self._params, self._checked_points(points_c))
        )
        return result

    def intrinsics_jacobian(self, points_c: ArrayLike) -> NDArray[np.float64]:
        """Derivative of the pixels of ``points_c`` ``(..., 3)`` with respect to :attr:`parameters`
        ``(fx, fy, cx, cy, d1, d2, d3, d4)``, shape ``(..., 2, 8)`` (rows ``u, v``)."""
        result: NDArray[np.float64] = self._kernel("intrinsics_jacobian")(self._params, self._checked_points(points_c))
        return result

    def distort(self, xy: ArrayLike) -> NDArray[np.float64]:
        """Distorted normalised coordinates ``(..., 2)`` of undistorted normalised ``xy = (X/Z, Y/Z)`` ``(..., 2)``."""
        result: NDArray[np.float64] = (
            self._kernel("distort")(self._params, _planar(xy, "xy", "undistorted normalised x, y"))[0]
        )
        return result

    def distort_jacobian(self, xy: ArrayLike) -> NDArray[np.float64]:
        """``d distort(xy) / d xy``, shape ``(..., 2, 2)`` (rows ``x_d, y_d``, columns ``x, y``)."""
        result: NDArray[np.float64] = (
            self._kernel("distort")(self._params, _planar(xy, "xy", "undistorted normalised x, y"))[1]
        )
        return result

    # ------------------------------------------------------------------ model (each subclass)
    @abc.abstractmethod
    def _limit(self) -> float:
        """The bound of the invertible region (radtan: largest undistorted r², equi: largest θ)."""

    @abc.abstractmethod
    def _unprojectable(self, p: NDArray[np.float64]) -> NDArray[np.bool_]:
        """True where the camera-frame point ``p`` (..., 3) cannot be projected by the model."""

    # ------------------------------------------------------------------ inverse
    @overload
    def undistort(self, xy_d: ArrayLike, *, return_valid: Literal[False] = False) -> NDArray[np.float64]: ...
    @overload
    def undistort(self, xy_d: ArrayLike, *, return_valid: Literal[True]) -> _WithValid: ...
    def undistort(self, xy_d: ArrayLike, *, return_valid: bool = False) -> NDArray[np.float64] | _WithValid:
        """Undistorted normalised coordinates ``(..., 2)`` of distorted normalised ``xy_d`` ``(..., 2)`` (the inverse
        of :meth:`distort`, by Newton's method to a residual below :data:`UNDISTORT_TOLERANCE`).

        Returns
        -------
        xy : ndarray (..., 2)
        valid : ndarray of bool (...)
            Only with ``return_valid=True``: False where the point is outside the invertible region (module
            docstring) or Newton did not converge; ``xy`` is NaN there.

        Raises
        ------
        ValueError
            Without ``return_valid``, when any point is not invertible (how many, and the first index).
        """
        return self._invert(_planar(xy_d, "xy_d", "distorted normalised x_d, y_d"), False, _UNDISTORTED, return_valid)

    @overload
    def unproject(self, pixels: ArrayLike, *, return_valid: Literal[False] = False) -> NDArray[np.float64]: ...
    @overload
    def unproject(self, pixels: ArrayLike, *, return_valid: Literal[True]) -> _WithValid: ...
    def unproject(self, pixels: ArrayLike, *, return_valid: bool = False) -> NDArray[np.float64] | _WithValid:
        """Undistorted normalised coordinates ``(X/Z, Y/Z)`` ``(..., 2)`` of ``pixels`` ``(..., 2)``; failure rules
        of :meth:`undistort` (naming ``pixels``)."""
        return self._invert(_planar(pixels, "pixels", "u, v in pixels"), True, _UNDISTORTED, return_valid)

    @overload
    def bearing(self, pixels: ArrayLike, *, return_valid: Literal[False] = False) -> NDArray[np.float64]: ...
    @overload
    def bearing(self, pixels: ArrayLike, *, return_valid: Literal[True]) -> _WithValid: ...
    def bearing(self, pixels: ArrayLike, *, return_valid: bool = False) -> NDArray[np.float64] | _WithValid:
        """Unit rays ``(..., 3)`` in the camera frame through ``pixels`` ``(..., 2)``; failure rules of
        :meth:`undistort` (naming ``pixels``)."""
        return self._invert(_planar(pixels, "pixels", "u, v in pixels"), True, _RAY, return_valid)

    @overload
    def ideal_pixels(self, pixels: ArrayLike, *, return_valid: Literal[False] = False) -> NDArray[np.float64]: ...
    @overload
    def ideal_pixels(self, pixels: ArrayLike, *, return_valid: Literal[True]) -> _WithValid: ...
    def ideal_pixels(self, pixels: ArrayLike, *, return_valid: bool = False) -> NDArray[np.float64] | _WithValid:
        """The pixels ``(..., 2)`` of the same rays in the undistorted pinhole camera :meth:`pinhole`
        (``K · unproject(pixels)``): what the pinhole-model filters consume.  Failure rules of :meth:`undistort`."""
        return self._invert(_planar(pixels, "pixels", "u, v in pixels"), True, _IDEAL_PIXELS, return_valid)

    # ------------------------------------------------------------------ helpers
    def _checked_points(self, points_c: object) -> NDArray[np.float64]:
        p = _points(points_c)
        bad = self._unprojectable(p)
        if bad.any():
            raise ValueError(
                f"points_c: {_first_bad(bad)} points cannot be projected by the {self.model} model "
                f"({self._PROJECTABLE})"
            )
        return p

    def _invert(
        self, src: NDArray[np.float64], from_pixels: bool, output: int, return_valid: bool,
    ) -> NDArray[np.float64] | _WithValid:
        """The compiled Newton inversion (``_native.camera_invert``) of ``src`` (..., 2): pixels or distorted
        normalised coordinates, to undistorted normalised coordinates, unit rays or ideal pixels."""
        flat = np.ascontiguousarray(src.reshape(-1, 2))
        out: NDArray[np.float64] = np.empty((len(flat), 3 if output == _RAY else 2))
        valid = np.empty(len(flat), dtype=np.int64)
        _native.camera_invert(self._MODEL_ID, int(from_pixels), output, self._params, self._bound, flat, out, valid)
        out = out.reshape(src.shape[:-1] + out.shape[-1:])
        ok = valid.astype(bool).reshape(src.shape[:-1])
        if return_valid:
            return out, ok
        if not ok.all():
            raise ValueError(
                f"{'pixels' if from_pixels else 'xy_d'}: {_first_bad(~ok)} points are outside the invertible region "
                "of the distortion (pass return_valid=True to get NaN and a mask instead)"
            )
        return out


# ---------------------------------------------------------------------------------------------- radtan


def _first_positive_root(coefficients: list[float]) -> float:
    """The smallest real root s > 0 of the polynomial (highest power first; inf if none)."""
    c = np.trim_zeros(np.array(coefficients, dtype=np.float64), "f")
    roots = np.roots(c) if len(c) > 1 else np.array([])
    real = [float(r.real) for r in roots if abs(r.imag) <= 1e-12 * abs(r) and r.real > 0]
    return min(real, default=math.inf)


@dataclass(frozen=True)
class RadTanCamera(DistortedCamera):
    """Pinhole camera with radial–tangential distortion (OpenCV ``[k1, k2, p1, p2]``, Kalibr ``radtan``).

    ``fx, fy, cx, cy, width, height`` as in :class:`~dualpose.types.camera.CameraIntrinsics` (pixels); ``k1, k2``
    the radial, ``p1, p2`` the tangential coefficients.
    """

    k1: float
    k2: float
    p1: float
    p2: float
    width: int
    height: int

    model: ClassVar[str] = "radtan"
    DISTORTION_NAMES: ClassVar[tuple[str, str, str, str]] = ("k1", "k2", "p1", "p2")
    _PROJECTABLE: ClassVar[str] = "Z must be > 0"

    _KERNELS: ClassVar[str] = "radtan"
    _MODEL_ID: ClassVar[int] = 0

    @property
    def max_radius2(self) -> float:
        """Largest undistorted ``r² = x² + y²`` of the invertible region (inf when the radial part is monotone)."""
        result: float = self._bound
        return result

    def _limit(self) -> float:
        # the first r² where d/dr [r (1 + k1 r² + k2 r⁴)] = 1 + 3 k1 r² + 5 k2 r⁴ vanishes
        return _first_positive_root([5.0 * self.k2, 3.0 * self.k1, 1.0])

    def _unprojectable(self, p: np.ndarray) -> NDArray[np.bool_]:
        return ~(p[..., 2] > 0.0)


# ---------------------------------------------------------------------------------------------- equidistant


@dataclass(frozen=True)
class EquidistantCamera(DistortedCamera):
    """Pinhole camera with equidistant fisheye distortion (Kannala–Brandt; OpenCV ``cv2.fisheye``, Kalibr ``equi``).

    ``fx, fy, cx, cy, width, height`` as in :class:`~dualpose.types.camera.CameraIntrinsics` (pixels); ``k1 .. k4``
    the coefficients of ``θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)``.
    """

    k1: float
    k2: float
    k3: float
    k4: float
    width: int
    height: int

    model: ClassVar[str] = "equi"
    DISTORTION_NAMES: ClassVar[tuple[str, str, str, str]] = ("k1", "k2", "k3", "k4")
    _PROJECTABLE: ClassVar[str] = "not on the optical axis at or behind the centre, X = Y = 0 with Z <= 0"

    _KERNELS: ClassVar[str] = "equi"
    _MODEL_ID: ClassVar[int] = 1

    @property
    def max_angle(self) -> float:
        """Largest ray angle θ from the optical axis (radians) of the invertible region: the first zero of
        ``dθ_d/dθ``, or π."""
        result: float = self._bound
        return result

    def _limit(self) -> float:
        # the first θ in (0, π) where dθ_d/dθ = 1 + 3 k1 θ² + 5 k2 θ⁴ + 7 k3 θ⁶ + 9 k4 θ⁸ vanishes, else π
        s = _first_positive_root([9.0 * self.k4, 7.0 * self.k3, 5.0 * self.k2, 3.0 * self.k1, 1.0])
        return min(math.sqrt(s), math.pi)

    def _unprojectable(self, p: np.ndarray) -> NDArray[np.bool_]:
        result: NDArray[np.bool_] = (p[..., 0] == 0.0) & (p[..., 1] == 0.0) & ~(p[..., 2] > 0.0)
        return result


# ---------------------------------------------------------------------------------------------- factory

#: accepted model names (lower case) -> camera class
CAMERA_MODEL_NAMES: dict[str, type[RadTanCamera] | type[EquidistantCamera]] = {
    "radtan": RadTanCamera,
    "radial-tangential": RadTanCamera,
    "pinhole-radtan": RadTanCamera,
    "equi": EquidistantCamera,
    "equidistant": EquidistantCamera,
    "fisheye": EquidistantCamera,
    "kannala-brandt": EquidistantCamera,
    "pinhole-equi": EquidistantCamera,
}


def camera_from_parameters(
    model: str, intrinsics: Iterable[float], distortion: Iterable[float], width: int, height: int
) -> RadTanCamera | EquidistantCamera:
    """A distorted camera from a calibration file's fields.

    Parameters
    ----------
    model : str
        ``"radtan"`` / ``"radial-tangential"`` / ``"pinhole-radtan"`` or ``"equi"`` / ``"equidistant"`` /
        ``"fisheye"`` / ``"kannala-brandt"`` / ``"pinhole-equi"`` (case-insensitive).
    intrinsics : sequence of 4 floats
        ``fx, fy, cx, cy`` in pixels.
    distortion : sequence of 4 floats
        ``k1, k2, p1, p2`` (radtan) or ``k1, k2, k3, k4`` (equi).
    width, height : int
        Image size, pixels.
    """
    if not isinstance(model, str) or model.strip().lower() not in CAMERA_MODEL_NAMES:
        raise ValueError(f"model must be one of {sorted(CAMERA_MODEL_NAMES)}; got {model!r}")
    cls = CAMERA_MODEL_NAMES[model.strip().lower()]
    values: dict[str, list[float]] = {}
    for name, seq, n in (("intrinsics", intrinsics, 4), ("distortion", distortion, 4)):
        try:
            a = [float(v) for v in seq]
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be a sequence of {n} numbers; got {seq!r}") from None
        if len(a) != n:
            raise ValueError(f"{name} must have {n} values for the {cls.model} model; got {len(a)}")
        values[name] = a
    (fx, fy, cx, cy), (d1, d2, d3, d4) = values["intrinsics"], values["distortion"]
    return cls(fx, fy, cx, cy, d1, d2, d3, d4, width, height)
