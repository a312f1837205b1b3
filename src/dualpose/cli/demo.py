"""``dualpose demo``: a short self-checking walk-through of the quaternion / dual-quaternion algebra.

It builds two rigid transforms (one from a rotation and a translation, one from Walker's screw parameters),
composes them, transforms points, interpolates with ScLERP and checks every step against 4x4 homogeneous
matrices and scipy's ``RigidTransform`` (an independent implementation).  It prints a table and returns 0 only if
every check is within its tolerance.
"""

from __future__ import annotations

import argparse

import numpy as np

import dualpose as dp
from dualpose.cli._args import seed


def _table(rows: list[tuple[str, str]]) -> None:
    width = max(len(r[0]) for r in rows)
    for name, value in rows:
        print(f"  {name:<{width}}  {value}")


def run_demo(seed: int = 7) -> int:
    """Run the walk-through; returns 0 if all checks pass, 1 otherwise."""
    from scipy.spatial.transform import RigidTransform

    rng = np.random.default_rng(seed)
    # Transform A: 60 degrees about a random axis, then a translation (dual = 1/2 t (x) real).
    axis_a = rng.normal(size=3)
    q_a = dp.quat_from_axis_angle(axis_a, np.deg2rad(60.0))
    t_a = np.array([0.5, -1.0, 2.0])
    dq_a = dp.dualquat_from_qt(q_a, t_a)
    # Transform B: Walker's screw: 120 degrees about a line through p along n, advancing d along n.
    n_b, p_b, d_b, th_b = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), 0.3, np.deg2rad(120.0)
    dq_b = dp.dualquat_from_screw(n_b, p_b, d_b, th_b)

    m_a, m_b = dp.matrix_from_dualquat(dq_a), dp.matrix_from_dualquat(dq_b)
    dq_ab = dp.dualquat_mul(dq_a, dq_b)
    pts = rng.normal(size=(5, 3))
    hom = np.c_[pts, np.ones(5)] @ (m_a @ m_b).T

    print("dualpose demo: dual quaternions [real xyzw, dual xyzw], dual = 1/2 t (x) real\n")
    print("transforms")
    _table(
        [
            ("A (rotation + translation)", np.array2string(dq_a, precision=4, suppress_small=True)),
            ("B (screw: n=z, p=(1,0,0), d=0.3, 120 deg)", np.array2string(dq_b, precision=4, suppress_small=True)),
            ("A (x) B", np.array2string(dq_ab, precision=4, suppress_small=True)),
        ]
    )

    checks: list[tuple[str, float, float]] = []
    checks.append(("compose: M(A (x) B) vs M_A @ M_B", np.abs(dp.matrix_from_dualquat(dq_ab) - m_a @ m_b).max(), 1e-14))
    checks.append(
        ("transform points vs 4x4 matrix", np.abs(dp.dualquat_transform(dq_ab, pts) - hom[:, :3]).max(), 1e-14)
    )
    ref_ab = RigidTransform.from_matrix(m_a) * RigidTransform.from_matrix(m_b)
    checks.append(
        ("A (x) B vs scipy RigidTransform", np.abs(dp.matrix_from_dualquat(dq_ab) - ref_ab.as_matrix()).max(), 1e-14)
    )
    n, p, d, th = dp.screw_from_dualquat(dq_b)
    screw_err = max(np.abs(n - n_b).max(), np.abs(p - p_b).max(), abs(d - d_b), abs(th - th_b))
    checks.append(("screw parameters of B recovered", float(screw_err), 1e-14))
    xi = dp.twist_from_dualquat(dq_ab)
    checks.append(("twist [w, v] vs scipy as_exp_coords", np.abs(xi - ref_ab.as_exp_coords()).max(), 1e-13))
    checks.append(("exp(log(A (x) B))", np.abs(dp.dualquat_from_twist(xi) - dp.dualquat_canonical(dq_ab)).max(), 1e-14))

    # ScLERP from A to A (x) B: a constant-screw path.
    ts = np.linspace(0.0, 1.0, 5)
    path = dp.dualquat_sclerp(dq_a, dq_ab, ts)
    rel = dp.dualquat_mul(dp.dualquat_conj(dq_a)[None], path)  # A* (x) S(t) = B**t
    axes, points, dists, angles = dp.screw_from_dualquat(rel[1:])
    checks.append(("ScLERP endpoints", max(np.abs(path[0] - dq_a).max(), _same(path[-1], dq_ab)), 1e-14))
    checks.append(
        ("ScLERP keeps one screw axis", float(np.abs(axes - axes[-1]).max() + np.abs(points - points[-1]).max()), 1e-12)
    )
    checks.append(
        (
            "ScLERP angle and advance linear in t",
            float(np.abs(angles - ts[1:] * th_b).max() + np.abs(dists - ts[1:] * d_b).max()),
            1e-13,
        )
    )
    checks.append(
        ("ScLERP(1/2) == A (x) B**(1/2)", _same(path[2], dp.dualquat_mul(dq_a, dp.dualquat_pow(dq_b, 0.5))), 1e-14)
    )

    print("\nScLERP from A to A (x) B")
    print(f"  {'t':>5}  {'angle from A [deg]':>18}  {'advance along axis':>18}  translation")
    for t, dq in zip(ts, path, strict=True):
        _, tr = dp.qt_from_dualquat(dq)
        ang = np.rad2deg(dp.quat_angle(dq_a[:4], dq[:4]))
        print(f"  {t:5.2f}  {ang:18.6f}  {t * d_b:18.6f}  {np.array2string(tr, precision=6)}")

    print("\nchecks")
    width = max(len(c[0]) for c in checks)
    print(f"  {'check':<{width}}  {'max error':>10}  {'tolerance':>9}  result")
    ok = True
    for name, err, tol in checks:
        passed = bool(err <= tol)
        ok &= passed
        print(f"  {name:<{width}}  {err:10.2e}  {tol:9.0e}  {'ok' if passed else 'FAIL'}")
    print("\nall checks passed" if ok else "\nSOME CHECKS FAILED")
    return 0 if ok else 1


def _same(a: np.ndarray, b: np.ndarray) -> float:
    """Max difference of two dual quaternions up to the overall sign (they are the same transform)."""
    return float(min(np.abs(a - b).max(), np.abs(a + b).max()))


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``dualpose demo``."""
    demo = subparsers.add_parser("demo", help="self-checking walk-through of the algebra on built-in data")
    demo.add_argument("--seed", type=seed, default=7, help="seed of the random transforms (default 7; >= 0)")
    return demo


def run(args: argparse.Namespace) -> int:
    """Entry point of ``dualpose demo``."""
    return run_demo(seed=args.seed)
