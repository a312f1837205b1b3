"""Speed of dualpose.registration against scipy and against an unrolled closed-form reference loop, in one process.

Run: ``.venv/bin/python benchmarks/bench_registration.py`` (``--quick`` for B = 10,000; ``--markdown PATH`` also
writes the tables to a new file).

What is timed
-------------
* **batch**: ``register_pose_batch`` on B problems x 10 points (default B = 100,000; noisy random poses), each
  method, including argument checking and the result object.
* **reference loop**: a numba loop, written here independently of the library, that solves each problem in closed
  form with unrolled scalar code: centroids, the 3x3 cross-covariance, the quartic characteristic polynomial of
  Horn's N (coefficients from ``‖H‖²``, ``det H``, ``det N``), Newton from the upper bound ``(G_a + G_b)/2``
  (Theobald 2005's QCP idea), and the eigenvector as the best column of ``adj(N − λ I)``.  No checks, no result
  object: the floor for a per-problem closed-form solve.
* **scipy loop**: a Python loop over the problems calling ``Rotation.align_vectors`` on centred points plus the
  centroid arithmetic (what a scipy user writes); timed on a subset and reported per problem.
* **single**: one problem of 10 points: ``register_pose`` vs scipy ``align_vectors`` + centroids (timeit, best of
  repeats).

Before timing, every method's rotations are checked against scipy on a subset (|Δq| <= 1e-9 after the sign).
Times are the best of k calls (the machine may be shared); the reference loop and the batch methods are timed
in interleaved rounds so that they see the same load; ``gc`` is disabled while timing.
"""

from __future__ import annotations

import argparse
import math
import platform
import timeit

import numba as nb
import numpy as np
import scipy
from scipy.spatial.transform import Rotation

import dualpose as dp
from _common import best_of, best_of_interleaved, emit
from dualpose.registration import register_pose, register_pose_batch


# ------------------------------------------------------------------------------------------ the reference loop
@nb.njit(cache=True)
def _det3(a, b, c, d, e, f, g, h, i):
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


