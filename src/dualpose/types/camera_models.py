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

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from dualpose.algebra.series import atan2c, sinc
from dualpose.types.camera import CameraIntrinsics, PinholeModel

__all__ = [
    "UNDISTORT_TOLERANCE",
    "DistortedCamera",
    "RadTanCamera",
    "EquidistantCamera",
    "camera_from_parameters",
    "CAMERA_MODEL_NAMES",
]

#: largest accepted residual of an undistorted point, in distorted normalised units (|distort(x) - x_d|, max norm)
UNDISTORT_TOLERANCE = 1e-12
#: Newton's iterations before a point counts as not converged
UNDISTORT_MAX_ITERATIONS = 50
#: a Newton step below this (normalised units / radians) ends the iteration for that point
_STEP_DONE = 1e-14


def _points(points_c: object, name: str = "points_c") -> np.ndarray:
    p = np.asarray(points_c, dtype=np.float64)
    if p.shape[-1:] != (3,):
        raise ValueError(f"{name} must have shape (..., 3) (camera-frame X, Y, Z in metres); got {p.shape}")
    if not np.isfinite(p).all():
        raise ValueError(f"{name} must be finite")
    return p


def _planar(xy: object, name: str, what: str) -> np.ndarray:
    a = np.asarray(xy, dtype=np.float64)
    if a.shape[-1:] != (2,):
        raise ValueError(f"{name} must have shape (..., 2) ({what}); got {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite")
    return a


def _first_bad(bad: np.ndarray) -> str:
    idx = np.unravel_index(int(np.argmax(bad)), bad.shape)
    return f"{int(bad.sum())} of {bad.size} (first at index {tuple(int(i) for i in idx)})"


