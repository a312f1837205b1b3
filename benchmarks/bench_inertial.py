"""Throughput of dualpose.inertial.integrate_attitude / integrate_pose (target: >= 1e6 updates/s, docs/inertial.md §5).

Run: ``.venv/bin/python benchmarks/bench_inertial.py [--updates 1000000]``

Each configuration is called once to load the compiled kernels, then timed best-of-5 with ``perf_counter``.  As a
reference the same fold is timed as a Python loop over updates calling the algebra (``dp.quat_mul`` /
``dp.dualquat_mul`` on the precomputed per-update steps) on 20,000 updates: the speed a user gets without a fused
kernel.  No peer library offers N-sample coning / screw-vector integration, so there is no peer column.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import dualpose as dp
import dualpose.inertial as di


def best(f, reps: int = 5) -> float:
    f()
    out = np.inf
    for _ in range(reps):
        t = time.perf_counter()
        f()
        out = min(out, time.perf_counter() - t)
    return out


def python_loop(steps: np.ndarray, mul, x0: np.ndarray) -> np.ndarray:
    out = [x0]
    for s in steps:
        out.append(mul(out[-1], s))
    return np.array(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--updates", type=int, default=1_000_000)
    k = ap.parse_args().updates
    rng = np.random.default_rng(1)
    print(f"{k} updates, numpy {np.__version__}\n")
    print("| function | N | coefficients | frame | time [ms] | updates/s |")
    print("|---|---|---|---|---|---|")
    for n, fam in [
        (1, "coning-optimal"),
        (1, "one-plus-previous"),
        (2, "coning-optimal"),
        (3, "coning-optimal"),
        (3, "polynomial"),
        (4, "coning-optimal"),
    ]:
        inc = rng.normal(size=(k * n, 6)) * 0.01
        for name, x0, x in [
            ("integrate_attitude", dp.quat_identity(), inc[:, :3]),
            ("integrate_pose", dp.dualquat_identity(), inc),
        ]:
            for frame in ("body", "space"):
                f = getattr(di, name)
                t = best(lambda f=f, x0=x0, x=x, n=n, fam=fam, frame=frame: f(x0, x, n, fam, frame))
                print(f"| {name} | {n} | {fam} | {frame} | {1e3 * t:.1f} | {k / t:,.0f} |")
    m = 20_000
    inc = rng.normal(size=(m * 3, 6)) * 0.01
    qsteps = dp.quat_from_rotvec(di.rotation_vector(inc[:, :3], 3))
    dsteps = di.screw_exp(di.screw_vector(inc, 3))
    tq = best(lambda: python_loop(qsteps, dp.quat_mul, dp.quat_identity()), reps=2)
    td = best(lambda: python_loop(dsteps, dp.dualquat_mul, dp.dualquat_identity()), reps=2)
    fq = best(lambda: di.integrate_attitude(dp.quat_identity(), inc[:, :3], 3))
    fd = best(lambda: di.integrate_pose(dp.dualquat_identity(), inc, 3))
    print("\n| fold (N=3, body) | Python loop over algebra calls [updates/s] | fused kernel [updates/s] | ratio |")
    print("|---|---|---|---|")
    print(f"| attitude | {m / tq:,.0f} | {m / fq:,.0f} | {tq / fq:.0f}x |")
    print(f"| pose | {m / td:,.0f} | {m / fd:,.0f} | {td / fd:.0f}x |")


if __name__ == "__main__":
    main()
