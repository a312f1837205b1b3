"""Speed of the camera-IMU filters: real-time factor on the eight-shaped run and µs per predict / update next to
filterpy's ``ExtendedKalmanFilter`` with the same state size (15), in one process.

Run ``.venv/bin/python benchmarks/bench_fusion.py`` (needs the ``bench`` extra for filterpy; ``make bench`` installs
it).  ``--markdown PATH`` also writes the table.

Method: every callable is called once to warm up, then timed with ``timeit`` as the best of 7 repeats of a loop of
``number`` calls (``gc`` disabled by timeit), reported per call.  What each call does:

* ``ErrorStateEKF.predict``: nominal-state strapdown (attitude, velocity, position), building the 15 × 15 error
  transition F and ``P ← F P Fᵀ + Q`` — through the Python method (argument handling included) and the bare native
  kernel (``dualpose._native.eskf_predict``).  filterpy's ``predict()`` does only the linear ``x ← F x``,
  ``P ← F P Fᵀ + Q`` with a fixed F.
* Update with one 2-D point correspondence: dualpose computes the reprojection residual and its Jacobian, the χ²
  gate, a Joseph-form update, injection and reset; filterpy ``update(z, HJacobian, Hx, R)`` with constant
  Python callables returning H (2 × 15) and h (its standard, non-Joseph form).
* A whole frame of 20 correspondences: dualpose's sequential gated update vs filterpy's stacked 40-row update.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import timeit

import numpy as np

from _common import emit
from dualpose import sim
from dualpose.estimation import eskf, hol22


def best_us(fn, number: int) -> float:
    fn()
    return min(timeit.repeat(fn, number=number, repeat=7)) / number * 1e6


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--markdown", help="also write the tables to this Markdown file")
    args = ap.parse_args()

    run = sim.simulate_eight(0)
    tr = run.truth
    duration = run.t[-1] - run.t[0]

    def new_filter() -> eskf.ErrorStateEKF:
        return eskf.ErrorStateEKF.for_run(run, tr["position"][0], tr["velocity"][0], tr["quat"][0])

    rows: list[tuple[str, float, str]] = []
    # --- whole run
    walls = []
    for _ in range(15):
        walls.append(new_filter().run_recording(run).wall_time)
    wall = min(walls)
    n_imu, n_frames = len(run.t), len(run.frames)
    rows.append(("ESKF whole eight run (batch `run`, native)", wall * 1e6, f"{duration / wall:.0f}x real time"))
    hwall = min(hol22.Hol22EKF.from_eskf_state(new_filter().x, new_filter().P, run).run_recording(run).wall_time
                for _ in range(15))  # fmt: skip
    rows.append(("Hol22 whole eight run (batch `run`, numba)", hwall * 1e6, f"{duration / hwall:.0f}x real time"))
    # online API over the run

    def online() -> None:
        f = new_filter()
        fr = run.frames
        j = 0
        for k in range(n_imu):
            while k > 0 and j < n_frames and fr.t[j] < run.t[k]:  # frames between samples: held IMU input
                f.update_camera(fr.t[j], *fr.frame(j))
                j += 1
            f.propagate(run.t[k], run.gyro[k], run.accel[k])

    t_on = best_us(online, 1)
    rows.append(
        (
            "ESKF whole eight run (online `propagate`/`update_camera`)",
            t_on,
            f"{duration / (t_on * 1e-6):.0f}x real time",
        )
    )

    # --- per call
    from dualpose import _native

    g, a = run.gyro[300].copy(), run.accel[300].copy()
    f = new_filter()
    rows.append(("dualpose ESKF.predict (Python method)", best_us(lambda: f.predict(g, a, 0.01), 2000), ""))
    x, P = f.x, f.P
    rows.append(("dualpose predict kernel (native, direct)",
                 best_us(lambda: _native.eskf_predict(x, P, g, a, 0.01, f.gravity, f.noise), 5000), ""))  # fmt: skip
    pix, pts = run.frames.frame(40)
    pix = np.ascontiguousarray(pix)
    pts = np.ascontiguousarray(pts)
    kin = run.motion.kinematics(run.frames.t_true[40:41])
    fu = new_filter()
    fu.x[0:3], fu.x[3:6], fu.x[6:10] = kin["position"][0], kin["velocity"][0], kin["quat"][0]
    nis1, acc1 = np.empty(1), np.zeros(1, np.int64)
    nis20, acc20 = np.empty(20), np.zeros(20, np.int64)
    p1, q1 = pix[:1].copy(), pts[:1].copy()

    upd, xu, Pu, intr, q_bc, p_bc = _native.eskf_update_points, fu.x, fu.P, fu.intrinsics, fu.q_bc, fu.p_bc

    rows.append(
        (
            "dualpose update, 1 correspondence (kernel)",
            best_us(lambda: upd(xu, Pu, intr, q_bc, p_bc, p1, q1, 1.0, 1e9, nis1, acc1), 2000),
            "",
        )
    )
    rows.append(
        (
            "dualpose update, frame of 20 (kernel)",
            best_us(lambda: upd(xu, Pu, intr, q_bc, p_bc, pix, pts, 1.0, 1e9, nis20, acc20), 500),
            "",
        )
    )
    rows.append(("dualpose ESKF.update_camera, frame of 20 (Python method)", best_us(
        lambda: fu.update_camera(fu.time or 0.0, pix, pts), 500), ""))  # fmt: skip

    try:
        from filterpy.kalman import ExtendedKalmanFilter
    except ImportError:
        print("filterpy not installed (pip install -e '.[bench]'); peer rows skipped", file=sys.stderr)
    else:
        ekf = ExtendedKalmanFilter(dim_x=15, dim_z=2)
        ekf.F = np.eye(15) + np.diag(np.full(12, 0.01), 3)
        ekf.Q = np.eye(15) * 1e-6
        ekf.P = np.eye(15) * 1e-2
        rows.append(("filterpy ExtendedKalmanFilter.predict (dim_x=15)", best_us(ekf.predict, 2000), ""))
        H2 = np.random.default_rng(0).normal(size=(2, 15))
        R2 = np.eye(2)
        z2 = np.zeros(2)
        rows.append(("filterpy EKF.update, dim_z=2", best_us(
            lambda: ekf.update(z2, lambda _x: H2, lambda _x: H2 @ _x, R=R2), 2000), ""))  # fmt: skip
        ekf40 = ExtendedKalmanFilter(dim_x=15, dim_z=40)
        ekf40.P = np.eye(15) * 1e-2
        H40 = np.random.default_rng(1).normal(size=(40, 15))
        R40 = np.eye(40)
        z40 = np.zeros(40)
        rows.append(("filterpy EKF.update, stacked frame dim_z=40", best_us(
            lambda: ekf40.update(z40, lambda _x: H40, lambda _x: H40 @ _x, R=R40), 500), ""))  # fmt: skip

    head = f"Python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, pid {os.getpid()}"
    lines = [
        f"Eight-shaped run: {duration:.1f} s, {n_imu} IMU samples (100 Hz), {n_frames} frames x 20 correspondences. "
        + head,
        "",
        "| operation | µs per call | note |",
        "|---|---:|---|",
    ]
    lines += [f"| {name} | {us:,.1f} | {note} |" for name, us, note in rows]
    text = "\n".join(lines)
    return emit(text, args.markdown)


if __name__ == "__main__":
    raise SystemExit(main())