class DistortedCamera(PinholeModel):
    """What the distorted pinhole cameras share (the projection API); see the module docstring for the models.

    A subclass is a frozen dataclass with fields ``fx, fy, cx, cy, <4 distortion coefficients>, width, height``,
    class attributes ``model`` (the name) and ``DISTORTION_NAMES``, and implements ``_distorted_normalised``,
    ``_distort`` and ``_undistort``.
    """

    model: ClassVar[str]
    DISTORTION_NAMES: ClassVar[tuple[str, str, str, str]]

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

    # ------------------------------------------------------------------ parameters
    @property
    def distortion(self) -> tuple[float, float, float, float]:
        """The four distortion coefficients, in the order of ``DISTORTION_NAMES``."""
        return tuple(getattr(self, n) for n in self.DISTORTION_NAMES)  # type: ignore[return-value]

    @property
    def parameters(self) -> np.ndarray:
        """``[fx, fy, cx, cy, d1, d2, d3, d4]``, shape (8,): the order of :meth:`intrinsics_jacobian`'s columns."""
        return np.array([self.fx, self.fy, self.cx, self.cy, *self.distortion])

    def pinhole(self) -> CameraIntrinsics:
        """The undistorted pinhole camera with the same ``fx, fy, cx, cy, width, height``."""
        return CameraIntrinsics(self.fx, self.fy, self.cx, self.cy, self.width, self.height)

    # ------------------------------------------------------------------ projection
    def project(self, points_c: np.ndarray) -> np.ndarray:
        """Pixels ``(..., 2)`` of camera-frame points ``points_c`` ``(..., 3)`` (metres).

        Raises
        ------
        ValueError
            Shape not ``(..., 3)``, non-finite values, or points the model cannot project (radtan: Z <= 0;
            equi: on the optical axis behind or at the centre, ``X = Y = 0, Z <= 0``), naming ``points_c``.
        """
        xd, _, _ = self._distorted_normalised(self._checked_points(points_c), False)
        return self._to_pixels(xd)

    def project_jacobian(self, points_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixels ``(..., 2)`` and their derivative with respect to the camera-frame point, ``(..., 2, 3)``
        (pixels per metre; rows ``u, v``, columns ``X, Y, Z``).  Same input rules as :meth:`project`."""
        xd, j, _ = self._distorted_normalised(self._checked_points(points_c), True)
        return self._to_pixels(xd), j * np.array([self.fx, self.fy])[:, None]

    def intrinsics_jacobian(self, points_c: np.ndarray) -> np.ndarray:
        """Derivative of the pixels of ``points_c`` ``(..., 3)`` with respect to :attr:`parameters`
        ``(fx, fy, cx, cy, d1, d2, d3, d4)``, shape ``(..., 2, 8)`` (rows ``u, v``)."""
        xd, _, jk = self._distorted_normalised(self._checked_points(points_c), True)
        out = np.zeros(xd.shape[:-1] + (2, 8))
        out[..., 0, 0] = xd[..., 0]
        out[..., 1, 1] = xd[..., 1]
        out[..., 0, 2] = 1.0
        out[..., 1, 3] = 1.0
        out[..., :, 4:] = jk * np.array([self.fx, self.fy])[:, None]
        return out

    def distort(self, xy: np.ndarray) -> np.ndarray:
        """Distorted normalised coordinates ``(..., 2)`` of undistorted normalised ``xy = (X/Z, Y/Z)`` ``(..., 2)``."""
        return self._distort(_planar(xy, "xy", "undistorted normalised x, y"), False)[0]

    def distort_jacobian(self, xy: np.ndarray) -> np.ndarray:
        """``d distort(xy) / d xy``, shape ``(..., 2, 2)`` (rows ``x_d, y_d``, columns ``x, y``)."""
        return self._distort(_planar(xy, "xy", "undistorted normalised x, y"), True)[1]

    # ------------------------------------------------------------------ inverse
    def undistort(self, xy_d: np.ndarray, *, return_valid: bool = False):
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
        a = _planar(xy_d, "xy_d", "distorted normalised x_d, y_d")
        xy, valid = self._undistort(a)
        return self._finish(xy, valid, return_valid, "xy_d")

    def unproject(self, pixels: np.ndarray, *, return_valid: bool = False):
        """Undistorted normalised coordinates ``(X/Z, Y/Z)`` ``(..., 2)`` of ``pixels`` ``(..., 2)``; failure rules
        of :meth:`undistort` (naming ``pixels``)."""
        xy, valid = self._undistort(self._distorted_from_pixels(pixels))
        return self._finish(xy, valid, return_valid, "pixels")

    def bearing(self, pixels: np.ndarray, *, return_valid: bool = False):
        """Unit rays ``(..., 3)`` in the camera frame through ``pixels`` ``(..., 2)``; failure rules of
        :meth:`undistort` (naming ``pixels``)."""
        ray, valid = self._bearing(self._distorted_from_pixels(pixels))
        return self._finish(ray, valid, return_valid, "pixels")

    def ideal_pixels(self, pixels: np.ndarray, *, return_valid: bool = False):
        """The pixels ``(..., 2)`` of the same rays in the undistorted pinhole camera :meth:`pinhole`
        (``K · unproject(pixels)``): what the pinhole-model filters consume.  Failure rules of :meth:`undistort`."""
        xy, valid = self._undistort(self._distorted_from_pixels(pixels))
        ideal = np.stack([self.fx * xy[..., 0] + self.cx, self.fy * xy[..., 1] + self.cy], axis=-1)
        return self._finish(ideal, valid, return_valid, "pixels")

    # ------------------------------------------------------------------ helpers
    def _to_pixels(self, xd: np.ndarray) -> np.ndarray:
        return np.stack([self.fx * xd[..., 0] + self.cx, self.fy * xd[..., 1] + self.cy], axis=-1)

    def _distorted_from_pixels(self, pixels: object) -> np.ndarray:
        p = _planar(pixels, "pixels", "u, v in pixels")
        return np.stack([(p[..., 0] - self.cx) / self.fx, (p[..., 1] - self.cy) / self.fy], axis=-1)

    def _checked_points(self, points_c: object) -> np.ndarray:
        p = _points(points_c)
        bad = self._unprojectable(p)
        if bad.any():
            raise ValueError(
                f"points_c: {_first_bad(bad)} points cannot be projected by the {self.model} model "
                f"({self._PROJECTABLE})"
            )
        return p

    def _bearing(self, xy_d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xy, valid = self._undistort(xy_d)
        ray = np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1)
        return ray / np.linalg.norm(ray, axis=-1, keepdims=True), valid

    @staticmethod
    def _finish(values: np.ndarray, valid: np.ndarray, return_valid: bool, name: str):
        values = np.where(valid[..., None], values, np.nan)
        if return_valid:
            return values, valid
        if not valid.all():
            raise ValueError(
                f"{name}: {_first_bad(~valid)} points are outside the invertible region of the distortion "
                "(pass return_valid=True to get NaN and a mask instead)"
            )
        return values


# ---------------------------------------------------------------------------------------------- radtan


def _radtan_terms(k: tuple[float, float, float, float], x: np.ndarray, y: np.ndarray, jac: bool):
    """Distorted normalised (x_d, y_d) of (x, y); with ``jac`` also d/d(x, y) (..., 2, 2) and d/d(k1, k2, p1, p2)
    (..., 2, 4)."""
    k1, k2, p1, p2 = k
    x2, y2, xy = x * x, y * y, x * y
    r2 = x2 + y2
    radial = 1.0 + r2 * (k1 + k2 * r2)
    xd = x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x2)
    yd = y * radial + p1 * (r2 + 2.0 * y2) + 2.0 * p2 * xy
    out = np.stack([xd, yd], axis=-1)
    if not jac:
        return out, None, None
    dr = 2.0 * (k1 + 2.0 * k2 * r2)  # d radial / d(r²) times 2
    j = np.empty(x.shape + (2, 2))
    j[..., 0, 0] = radial + x2 * dr + 2.0 * p1 * y + 6.0 * p2 * x
    j[..., 0, 1] = xy * dr + 2.0 * p1 * x + 2.0 * p2 * y
    j[..., 1, 0] = j[..., 0, 1]
    j[..., 1, 1] = radial + y2 * dr + 6.0 * p1 * y + 2.0 * p2 * x
    jk = np.empty(x.shape + (2, 4))
    jk[..., 0, 0] = x * r2
    jk[..., 0, 1] = x * r2 * r2
    jk[..., 0, 2] = 2.0 * xy
    jk[..., 0, 3] = r2 + 2.0 * x2
    jk[..., 1, 0] = y * r2
    jk[..., 1, 1] = y * r2 * r2
    jk[..., 1, 2] = r2 + 2.0 * y2
    jk[..., 1, 3] = 2.0 * xy
    return out, j, jk


def _radial_limit_r2(k1: float, k2: float) -> float:
    """The first r² > 0 where d/dr [r (1 + k1 r² + k2 r⁴)] = 1 + 3 k1 r² + 5 k2 r⁴ vanishes (inf if none)."""
    roots = np.roots([5.0 * k2, 3.0 * k1, 1.0]) if (k1 or k2) else np.array([])
    real = [float(s.real) for s in np.atleast_1d(roots) if abs(s.imag) <= 1e-12 * abs(s) and s.real > 0]
    return min(real, default=math.inf)


@dataclass(frozen=True)
class RadTanCamera(DistortedCamera):
    """Pinhole camera with radial–tangential distortion (OpenCV ``[k1, k2, p1, p2]``, Kalibr ``radtan``).

    Attributes
    ----------
    fx, fy : float
        Focal lengths, pixels (> 0).
    cx, cy : float
        Principal point, pixels.
    k1, k2 : float
        Radial coefficients.
    p1, p2 : float
        Tangential coefficients.
    width, height : int
        Image size, pixels.
    """

    fx: float
    fy: float
    cx: float
    cy: float
    k1: float
    k2: float
    p1: float
    p2: float
    width: int
    height: int

    model: ClassVar[str] = "radtan"
    DISTORTION_NAMES: ClassVar[tuple[str, str, str, str]] = ("k1", "k2", "p1", "p2")
    _PROJECTABLE: ClassVar[str] = "Z must be > 0"

    @property
    def max_radius2(self) -> float:
        """Largest undistorted ``r² = x² + y²`` of the invertible region (inf when the radial part is monotone)."""
        return _radial_limit_r2(self.k1, self.k2)

    def _unprojectable(self, p: np.ndarray) -> np.ndarray:
        return ~(p[..., 2] > 0.0)

    def _distort(self, xy: np.ndarray, jac: bool):
        out, j, _ = _radtan_terms(self.distortion, xy[..., 0], xy[..., 1], jac)
        return out, j

    def _distorted_normalised(self, p: np.ndarray, jac: bool):
        iz = 1.0 / p[..., 2]
        x, y = p[..., 0] * iz, p[..., 1] * iz
        xd, j, jk = _radtan_terms(self.distortion, x, y, jac)
        if not jac:
            return xd, None, None
        # d(x, y)/dP = [[1/Z, 0, -x/Z], [0, 1/Z, -y/Z]]
        j3 = np.empty(x.shape + (2, 3))
        j3[..., :, 0] = j[..., :, 0] * iz[..., None]
        j3[..., :, 1] = j[..., :, 1] * iz[..., None]
        j3[..., :, 2] = -(j[..., :, 0] * x[..., None] + j[..., :, 1] * y[..., None]) * iz[..., None]
        return xd, j3, jk

    def _undistort(self, xy_d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k = self.distortion
        x, y = xy_d[..., 0].copy(), xy_d[..., 1].copy()
        active = np.ones(x.shape, dtype=bool)
        for _ in range(UNDISTORT_MAX_ITERATIONS):
            if not active.any():
                break
            xa, ya = x[active], y[active]
            d, j, _ = _radtan_terms(k, xa, ya, True)
            ex, ey = d[..., 0] - xy_d[..., 0][active], d[..., 1] - xy_d[..., 1][active]
            det = j[..., 0, 0] * j[..., 1, 1] - j[..., 0, 1] * j[..., 1, 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                sx = (j[..., 1, 1] * ex - j[..., 0, 1] * ey) / det
                sy = (j[..., 0, 0] * ey - j[..., 1, 0] * ex) / det
            x[active], y[active] = xa - sx, ya - sy
            done = ~(np.maximum(np.abs(sx), np.abs(sy)) > _STEP_DONE)  # NaN steps end too (and fail the checks)
            idx = np.flatnonzero(active.ravel())
            active.ravel()[idx[done]] = False
        d, j, _ = _radtan_terms(k, x, y, True)
        resid = np.maximum(np.abs(d[..., 0] - xy_d[..., 0]), np.abs(d[..., 1] - xy_d[..., 1]))
        det = j[..., 0, 0] * j[..., 1, 1] - j[..., 0, 1] * j[..., 1, 0]
        valid = (resid <= UNDISTORT_TOLERANCE) & (det > 0) & (x * x + y * y < self.max_radius2)
        return np.stack([x, y], axis=-1), valid


# ---------------------------------------------------------------------------------------------- equidistant


def _equi_poly(k: tuple[float, float, float, float], t2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``θ_d/θ = 1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸`` and ``dθ_d/dθ = 1 + 3 k1 θ² + ... + 9 k4 θ⁸`` at ``θ² = t2``."""
    k1, k2, k3, k4 = k
    poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))
    dpoly = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)))
    return poly, dpoly


