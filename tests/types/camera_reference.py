"""A vectorised NumPy statement of the distorted camera models (dualpose.types.camera_models), the reference the
compiled kernels (src/native/common/camera_models.hpp) are checked against to 1e-12 relative: the same equations
written as whole-array NumPy, with per-point Newton iterations frozen once their step is below 1e-14 (as the
kernels do point by point).  Parameters ``p`` (8,) = ``[fx, fy, cx, cy, d1, d2, d3, d4]``."""

from __future__ import annotations

import numpy as np

from dualpose.algebra.series import atan2c, sinc

TOLERANCE = 1e-12
MAX_ITERATIONS = 50
STEP_DONE = 1e-14


def radtan_distort(d, x, y):
    """Distorted (..., 2), d/d(x, y) (..., 2, 2), d/d(k1, k2, p1, p2) (..., 2, 4)."""
    k1, k2, p1, p2 = d
    x2, y2, xy = x * x, y * y, x * y
    r2 = x2 + y2
    radial = 1.0 + r2 * (k1 + k2 * r2)
    out = np.stack(
        [x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x2), y * radial + p1 * (r2 + 2.0 * y2) + 2.0 * p2 * xy], -1
    )
    dr = 2.0 * (k1 + 2.0 * k2 * r2)
    off = xy * dr + 2.0 * p1 * x + 2.0 * p2 * y
    j = np.stack(
        [
            np.stack([radial + x2 * dr + 2.0 * p1 * y + 6.0 * p2 * x, off], -1),
            np.stack([off, radial + y2 * dr + 6.0 * p1 * y + 2.0 * p2 * x], -1),
        ],
        -2,
    )
    jk = np.stack(
        [
            np.stack([x * r2, x * r2 * r2, 2.0 * xy, r2 + 2.0 * x2], -1),
            np.stack([y * r2, y * r2 * r2, r2 + 2.0 * y2, 2.0 * xy], -1),
        ],
        -2,
    )
    return out, j, jk


def radtan_point(d, p):
    """Distorted normalised (..., 2), d/dP (..., 2, 3), d/dd (..., 2, 4) of camera-frame points (Z > 0)."""
    iz = 1.0 / p[..., 2]
    x, y = p[..., 0] * iz, p[..., 1] * iz
    out, j, jk = radtan_distort(d, x, y)
    dz = -(j[..., 0] * x[..., None] + j[..., 1] * y[..., None]) * iz[..., None]
    j3 = np.stack([j[..., 0] * iz[..., None], j[..., 1] * iz[..., None], dz], -1)
    return out, j3, jk


def radtan_undistort(d, max_r2, xy_d):
    x, y = xy_d[..., 0].copy(), xy_d[..., 1].copy()
    active = np.ones(x.shape, dtype=bool)
    for _ in range(MAX_ITERATIONS):
        if not active.any():
            break
        o, j, _ = radtan_distort(d, x[active], y[active])
        ex, ey = o[..., 0] - xy_d[..., 0][active], o[..., 1] - xy_d[..., 1][active]
        det = j[..., 0, 0] * j[..., 1, 1] - j[..., 0, 1] * j[..., 1, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            sx = (j[..., 1, 1] * ex - j[..., 0, 1] * ey) / det
            sy = (j[..., 0, 0] * ey - j[..., 1, 0] * ex) / det
        x[active] -= sx
        y[active] -= sy
        idx = np.flatnonzero(active)
        active[idx[~(np.maximum(np.abs(sx), np.abs(sy)) > STEP_DONE)]] = False
    o, j, _ = radtan_distort(d, x, y)
    resid = np.maximum(np.abs(o[..., 0] - xy_d[..., 0]), np.abs(o[..., 1] - xy_d[..., 1]))
    det = j[..., 0, 0] * j[..., 1, 1] - j[..., 0, 1] * j[..., 1, 0]
    return np.stack([x, y], -1), (resid <= TOLERANCE) & (det > 0) & (x * x + y * y < max_r2)


def equi_poly(k, t2):
    k1, k2, k3, k4 = k
    poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))
    dpoly = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)))
    return poly, dpoly


def equi_point(k, p):
    """θ_d (X, Y)/ρ (..., 2), d/dP (..., 2, 3), d/dk (..., 2, 4)."""
    X, Y, Z = p[..., 0], p[..., 1], p[..., 2]
    rho = np.hypot(X, Y)
    a = atan2c(rho, Z)
    theta = rho * a
    t2 = theta * theta
    poly, dpoly = equi_poly(k, t2)
    s = a * poly
    q = rho * rho + Z * Z
    c = dpoly * Z / q - s
    with np.errstate(divide="ignore", invalid="ignore"):
        nx = np.where(rho > 0, X / rho, 0.0)
        ny = np.where(rho > 0, Y / rho, 0.0)
    dz = -dpoly / q
    j = np.stack(
        [np.stack([s + c * nx * nx, c * nx * ny, X * dz], -1), np.stack([c * nx * ny, s + c * ny * ny, Y * dz], -1)], -2
    )
    powers = [a * t2]
    for _ in range(3):
        powers.append(powers[-1] * t2)
    jk = np.stack([np.stack([X * w for w in powers], -1), np.stack([Y * w for w in powers], -1)], -2)
    return np.stack([X * s, Y * s], -1), j, jk


def equi_theta(k, max_theta, xy_d):
    rd = np.hypot(xy_d[..., 0], xy_d[..., 1])
    theta = np.array(np.minimum(rd, max_theta))
    active = np.ones(rd.shape, dtype=bool)
    for _ in range(MAX_ITERATIONS):
        if not active.any():
            break
        t = theta[active]
        poly, dpoly = equi_poly(k, t * t)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = (t * poly - rd[active]) / dpoly
        theta[active] = np.clip(t - step, 0.0, max_theta)
        idx = np.flatnonzero(active)
        active[idx[~(np.abs(step) > STEP_DONE)]] = False
    poly, _ = equi_poly(k, theta * theta)
    return theta, poly, (np.abs(theta * poly - rd) <= TOLERANCE) & (theta < max_theta)


def equi_undistort(k, max_theta, xy_d):
    theta, poly, valid = equi_theta(k, max_theta, xy_d)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = sinc(theta) / (np.cos(theta) * poly)
    return xy_d * f[..., None], valid & (theta < 0.5 * np.pi)


def equi_bearing(k, max_theta, xy_d):
    theta, poly, valid = equi_theta(k, max_theta, xy_d)
    f = sinc(theta) / poly
    return np.concatenate([xy_d * f[..., None], np.cos(theta)[..., None]], -1), valid


def project(model: str, p8, points):
    """Pixels (..., 2), d/dP (..., 2, 3), d/dparams (..., 2, 8)."""
    p8 = np.asarray(p8)
    o, j3, jk = (radtan_point if model == "radtan" else equi_point)(p8[4:], points)
    f = p8[:2]
    px = o * f + p8[2:4]
    jp = np.zeros(o.shape[:-1] + (2, 8))
    jp[..., 0, 0], jp[..., 1, 1], jp[..., 0, 2], jp[..., 1, 3] = o[..., 0], o[..., 1], 1.0, 1.0
    jp[..., 4:] = jk * f[:, None]
    return px, j3 * f[:, None], jp
