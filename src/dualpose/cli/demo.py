"""``dualpose demo``: a short self-checking walk-through of the quaternion algebra."""

from __future__ import annotations

import numpy as np

import dualpose as dp


def run_demo(seed: int = 7) -> int:
    """Build rotations, compose, interpolate, compare with matrices; print a table; return 0 if all checks pass."""
    rng = np.random.default_rng(seed)
    rv = rng.normal(size=(2, 3))
    q = dp.quat_from_rotvec(rv)
    checks: list[tuple[str, float, float]] = []

    composed = dp.quat_mul(q[0], q[1])
    r_comp = dp.matrix_from_quat(q[0]) @ dp.matrix_from_quat(q[1])
    comp_err = np.abs(dp.matrix_from_quat(composed) - r_comp).max()
    checks.append(("compose: R(q0 q1) vs R0 R1", float(comp_err), 1e-14))
    v = rng.normal(size=3)
    rot_err = np.abs(dp.quat_rotate(q[0], v) - dp.matrix_from_quat(q[0]) @ v).max()
    checks.append(("rotate: q v q* vs R v", float(rot_err), 1e-14))
    mid = dp.quat_slerp(q[0], q[1], 0.5)
    a0, a1 = dp.quat_angle(q[0], mid), dp.quat_angle(mid, q[1])
    checks.append(("slerp midpoint equidistant", abs(float(a0 - a1)), 1e-14))
    back = dp.rotvec_from_quat(dp.quat_from_rotvec(rv))
    checks.append(("rotvec -> quat -> rotvec", float(np.abs(back - rv).max()), 1e-14))

    width = max(len(c[0]) for c in checks)
    print(f"{'check':<{width}}  {'max error':>10}  {'tolerance':>9}  result")
    ok = True
    for name, err, tol in checks:
        passed = err <= tol
        ok &= passed
        print(f"{name:<{width}}  {err:10.2e}  {tol:9.0e}  {'ok' if passed else 'FAIL'}")
    print("all checks passed" if ok else "SOME CHECKS FAILED")
    return 0 if ok else 1