def _equi_terms(k: tuple[float, float, float, float], X, Y, Z, jac: bool):
    """``θ_d (X, Y)/ρ`` (..., 2); with ``jac`` also d/d(X, Y, Z) (..., 2, 3) and d/d(k1..k4) (..., 2, 4)."""
    rho = np.hypot(X, Y)
    a = atan2c(rho, Z)  # θ / ρ, guarded at ρ = 0
    theta = rho * a
    t2 = theta * theta
    poly, dpoly = _equi_poly(k, t2)
    s = a * poly  # θ_d / ρ
    out = np.stack([X * s, Y * s], axis=-1)
    if not jac:
        return out, None, None
    q = rho * rho + Z * Z
    # d s/dρ · ρ = θ_d'(θ) Z/q - s: (u, v) = s (X, Y), so d/d(X, Y) = s I + c n nᵀ with n = (X, Y)/ρ
    c = dpoly * Z / q - s
    with np.errstate(divide="ignore", invalid="ignore"):
        nx = np.where(rho > 0, X / rho, 0.0)
        ny = np.where(rho > 0, Y / rho, 0.0)
    dz = -dpoly / q  # ds/dZ
    j = np.empty(np.shape(s) + (2, 3))
    j[..., 0, 0] = s + c * nx * nx
    j[..., 0, 1] = c * nx * ny
    j[..., 1, 0] = j[..., 0, 1]
    j[..., 1, 1] = s + c * ny * ny
    j[..., 0, 2] = X * dz
    j[..., 1, 2] = Y * dz
    jk = np.empty(np.shape(s) + (2, 4))
    power = a * t2  # θ^(2i+1)/ρ
    for i in range(4):
        jk[..., 0, i] = X * power
        jk[..., 1, i] = Y * power
        power = power * t2
    return out, j, jk