@nb.njit(cache=True)
def reference_loop(p0, p1, out):
    """Closed-form rigid registration of each problem ``p0[b] -> p1[b]``; writes [q xyzw, t] to ``out[b]``."""
    n = p0.shape[1]
    for b in range(p0.shape[0]):
        ax = ay = az = bx = by = bz = 0.0
        for k in range(n):
            ax += p0[b, k, 0]
            ay += p0[b, k, 1]
            az += p0[b, k, 2]
            bx += p1[b, k, 0]
            by += p1[b, k, 1]
            bz += p1[b, k, 2]
        ax /= n
        ay /= n
        az /= n
        bx /= n
        by /= n
        bz /= n
        sxx = sxy = sxz = syx = syy = syz = szx = szy = szz = 0.0
        ga = gb = 0.0
        for k in range(n):
            x0, y0, z0 = p0[b, k, 0] - ax, p0[b, k, 1] - ay, p0[b, k, 2] - az
            x1, y1, z1 = p1[b, k, 0] - bx, p1[b, k, 1] - by, p1[b, k, 2] - bz
            ga += x0 * x0 + y0 * y0 + z0 * z0
            gb += x1 * x1 + y1 * y1 + z1 * z1
            sxx += x0 * x1
            sxy += x0 * y1
            sxz += x0 * z1
            syx += y0 * x1
            syy += y0 * y1
            syz += y0 * z1
            szx += z0 * x1
            szy += z0 * y1
            szz += z0 * z1
        # Horn's N in xyzw order
        n00, n11, n22, n33 = sxx - syy - szz, -sxx + syy - szz, -sxx - syy + szz, sxx + syy + szz
        n01, n02, n12 = sxy + syx, szx + sxz, syz + szy
        n03, n13, n23 = syz - szy, szx - sxz, sxy - syx
        # characteristic polynomial λ⁴ + c2 λ² + c1 λ + c0
        hh = sxx * sxx + sxy * sxy + sxz * sxz + syx * syx + syy * syy + syz * syz + szx * szx + szy * szy + szz * szz
        c2 = -2.0 * hh
        c1 = -8.0 * _det3(sxx, sxy, sxz, syx, syy, syz, szx, szy, szz)
        c0 = (
            n00 * _det3(n11, n12, n13, n12, n22, n23, n13, n23, n33)
            - n01 * _det3(n01, n12, n13, n02, n22, n23, n03, n23, n33)
            + n02 * _det3(n01, n11, n13, n02, n12, n23, n03, n13, n33)
            - n03 * _det3(n01, n11, n12, n02, n12, n22, n03, n13, n23)
        )
        lam = 0.5 * (ga + gb)
        for _ in range(50):
            f = ((lam * lam + c2) * lam + c1) * lam + c0
            df = (4.0 * lam * lam + 2.0 * c2) * lam + c1
            if df == 0.0:
                break
            step = f / df
            lam -= step
            if abs(step) <= 1e-13 * abs(lam):
                break
        m00, m11, m22, m33 = n00 - lam, n11 - lam, n22 - lam, n33 - lam
        # adj(M) = c v vᵀ for the rank-3 M: take the column with the largest diagonal cofactor
        d0 = _det3(m11, n12, n13, n12, m22, n23, n13, n23, m33)
        d1 = _det3(m00, n02, n03, n02, m22, n23, n03, n23, m33)
        d2 = _det3(m00, n01, n03, n01, m11, n13, n03, n13, m33)
        d3 = _det3(m00, n01, n02, n01, m11, n12, n02, n12, m22)
        a0, a1, a2, a3 = abs(d0), abs(d1), abs(d2), abs(d3)
        if a0 >= a1 and a0 >= a2 and a0 >= a3:
            qx, qy, qz, qw = d0, -_det3(n01, n12, n13, n02, m22, n23, n03, n23, m33), _det3(
                n01, m11, n13, n02, n12, n23, n03, n13, m33
            ), -_det3(n01, m11, n12, n02, n12, m22, n03, n13, n23)
        elif a1 >= a2 and a1 >= a3:
            qx, qy, qz, qw = -_det3(n01, n02, n03, n12, m22, n23, n13, n23, m33), d1, -_det3(
                m00, n02, n03, n01, n12, n13, n03, n23, m33
            ), _det3(m00, n02, n03, n01, n12, n13, n02, m22, n23)
        elif a2 >= a3:
            qx, qy, qz, qw = _det3(n01, n02, n03, m11, n12, n13, n13, n23, m33), -_det3(
                m00, n02, n03, n01, n12, n13, n03, n23, m33
            ), d2, -_det3(m00, n01, n03, n01, m11, n13, n02, n12, n23)
        else:
            qx, qy, qz, qw = -_det3(n01, n02, n03, m11, n12, n13, n12, m22, n23), _det3(
                m00, n02, n03, n01, n12, n13, n02, m22, n23
            ), -_det3(m00, n01, n03, n01, m11, n13, n02, n12, n23), d3
        s = 1.0 / math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
        if qw < 0.0:
            s = -s
        qx, qy, qz, qw = qx * s, qy * s, qz * s, qw * s
        out[b, 0], out[b, 1], out[b, 2], out[b, 3] = qx, qy, qz, qw
        # t = c1 - R c0
        xx, yy, zz = qx * qx, qy * qy, qz * qz
        xy, xz, yz, wx, wy, wz = qx * qy, qx * qz, qy * qz, qw * qx, qw * qy, qw * qz
        out[b, 4] = bx - ((1 - 2 * (yy + zz)) * ax + 2 * (xy - wz) * ay + 2 * (xz + wy) * az)
        out[b, 5] = by - (2 * (xy + wz) * ax + (1 - 2 * (xx + zz)) * ay + 2 * (yz - wx) * az)
        out[b, 6] = bz - (2 * (xz - wy) * ax + 2 * (yz + wx) * ay + (1 - 2 * (xx + yy)) * az)


