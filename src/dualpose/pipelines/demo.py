"""The algebra walk-through behind ``dualpose demo``: two rigid transforms checked against independent references.

It builds two rigid transforms (one from a rotation and a translation, one from Walker's screw parameters, Walker
1991 eqs. (11)-(12)), composes them, transforms points, interpolates with ScLERP (Dantam 2014 §5) and checks every
step against 4x4 homogeneous matrices and scipy's ``RigidTransform`` (an independent implementation).
Dual quaternions are ``[real xyzw, dual xyzw]`` with ``dual = ½ t ⊗ real``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import RigidTransform

import dualpose as dp

__all__ = ["DemoCheck", "DemoResult", "algebra_walkthrough"]


@dataclass(frozen=True)
class DemoCheck:
    """One check: ``name``, the maximum ``error`` found and the ``tolerance`` it must not exceed."""

    name: str
    error: float
    tolerance: float

    @property
    def passed(self) -> bool:
        return bool(self.error <= self.tolerance)


@dataclass(frozen=True)
class DemoResult:
    """``transforms``: label -> dual quaternion (8,); ``sclerp``: rows ``(t, angle from A [deg], advance along the
    axis, translation (3,))`` of the path from A to A ⊗ B; ``checks``: the :class:`DemoCheck` list."""

    transforms: dict[str, np.ndarray]
    sclerp: list[tuple[float, float, float, np.ndarray]]
    checks: list[DemoCheck]

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)


def _same(a: np.ndarray, b: np.ndarray) -> float:
    """Max difference of two dual quaternions up to the overall sign (they are the same transform)."""
    return float(min(np.abs(a - b).max(), np.abs(a + b).max()))


def algebra_walkthrough(seed: int = 7) -> DemoResult:
    """Run the walk-through with transforms drawn from ``seed`` (module docstring)."""
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
    transforms = {
        "A (rotation + translation)": dq_a,
        "B (screw: n=z, p=(1,0,0), d=0.3, 120 deg)": dq_b,
        "A (x) B": dq_ab,
    }

    checks = [DemoCheck("compose: M(A (x) B) vs M_A @ M_B", np.abs(dp.matrix_from_dualquat(dq_ab) - m_a @ m_b).max(),
                        1e-14)]  # fmt: skip
    checks.append(
        DemoCheck("transform points vs 4x4 matrix", np.abs(dp.dualquat_transform(dq_ab, pts) - hom[:, :3]).max(), 1e-14)
    )
    ref_ab = RigidTransform.from_matrix(m_a) * RigidTransform.from_matrix(m_b)
    checks.append(
        DemoCheck("A (x) B vs scipy RigidTransform", np.abs(dp.matrix_from_dualquat(dq_ab) - ref_ab.as_matrix()).max(),
                  1e-14)  # fmt: skip
    )
    n, p, d, th = dp.screw_from_dualquat(dq_b)
    screw_err = max(np.abs(n - n_b).max(), np.abs(p - p_b).max(), abs(d - d_b), abs(th - th_b))
    checks.append(DemoCheck("screw parameters of B recovered", float(screw_err), 1e-14))
    xi = dp.twist_from_dualquat(dq_ab)
    checks.append(DemoCheck("twist [w, v] vs scipy as_exp_coords", np.abs(xi - ref_ab.as_exp_coords()).max(), 1e-13))
    checks.append(
        DemoCheck("exp(log(A (x) B))", np.abs(dp.dualquat_from_twist(xi) - dp.dualquat_canonical(dq_ab)).max(), 1e-14)
    )

    # ScLERP from A to A (x) B: a constant-screw path.
    ts = np.linspace(0.0, 1.0, 5)
    path = dp.dualquat_sclerp(dq_a, dq_ab, ts)
    rel = dp.dualquat_mul(dp.dualquat_conj(dq_a)[None], path)  # A* (x) S(t) = B**t
    axes, points, dists, angles = dp.screw_from_dualquat(rel[1:])
    checks.append(DemoCheck("ScLERP endpoints", max(np.abs(path[0] - dq_a).max(), _same(path[-1], dq_ab)), 1e-14))
    axis_spread = float(np.abs(axes - axes[-1]).max() + np.abs(points - points[-1]).max())
    checks.append(DemoCheck("ScLERP keeps one screw axis", axis_spread, 1e-12))
    checks.append(
        DemoCheck(
            "ScLERP angle and advance linear in t",
            float(np.abs(angles - ts[1:] * th_b).max() + np.abs(dists - ts[1:] * d_b).max()),
            1e-13,
        )
    )
    checks.append(
        DemoCheck("ScLERP(1/2) == A (x) B**(1/2)", _same(path[2], dp.dualquat_mul(dq_a, dp.dualquat_pow(dq_b, 0.5))),
                  1e-14)  # fmt: skip
    )
    rows = []
    for t, dq in zip(ts, path, strict=True):
        _, tr = dp.qt_from_dualquat(dq)
        rows.append((float(t), float(np.rad2deg(dp.quat_angle(dq_a[:4], dq[:4]))), float(t * d_b), tr))
    return DemoResult(transforms, rows, checks)
