"""Re-run of Walker, Shao & Volz (1991) §4: accuracy of the DQ and SVD estimators on the "Feeder", and timing.

The paper's Feeder (32 vertices, 322 x 84 x 151 units) is not published beyond its size, so the object here is
generated: the 8 corners of the box ``[0, 322] x [0, 84] x [0, 151]`` (model origin at a corner, as in a CAD model)
plus 24 vertices drawn uniformly (seeded) on the box's faces.  The true pose is a 36° rotation about
``(3, 4, 6)`` followed by the translation ``(7, 8, 13)``; measured points get N(0, 0.5²) noise per coordinate;
5/10/20/30 vertices are drawn (without replacement) for each of 25 point sets, each run with 20 noise draws; all
weights are 1.  Per point set the std over the 20 trials is taken, then the root-mean-square over the 25 sets is
reported (the paper does not say how it combined them).  ``θ`` is the rotation angle in degrees.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["PAPER_TABLE3", "feeder_vertices", "accuracy_experiment", "timing_experiment", "mixed_experiment", "run"]

#: Walker 1991 Table 3: n_points -> {method: (std x, std y, std z, std θ)}
PAPER_TABLE3 = {
    5: {"svd": (1.434, 3.013, 1.190, 0.147), "dq": (0.461, 0.277, 0.509, 0.147)},
    10: {"svd": (1.133, 2.373, 0.843, 0.046), "dq": (0.133, 0.215, 0.169, 0.046)},
    20: {"svd": (0.296, 0.607, 0.254, 0.040), "dq": (0.102, 0.187, 0.108, 0.040)},
    30: {"svd": (0.171, 0.246, 0.125, 0.037), "dq": (0.115, 0.115, 0.087, 0.037)},
}
SIZE = (322.0, 84.0, 151.0)
AXIS = (3.0, 4.0, 6.0)
ANGLE_DEG = 36.0
TRANSLATION = (7.0, 8.0, 13.0)
SIGMA = 0.5

Progress = Callable[[float, str], None]


def _quiet(frac: float, stage: str) -> None:
    return None


def feeder_vertices(seed: int = 1991) -> np.ndarray:
    """32 model vertices (32, 3): the box corners and 24 seeded points on the faces of the 322 x 84 x 151 box."""
    rng = np.random.default_rng(seed)
    size = np.array(SIZE)
    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float) * size
    pts = rng.uniform(0, 1, size=(24, 3)) * size
    axis = rng.integers(0, 3, 24)
    side = rng.integers(0, 2, 24)
    pts[np.arange(24), axis] = side * size[axis]  # push each onto a face
    verts: NDArray[np.float64] = np.r_[corners, pts]
    return verts


def _truth() -> tuple[np.ndarray, np.ndarray]:
    import dualpose as dp

    return dp.quat_from_axis_angle(np.array(AXIS), np.deg2rad(ANGLE_DEG)), np.array(TRANSLATION)


def accuracy_experiment(
    n_points: tuple[int, ...] = (5, 10, 20, 30),
    n_sets: int = 25,
    n_trials: int = 20,
    seed: int = 1991,
    progress: Progress = _quiet,
) -> list[dict[str, Any]]:
    """Table 3: rows ``{n_points, method, std_x, std_y, std_z, std_theta_deg, paper: {...}, max_diff_vs_other}``."""
    import dualpose as dp
    from dualpose.registration import register_pose_batch

    rng = np.random.default_rng(seed)
    verts = feeder_vertices(seed)
    q, t = _truth()
    rows = []
    for k, n in enumerate(n_points):
        progress(k / len(n_points), f"accuracy, {n} points")
        idx = np.array([rng.choice(len(verts), n, replace=False) for _ in range(n_sets)])
        p0 = np.repeat(verts[idx], n_trials, axis=0)  # (sets * trials, n, 3)
        p1 = dp.quat_rotate(q, p0) + t + SIGMA * rng.normal(size=p0.shape)
        est = {m: register_pose_batch(p0, p1, method=m) for m in ("svd", "dq")}
        diff = max(
            float(np.abs(est["svd"].quat - est["dq"].quat).max()),
            float(np.abs(est["svd"].translation - est["dq"].translation).max()),
        )
        for m in ("svd", "dq"):
            tr = est[m].translation.reshape(n_sets, n_trials, 3)
            theta = np.rad2deg(2 * np.arctan2(np.linalg.norm(est[m].quat[:, :3], axis=1), est[m].quat[:, 3]))
            theta = theta.reshape(n_sets, n_trials)
            std_t = np.sqrt(np.mean(tr.std(axis=1, ddof=1) ** 2, axis=0))
            std_th = float(np.sqrt(np.mean(theta.std(axis=1, ddof=1) ** 2)))
            paper = PAPER_TABLE3.get(n, {}).get(m)
            rows.append(
                {
                    "n_points": int(n),
                    "method": m,
                    "std_x": float(std_t[0]),
                    "std_y": float(std_t[1]),
                    "std_z": float(std_t[2]),
                    "std_theta_deg": std_th,
                    "paper": None if paper is None else dict(zip(("std_x", "std_y", "std_z", "std_theta_deg"),
                                                                 paper, strict=True)),  # fmt: skip
                    "max_abs_diff_svd_vs_dq": diff,
                }
            )
    return rows


def mixed_experiment(
    n_points: tuple[int, ...] = (3, 4, 5),
    sigma_directions: float = 0.01,
    n_trials: int = 500,
    seed: int = 7,
    progress: Progress = _quiet,
) -> list[dict[str, Any]]:
    """Few points with and without the Feeder's 3 face normals (±x, ±y, ±z up to sign; ``σ_d`` per coordinate).

    Weights are inverse variances (``β = 1/σ_p²``, ``α = 1/σ_d²``).  Rows: ``{n_points, n_directions, std_x,
    std_y, std_z, std_theta_deg, rot_err_rms_deg}``.
    """
    import dualpose as dp
    from dualpose.registration import register_pose_batch

    rng = np.random.default_rng(seed)
    verts = feeder_vertices()
    q, t = _truth()
    normals = np.eye(3)
    rows = []
    for k, n in enumerate(n_points):
        progress(k / len(n_points), f"mixed, {n} points")
        idx = np.array([rng.choice(len(verts), n, replace=False) for _ in range(n_trials)])
        p0 = verts[idx]
        p1 = dp.quat_rotate(q, p0) + t + SIGMA * rng.normal(size=p0.shape)
        n0 = np.broadcast_to(normals, (n_trials, 3, 3)).copy()
        n1 = dp.quat_rotate(q, n0) + sigma_directions * rng.normal(size=n0.shape)
        for with_dirs in (False, True):
            est = register_pose_batch(
                p0, p1, point_weights=np.full(p0.shape[:2], 1 / SIGMA**2),
                model_directions=n0 if with_dirs else None, measured_directions=n1 if with_dirs else None,
                direction_weights=np.full(n0.shape[:2], 1 / sigma_directions**2) if with_dirs else None,
            )  # fmt: skip
            rot_err = dp.quat_angle(est.quat, q)
            err_t = est.translation - t
            rows.append(
                {
                    "n_points": int(n),
                    "n_directions": 3 if with_dirs else 0,
                    "std_x": float(err_t[:, 0].std()),
                    "std_y": float(err_t[:, 1].std()),
                    "std_z": float(err_t[:, 2].std()),
                    "rot_err_rms_deg": float(np.rad2deg(np.sqrt(np.mean(rot_err**2)))),
                    "degenerate_fraction": float(1.0 - est.rotation_unique.mean()),
                }
            )
    return rows


def timing_experiment(
    samples: tuple[int, ...] = (4, 10, 30, 100, 300, 1000, 3000, 10000),
    repeats: int = 200,
    progress: Progress = _quiet,
) -> dict[str, Any]:
    """Fig. 4: time of one ``register_pose(method="dq")`` call vs samples (equal numbers of points and unit
    vectors).  Returns the series and a least-squares line ``a + b n`` with its R²."""
    import dualpose as dp
    from dualpose.registration import register_pose

    rng = np.random.default_rng(0)
    q, t = _truth()
    times = []
    for k, n in enumerate(samples):
        progress(k / len(samples), f"timing, {n} samples")
        npt = n // 2
        ndir = n - npt
        p0 = rng.uniform(0, 300, size=(npt, 3))
        p1 = dp.quat_rotate(q, p0) + t
        d0: NDArray[np.float64] | None = None
        d1: NDArray[np.float64] | None = None
        if ndir:
            d0 = rng.normal(size=(ndir, 3))
            d1 = dp.quat_rotate(q, d0)
        register_pose(p0, p1, model_directions=d0, measured_directions=d1)
        best = np.inf
        reps = max(5, repeats // max(1, n // 100))
        for _ in range(3):
            t0 = time.perf_counter()
            for _ in range(reps):
                register_pose(p0, p1, model_directions=d0, measured_directions=d1)
            best = min(best, (time.perf_counter() - t0) / reps)
        times.append(best)
    x = np.array(samples, float)
    y = np.array(times)
    slope, intercept = np.polyfit(x, y, 1)
    r2 = 1.0 - np.sum((y - (intercept + slope * x)) ** 2) / np.sum((y - y.mean()) ** 2)
    return {
        "samples": list(samples),
        "seconds": [float(v) for v in times],
        "fit_intercept_s": float(intercept),
        "fit_slope_s_per_sample": float(slope),
        "fit_r2": float(r2),
    }


def run(quick: bool = False, progress: Progress = _quiet) -> dict[str, Any]:
    """All three experiments; ``quick`` uses 5 sets x 10 trials and a shorter timing series (for tests)."""
    stages = [0.0, 0.6, 0.8, 1.0]

    def sub(i: int) -> Progress:
        return lambda f, s: progress(stages[i] + f * (stages[i + 1] - stages[i]), s)

    if quick:
        rows = accuracy_experiment(n_sets=5, n_trials=10, progress=sub(0))
        mixed = mixed_experiment(n_trials=100, progress=sub(1))
        timing = timing_experiment(samples=(4, 10, 100, 1000), repeats=20, progress=sub(2))
    else:
        rows = accuracy_experiment(progress=sub(0))
        mixed = mixed_experiment(progress=sub(1))
        timing = timing_experiment(progress=sub(2))
    progress(1.0, "done")
    return {
        "experiment": "walker1991",
        "setup": {
            "object": "32 vertices: corners of [0,322]x[0,84]x[0,151] + 24 seeded points on its faces (seed 1991)",
            "rotation": {"axis": list(AXIS), "angle_deg": ANGLE_DEG},
            "translation": list(TRANSLATION),
            "sigma_points": SIGMA,
            "sets": 5 if quick else 25,
            "trials_per_set": 10 if quick else 20,
        },
        "rows": rows,
        "mixed": mixed,
        "timing": timing,
    }