def _equi_theta_limit(k: tuple[float, float, float, float]) -> float:
    """The first θ in (0, π) where dθ_d/dθ vanishes (π if none)."""
    k1, k2, k3, k4 = k
    coeffs = np.trim_zeros([9.0 * k4, 7.0 * k3, 5.0 * k2, 3.0 * k1, 1.0], "f")
    roots = np.roots(coeffs) if len(coeffs) > 1 else np.array([])
    real = [math.sqrt(s.real) for s in np.atleast_1d(roots) if abs(s.imag) <= 1e-12 * abs(s) and s.real > 0]
    return min([t for t in real if t < math.pi], default=math.pi)


@dataclass(frozen=True)
class EquidistantCamera(DistortedCamera):
    """Pinhole camera with equidistant fisheye distortion (Kannala–Brandt; OpenCV ``cv2.fisheye``, Kalibr ``equi``).

    Attributes
    ----------
    fx, fy : float
        Focal lengths, pixels (> 0).
    cx, cy : float
        Principal point, pixels.
    k1, k2, k3, k4 : float
        Coefficients of ``θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)``.
    width, height : int
        Image size, pixels.
    """

    fx: float
    fy: float
    cx: float
    cy: float
    k1: float
    k2: float
    k3: float
    k4: float
    width: int
    height: int

    model: ClassVar[str] = "equi"
    DISTORTION_NAMES: ClassVar[tuple[str, str, str, str]] = ("k1", "k2", "k3", "k4")
    _PROJECTABLE: ClassVar[str] = "not on the optical axis at or behind the centre, X = Y = 0 with Z <= 0"

    @property
    def max_angle(self) -> float:
        """Largest ray angle θ from the optical axis (radians) of the invertible region: the first zero of
        ``dθ_d/dθ``, or π."""
        return _equi_theta_limit(self.distortion)

    def _unprojectable(self, p: np.ndarray) -> np.ndarray:
        return (p[..., 0] == 0.0) & (p[..., 1] == 0.0) & ~(p[..., 2] > 0.0)

    def _distort(self, xy: np.ndarray, jac: bool):
        out, j, _ = _equi_terms(self.distortion, xy[..., 0], xy[..., 1], np.ones(xy.shape[:-1]), jac)
        return out, (None if j is None else j[..., :2])

    def _distorted_normalised(self, p: np.ndarray, jac: bool):
        return _equi_terms(self.distortion, p[..., 0], p[..., 1], p[..., 2], jac)

    def _theta(self, xy_d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """θ of distorted normalised points (Newton on θ_d(θ) = |xy_d|), ``θ_d/θ`` there, and validity."""
        k = self.distortion
        rd = np.hypot(xy_d[..., 0], xy_d[..., 1])
        limit = self.max_angle
        theta = np.array(np.minimum(rd, limit))
        active = np.ones(rd.shape, dtype=bool)
        for _ in range(UNDISTORT_MAX_ITERATIONS):
            if not active.any():
                break
            t = theta[active]
            poly, dpoly = _equi_poly(k, t * t)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = (t * poly - rd[active]) / dpoly
            t_new = np.clip(t - step, 0.0, limit)
            theta[active] = t_new
            done = ~(np.abs(step) > _STEP_DONE)
            idx = np.flatnonzero(active.ravel())
            active.ravel()[idx[done]] = False
        poly, _ = _equi_poly(k, theta * theta)
        valid = (np.abs(theta * poly - rd) <= UNDISTORT_TOLERANCE) & (theta < limit)
        return theta, poly, valid

    def _undistort(self, xy_d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        theta, poly, valid = self._theta(xy_d)
        valid &= theta < 0.5 * math.pi
        # (x, y) = tan θ · n = xy_d · (tan θ / θ) / (θ_d / θ), with tan θ/θ = sinc θ / cos θ
        with np.errstate(divide="ignore", invalid="ignore"):
            f = sinc(theta) / (np.cos(theta) * poly)
        return xy_d * f[..., None], valid

    def _bearing(self, xy_d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        theta, poly, valid = self._theta(xy_d)
        f = sinc(theta) / poly  # sin θ / θ_d, so f · xy_d = sin θ · n
        return np.concatenate([xy_d * f[..., None], np.cos(theta)[..., None]], axis=-1), valid


# ---------------------------------------------------------------------------------------------- factory

#: accepted model names (lower case) -> camera class
CAMERA_MODEL_NAMES: dict[str, type[DistortedCamera]] = {
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
    model: str, intrinsics, distortion, width: int, height: int
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
    values = {}
    for name, seq, n in (("intrinsics", intrinsics, 4), ("distortion", distortion, 4)):
        try:
            a = [float(v) for v in seq]
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be a sequence of {n} numbers; got {seq!r}") from None
        if len(a) != n:
            raise ValueError(f"{name} must have {n} values for the {cls.model} model; got {len(a)}")
        values[name] = a
    return cls(*values["intrinsics"], *values["distortion"], width, height)  # type: ignore[call-arg]