def scipy_loop(p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What a scipy user writes: centroids, align_vectors on the centred points, t = c1 - R c0, per problem."""
    qs = np.empty((p0.shape[0], 4))
    ts = np.empty((p0.shape[0], 3))
    for b in range(p0.shape[0]):
        c0, c1 = p0[b].mean(axis=0), p1[b].mean(axis=0)
        rot, _ = Rotation.align_vectors(p1[b] - c1, p0[b] - c0)
        qs[b] = rot.as_quat()
        ts[b] = c1 - rot.apply(c0)
    return qs, ts


# ------------------------------------------------------------------------------------------------------ timing
def same_rotation(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.minimum(np.abs(a - b).max(axis=-1), np.abs(a + b).max(axis=-1)).max())


def problems(b: int, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    p0 = rng.normal(size=(b, n, 3)) * 2.0
    q = dp.quat_normalize(rng.normal(size=(b, 4)))
    t = rng.normal(size=(b, 3)) * 5.0
    p1 = dp.quat_rotate(q[:, None, :], p0) + t[:, None, :] + 0.01 * rng.normal(size=(b, n, 3))
    return p0, p1


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="B = 10,000 instead of 100,000")
    ap.add_argument("--markdown", metavar="PATH", help="also write the tables as Markdown")
    args = ap.parse_args(argv)
    big = 10_000 if args.quick else 100_000
    n = 10
    rng = np.random.default_rng(2026)
    p0, p1 = problems(big, n, rng)
    sub = 2_000

    # correctness before timing
    ref_q, ref_t = scipy_loop(p0[:sub], p1[:sub])
    out = np.empty((big, 7))
    reference_loop(p0, p1, out)
    checks = {"reference loop": (same_rotation(out[:sub, :4], ref_q), float(np.abs(out[:sub, 4:] - ref_t).max()))}
    for m in ("dq", "horn", "svd"):
        r = register_pose_batch(p0, p1, method=m)
        checks[f"batch {m}"] = (same_rotation(r.quat[:sub], ref_q), float(np.abs(r.translation[:sub] - ref_t).max()))
    for name, (dq_err, dt_err) in checks.items():
        if not (dq_err <= 1e-9 and dt_err <= 1e-8):
            raise SystemExit(f"{name} disagrees with scipy: |Δq| = {dq_err:.2e}, |Δt| = {dt_err:.2e}")

    rows = []
    timed = {"ref": lambda: reference_loop(p0, p1, out)}
    for m in ("dq", "horn", "svd"):
        timed[m] = lambda m=m: register_pose_batch(p0, p1, method=m)
    best = best_of_interleaved(timed)
    t_ref = best["ref"]
    t_scipy = best_of(lambda: scipy_loop(p0[:sub], p1[:sub]), k=3) / sub * big
    rows.append(("reference loop (numba, unrolled closed form)", t_ref, None))
    for m in ("dq", "horn", "svd"):
        rows.append((f"register_pose_batch(method={m!r})", best[m], m))
    rows.append((f"scipy align_vectors + centroids, Python loop (timed on {sub:,})", t_scipy, None))

    lines = [
        f"## Batch: B = {big:,} problems x {n} points",
        "",
        "| implementation | total [ms] | per problem [µs] | vs reference loop | speed-up vs scipy loop |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, t, _ in rows:
        lines.append(f"| {name} | {t * 1e3:.1f} | {t / big * 1e6:.3f} | {t / t_ref:.2f}x | {t_scipy / t:.0f}x |")

    # single problem
    a, b = p0[0], p1[0]

    def scipy_single() -> None:
        c0, c1 = a.mean(axis=0), b.mean(axis=0)
        rot, _ = Rotation.align_vectors(b - c1, a - c0)
        _ = c1 - rot.apply(c0)

    def best_timeit(fn, number: int = 2000) -> float:
        return min(timeit.repeat(fn, number=number, repeat=7)) / number

    t_sc = best_timeit(scipy_single)
    lines += [
        "",
        f"## Single problem, n = {n}",
        "",
        "| implementation | per call [µs] | speed-up vs scipy |",
        "|---|---:|---:|",
        f"| scipy align_vectors + centroids | {t_sc * 1e6:.1f} | 1.0x |",
    ]
    for m in ("dq", "horn", "svd"):
        t = best_timeit(lambda m=m: register_pose(a, b, method=m))
        lines.append(f"| register_pose(method={m!r}) | {t * 1e6:.1f} | {t_sc / t:.1f}x |")
    lines += [
        "",
        "Agreement with scipy before timing (max over "
        f"{sub:,} problems): " + ", ".join(f"{k}: |Δq| {v[0]:.1e}, |Δt| {v[1]:.1e}" for k, v in checks.items()),
        "",
        f"numpy {np.__version__}, scipy {scipy.__version__}, numba {nb.__version__}, Python "
        f"{platform.python_version()}, {platform.machine()}; best of 9 interleaved rounds (scipy loop: best of 3).",
    ]
    return emit("\n".join(lines), args.markdown)


if __name__ == "__main__":
    raise SystemExit(main())
