"""Simulated hand-eye recordings with known ``X`` and ``τ``: a camera stream with the faults of real files; and the
scoring shared by the hand-eye tests (loop-residual RMSE, OpenCV's closed forms on the same pairs).

Frames: body pose ``B(t)`` (body clock), camera pose in the target ``A = T⁻¹ B(s + τ) X`` at camera stamp ``s``
(``T`` the target in the body's reference frame).  Shared by ``tests/calibration`` and ``tests/cli``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import dualpose as dp
from dualpose.calibration import interpolate_stream, pair_motions, pair_residuals

OPENCV_METHODS = ("TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS")


def loop_rmse(cam, body, pairs, tau, q, t):
    """RMS rotation angle (deg) and translation norm (m) of the loop residuals of ``pairs`` (m, 2) at ``tau``."""
    qa, ta, qb, tb, ok = pair_motions(cam, body, pairs[:, 0], pairs[:, 1], tau)
    rv, te = pair_residuals(qa[ok], ta[ok], qb[ok], tb[ok], q, t)
    return np.degrees(np.sqrt(np.mean(np.sum(rv**2, 1)))), np.sqrt(np.mean(np.sum(te**2, 1)))


def opencv_hand_eye(cam, body, pairs, tau, method, max_poses=150):
    """OpenCV's ``X`` (quat xyzw, translation) from the camera samples of ``pairs`` (evenly thinned to ``max_poses``)
    with the body interpolated at ``t + tau``."""
    import cv2

    idx = np.unique(pairs)
    idx = idx[np.linspace(0, len(idx) - 1, min(max_poses, len(idx))).round().astype(int)]
    pb, qb, ok = interpolate_stream(body, cam.stamps[idx] + tau)
    qc, tc = dp.qt_conj(cam.quats[idx[ok]], cam.positions[idx[ok]])
    r, t = cv2.calibrateHandEye(list(dp.matrix_from_quat(qb[ok])), list(pb[ok][:, :, None]),
                                list(dp.matrix_from_quat(qc)), list(tc[:, :, None]),
                                method=getattr(cv2, f"CALIB_HAND_EYE_{method}"))  # fmt: skip
    return dp.quat_from_matrix(r), t.ravel()


@dataclass
class SimRecording:
    camera: np.ndarray  # (n, 8) rows t, x, y, z, qx, qy, qz, qw as a file would hold them (unsorted, duplicates)
    body: np.ndarray  # (m, 8)
    quat: np.ndarray  # true X rotation (4,)
    translation: np.ndarray  # true X translation (3,)
    time_offset: float
    outliers: int


def _body_pose(t: np.ndarray, coef: dict) -> tuple[np.ndarray, np.ndarray]:
    u = t - coef["t0"]
    rv = sum(a * np.sin(2 * np.pi * f * u[:, None] + p) for a, f, p in coef["rot"])
    pos = sum(a * np.sin(2 * np.pi * f * u[:, None] + p) for a, f, p in coef["pos"])
    return dp.quat_from_rotvec(rv + coef["rot0"]), pos + coef["pos0"]


def simulate(
    time_offset: float, seed: int, *, duration: float = 50.0, camera_rate: float = 30.0, body_rate: float = 100.0,
    outlier_fraction: float = 0.05, duplicate_fraction: float = 0.03, camera_noise_deg: float = 0.15,
    camera_noise_m: float = 0.001, gaps: tuple[tuple[float, float], ...] = ((10.0, 12.5), (27.0, 28.0), (38.0, 41.0)),
    body_t0: float = 1.7e9,
) -> SimRecording:  # fmt: skip
    rng = np.random.default_rng(seed)
    coef = {
        "t0": body_t0,
        "rot": [(rng.uniform(0.15, 0.5, 3), rng.uniform(0.05, 0.35, 3), rng.uniform(0, 6.3, 3)) for _ in range(3)],
        "pos": [(rng.uniform(0.05, 0.2, 3), rng.uniform(0.05, 0.3, 3), rng.uniform(0, 6.3, 3)) for _ in range(2)],
        "rot0": rng.normal(size=3),
        "pos0": rng.normal(size=3),
    }  # fmt: skip
    qx = dp.quat_canonical(dp.quat_from_rotvec(rng.normal(size=3)))
    tx = rng.uniform(-0.1, 0.1, 3)
    qt, tt = dp.quat_from_rotvec(rng.normal(size=3)), rng.normal(size=3)  # target in the reference frame
    # body stream: body clock, 100 Hz with tiny noise
    tb = body_t0 + np.arange(0.0, duration, 1.0 / body_rate)
    qb, pb = _body_pose(tb, coef)
    qb = dp.quat_mul(dp.quat_from_rotvec(rng.normal(scale=np.deg2rad(0.02), size=(len(tb), 3))), qb)
    pb = pb + rng.normal(scale=1e-4, size=pb.shape)
    # camera stream: camera clock s, body time s + τ, inside the body span, with jitter and gaps
    s = body_t0 - time_offset + 1.0 + np.arange(0.0, duration - 2.0, 1.0 / camera_rate)
    s = s + rng.uniform(-2e-3, 2e-3, s.size)
    u = s + time_offset - body_t0
    keep = np.ones(s.size, bool)
    for a, b in gaps:
        keep &= ~((u >= a) & (u < b))
    s = s[keep]
    qbs, pbs = _body_pose(s + time_offset, coef)
    qbx, tbx = dp.qt_mul(qbs, pbs, qx, tx)
    qa, ta = dp.qt_mul(*dp.qt_conj(qt, tt), qbx, tbx)
    qa = dp.quat_mul(qa, dp.quat_from_rotvec(rng.normal(scale=np.deg2rad(camera_noise_deg), size=(s.size, 3))))
    ta = ta + rng.normal(scale=camera_noise_m, size=ta.shape)
    n_out = int(round(outlier_fraction * s.size))
    bad = rng.choice(s.size, n_out, replace=False)
    axis = rng.normal(size=(n_out, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    qa[bad] = dp.quat_mul(dp.quat_from_rotvec(axis * np.deg2rad(rng.uniform(10, 40, (n_out, 1)))), qa[bad])
    ta[bad] += rng.uniform(0.05, 0.2, (n_out, 1)) * rng.choice([-1, 1], (n_out, 3))
    qa = qa * rng.choice([-1.0, 1.0], (s.size, 1))  # arbitrary quaternion signs
    camera = _faulty_rows(np.column_stack([s, ta, qa]), rng, duplicate_fraction)
    body = _faulty_rows(np.column_stack([tb, pb, qb]), rng, duplicate_fraction)
    return SimRecording(camera, body, qx, tx, float(time_offset), n_out)


def _faulty_rows(rows: np.ndarray, rng: np.random.Generator, duplicate_fraction: float) -> np.ndarray:
    dup = rng.choice(len(rows), int(round(duplicate_fraction * len(rows))), replace=False)
    out = np.vstack([rows, rows[dup]])
    return out[rng.permutation(len(out))]


def write_rows(path, rows: np.ndarray, sep: str = ", ") -> None:
    with open(path, "w") as f:
        f.write("# t, x, y, z, qx, qy, qz, qw\n")
        for r in rows:
            f.write(sep.join(f"{v:.17g}" for v in r) + "\n")
