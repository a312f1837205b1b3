"""Accuracy at large offsets: Walker's DQ estimator uncentred vs ``register_pose`` (centred), noise-free data.

Run: ``.venv/bin/python benchmarks/walker_centring.py``.  Prints the Markdown table of docs/registration.md §1:
spread of the 10 points, offset from the origin, rotation error (rad) and max translation error of a direct numpy
transcription of Walker 1991 eqs. (35)-(47) (uncentred, point weights x4) and of ``register_pose``.
"""

from __future__ import annotations

import numpy as np

import dualpose as dp
from dualpose.registration import register_pose


def _pure(v: np.ndarray, s: float) -> np.ndarray:
    return np.c_[s * v, np.zeros(len(v))]


def walker_uncentred(p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Walker §3.2 as printed (points only, weights 4 so that the documented cost is minimised)."""
    big_p0, big_p1 = _pure(p0, 0.5), _pure(p1, 0.5)
    q_mat, w_mat = dp.quat_left_matrix, dp.quat_right_matrix
    bw = 4.0 * np.ones(len(p0))
    c1 = -2 * np.einsum("k,kji,kjl->il", bw, q_mat(big_p1), w_mat(big_p0))
    c2 = bw.sum() * np.eye(4)
    c3 = 2 * np.einsum("k,kij->ij", bw, w_mat(big_p0) - q_mat(big_p1))
    a = 0.5 * (c3.T @ np.linalg.inv(c2 + c2.T) @ c3 - c1 - c1.T)
    r = np.linalg.eigh(a)[1][:, -1]
    s = -np.linalg.inv(c2 + c2.T) @ c3 @ r
    return dp.quat_canonical(r), 2 * (w_mat(r).T @ s)[:3]


def main() -> None:
    rng = np.random.default_rng(0)
    t = np.array([7.0, 8.0, 13.0])
    print("| spread | offset | uncentred Walker: rotation | uncentred: translation | register_pose: rotation | "
          "register_pose: translation |")  # fmt: skip
    print("|---:|---:|---:|---:|---:|---:|")
    for spread in (1, 10, 100, 322):
        for off in (1e5, 1e6):
            q = dp.quat_canonical(dp.quat_normalize(rng.normal(size=4)))
            p0 = rng.normal(size=(10, 3)) * spread + off * np.array([1, 0.7, -0.4])
            p1 = dp.quat_rotate(q, p0) + t
            rw, tw = walker_uncentred(p0, p1)
            e = register_pose(p0, p1)
            print(
                f"| {spread} | {off:.0e} | {dp.quat_angle(rw, q):.1e} | {np.abs(tw - t).max():.1e} | "
                f"{dp.quat_angle(e.quat, q):.1e} | {np.abs(e.translation - t).max():.1e} |"
            )


if __name__ == "__main__":
    main()
