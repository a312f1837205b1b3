"""Print the coning-drift tables of docs/inertial.md: ``python tests/inertial/make_drift_table.py``.

Simulated drift (error screw vector at the end / elapsed time) of each algorithm on classical and dual coning
against the analytic leading terms; then the O(a⁴) term that limits the N >= 3 coning-optimal algorithms.
"""

from __future__ import annotations

import dualpose as dp
import dualpose.inertial as di
from dualpose.inertial import motions as m


def drift(n: int, family: str, a: float, omega: float, omega_t: float, k: int, frame: str, d: float = 1.0):
    T = omega_t / omega
    c = m.Coning(a, omega, d)
    inc = c.dual_increments(0.0, T / n, k * n, frame)
    est = di.integrate_pose(c.pose(0.0), inc, n, family, frame)[-1]
    true = c.pose(T * k)
    err = (
        dp.dualquat_mul(dp.dualquat_conj(true), est)
        if frame == "body"
        else dp.dualquat_mul(est, dp.dualquat_conj(true))
    )
    return dp.twist_from_dualquat(err) / (T * k)


def main() -> None:
    print(
        "| algorithm | a [rad] | ΩT | frame | drift [rad/s] | predicted | ratio "
        "| dual drift [m/s] | predicted 2ad·ρΩ(ΩT)^2N | ratio |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    cases = [
        (1, "coning-optimal", 0.01, 0.1, 1 / 12, 2),
        (2, "coning-optimal", 0.01, 0.3, 1 / 960, 4),
        (3, "coning-optimal", 0.01, 1.0, 1 / 204120, 6),
        (4, "coning-optimal", 5e-4, 1.0, 1 / 82575360, 8),
        (3, "polynomial", 0.01, 0.3, 1 / 6480, 4),
        (4, "polynomial", 0.001, 1.0, 1 / 387072, 6),
        (1, "one-plus-previous", 0.01, 0.3, 1 / 60, 4),
    ]
    for n, fam, a, wt, rho, p in cases:
        for frame in ("body", "space"):
            e = drift(n, fam, a, 1.0, wt, 2000 if fam != "one-plus-previous" else 5000, frame)
            pred = rho * a * a * wt**p
            print(
                f"| {n}-sample {fam} | {a:g} | {wt:g} | {frame} | {abs(e[0]):.3e} | {pred:.3e} "
                f"| {abs(e[0]) / pred:.3f} "
                f"| {abs(e[3]):.3e} | {2 * pred / a:.3e} | {abs(e[3]) / (2 * pred / a):.3f} |"
            )
    print()
    print("| N | a [rad] | ΩT | drift [rad/s] | ρ_N a² Ω (ΩT)^2N | drift / (a⁴ Ω (ΩT)⁴) |")
    print("|---|---|---|---|---|---|")
    for n in (3, 4):
        for a, wt in [(0.2, 0.1), (0.1, 0.1), (0.05, 0.1), (0.2, 0.2)]:
            e = drift(n, "coning-optimal", a, 1.0, wt, 20000, "body")[0]
            print(
                f"| {n} | {a:g} | {wt:g} | {e:.3e} | {m.coning_drift(a, 1.0, wt, n):.3e} | {e / (a**4 * wt**4):.2e} |"
            )


if __name__ == "__main__":
    main()
