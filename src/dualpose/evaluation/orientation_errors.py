"""Orientation errors in the earth frame, split into heading and inclination (the BROAD benchmark's metric).

BROAD (Laidig, Caruso, Cereatti, Seel, "BROAD -- A Benchmark for Robust Inertial Orientation Estimation", Data 6(7)
72, 2021, CC BY 4.0) scores an estimate ``q_est`` (IMU → earth, ENU) against the optical reference ``q_ref`` with
the **earth-frame** error quaternion ``e = q_est ⊗ q_ref*`` and splits it into a rotation about the vertical (the
heading error) and a rotation about a horizontal axis (the inclination error): for ``e = (x, y, z, w)`` (xyzw)

* total error ``2 atan2(|(x, y, z)|, |w|)``,
* heading error ``2 atan2(|z|, |w|)`` (the twist of ``e`` about earth z),
* inclination error ``2 atan2(|(x, y)|, |(z, w)|)`` (the swing: the angle between the true and estimated vertical).

These are BROAD's definitions written with ``atan2`` (equal to its ``2 arccos|w|``, ``2 arctan|z/w|`` and
``2 arccos √(w² + z²)`` for unit quaternions, but accurate near 0 and π).  RMSEs are taken over the trial's
``movement`` samples, skipping samples whose reference is NaN (the optical system lost the markers).

Heading offset.  BROAD's published evaluation applies no alignment: the optical frame of the dataset was
aligned with the magnetic east-north-up frame when the dataset was made, so a 9D estimate in magnetic ENU is
compared as is.  A 6D estimate has no absolute heading; :func:`orientation_rmse` with ``fit_heading_offset=True``
first rotates the whole estimate about the vertical by the one constant angle that minimises the total RMSE over
the scored samples (the same correction for every method compared).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["OrientationRmse", "earth_error_quat", "heading_inclination_errors", "orientation_rmse"]


def _unit_rows(q: np.ndarray, name: str) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 4:
        raise ValueError(f"{name} must have shape (n, 4) (xyzw); got shape {q.shape}")
    unit: NDArray[np.float64] = q / np.linalg.norm(q, axis=1, keepdims=True)
    return unit


def earth_error_quat(q_est: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """Earth-frame error ``e = q_est ⊗ q_ref*`` of IMU → earth orientations, (n, 4) xyzw (rows normalized first)."""
    import dualpose as dp

    a = _unit_rows(q_est, "q_est")
    b = _unit_rows(q_ref, "q_ref")
    if a.shape != b.shape:
        raise ValueError(f"q_est and q_ref must have the same shape; got {a.shape} and {b.shape}")
    return dp.quat_mul(a, dp.quat_conj(b))


def heading_inclination_errors(e: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Total, heading and inclination angle (rad, each (n,)) of earth-frame error quaternions ``e`` (n, 4) xyzw."""
    e = np.asarray(e, dtype=np.float64)
    aw, az = np.abs(e[:, 3]), np.abs(e[:, 2])
    total = 2.0 * np.arctan2(np.linalg.norm(e[:, :3], axis=1), aw)
    heading = 2.0 * np.arctan2(az, aw)
    inclination = 2.0 * np.arctan2(np.hypot(e[:, 0], e[:, 1]), np.hypot(az, aw))
    return total, heading, inclination


@dataclass(frozen=True)
class OrientationRmse:
    """RMSEs in degrees and the heading offset that was removed (0 unless fitted), degrees."""

    total_rmse_deg: float
    heading_rmse_deg: float
    inclination_rmse_deg: float
    heading_offset_deg: float
    scored_samples: int

    def as_dict(self) -> dict[str, float]:
        """The five fields by name (for JSON)."""
        return asdict(self)


def _rotate_about_up(e: np.ndarray, angle: float) -> np.ndarray:
    """``Rz(angle) ⊗ e`` for (n, 4) xyzw ``e`` (vectorised, no allocation of the rotation)."""
    s, c = math.sin(0.5 * angle), math.cos(0.5 * angle)
    x, y, z, w = e[:, 0], e[:, 1], e[:, 2], e[:, 3]
    return np.stack([c * x - s * y, c * y + s * x, c * z + s * w, c * w - s * z], axis=1)


def _total_ms(e: np.ndarray, angle: float) -> float:
    r = _rotate_about_up(e, angle)
    t = 2.0 * np.arctan2(np.linalg.norm(r[:, :3], axis=1), np.abs(r[:, 3]))
    return float(np.mean(t * t))


def orientation_rmse(
    q_est: np.ndarray, q_ref: np.ndarray, mask: np.ndarray | None = None, *, fit_heading_offset: bool = False
) -> OrientationRmse:
    """BROAD's total / heading / inclination RMSE (degrees) of ``q_est`` against ``q_ref`` over ``mask``.

    Parameters
    ----------
    q_est, q_ref : array_like, shape (n, 4)
        IMU → earth orientations, xyzw.  Rows of ``q_ref`` containing NaN are skipped; ``q_est`` must be finite on
        the scored samples.
    mask : array_like of bool, shape (n,), optional
        Samples to score (BROAD: ``movement``); default all.
    fit_heading_offset : bool
        Remove the constant rotation about the vertical that minimises the total RMSE (for 6D estimates).

    Returns
    -------
    OrientationRmse
    """
    q_est = np.asarray(q_est, dtype=np.float64)
    q_ref = np.asarray(q_ref, dtype=np.float64)
    if q_est.shape != q_ref.shape or q_est.ndim != 2 or q_est.shape[1] != 4:
        raise ValueError(f"q_est and q_ref must both have shape (n, 4); got {q_est.shape} and {q_ref.shape}")
    sel = np.ones(q_est.shape[0], bool) if mask is None else np.asarray(mask, dtype=bool)
    if sel.shape != (q_est.shape[0],):
        raise ValueError(f"mask must have shape ({q_est.shape[0]},); got {sel.shape}")
    sel = sel & np.isfinite(q_ref).all(axis=1)
    if not sel.any():
        raise ValueError("no sample to score: the mask is empty or the reference is NaN on all of it")
    if not np.isfinite(q_est[sel]).all():
        raise ValueError("q_est contains NaN or inf on scored samples")
    e = earth_error_quat(q_est[sel], q_ref[sel])
    offset = 0.0
    if fit_heading_offset:
        from scipy.optimize import minimize_scalar

        grid = np.radians(np.arange(-180.0, 180.0, 2.0))
        costs = [_total_ms(e, a) for a in grid]
        a0 = float(grid[int(np.argmin(costs))])
        res = minimize_scalar(lambda a: _total_ms(e, a), bounds=(a0 - 0.035, a0 + 0.035), method="bounded",
                              options={"xatol": 1e-7})
        offset = float(res.x)
        e = _rotate_about_up(e, offset)
    total, heading, incl = heading_inclination_errors(e)

    def rms(x: np.ndarray) -> float:
        return float(np.degrees(np.sqrt(np.mean(x * x))))

    return OrientationRmse(rms(total), rms(heading), rms(incl), math.degrees(offset), int(sel.sum()))
