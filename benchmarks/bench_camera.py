"""Distorted cameras: dualpose's projection and undistortion against OpenCV's, 1e3 and 1e5 points in one process.

Run ``.venv/bin/python benchmarks/bench_camera.py [--points 1e3 1e5] [--markdown FILE]``.

Cameras: EuRoC MAV cam0 (radtan, 752 x 480) and a TUM-VI-like fisheye (equi, 512 x 512).  Points: pixels drawn
uniformly over the image (seeded), their rays at depths 0.5-4 m (fisheye: rays within 85° of the axis, what OpenCV's
fisheye model handles).  Contenders, each best of 15 interleaved rounds:

* project: ``camera.project`` vs ``cv2.projectPoints`` / ``cv2.fisheye.projectPoints`` (rvec = tvec = 0);
* project + Jacobian: ``camera.project_jacobian`` (d pixel / d point) vs ``cv2.projectPoints`` with its Jacobian
  output (d pixel / d (rvec, tvec, f, c, distortion): a different, larger Jacobian; the nearest OpenCV offers);
* undistort: ``camera.unproject`` (Newton to 1e-12) vs ``cv2.undistortPointsIter`` (criteria 20 iterations or
  1e-14) / ``cv2.fisheye.undistortPoints`` (its default criteria).

"ratio" is OpenCV's time over dualpose's (> 1: dualpose faster).  A second table gives the largest differences from
OpenCV on the same points: pixels of the projections, and the angle (radians, atan2 of |cross| and dot) between
dualpose's and OpenCV's undistorted rays; and dualpose's own round trip ``|project(bearing(p)) - p|`` (pixels).
"""

from __future__ import annotations

import argparse
import platform
import sys

import cv2
import numpy as np

from _common import best_of_interleaved, emit
from dualpose.types import EquidistantCamera, RadTanCamera

EUROC = RadTanCamera(458.654, 457.296, 367.215, 248.375, -0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 752, 480)
TUMVI = EquidistantCamera(
    190.97847715128717, 190.9733070521226, 254.93170605935475, 256.8974428996504,
    0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202, 0.00020293673591811182, 512, 512,
)  # fmt: skip


def _inputs(cam, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(pixels (n, 2), camera-frame points (n, 3)) over the image."""
    pixels = np.empty((0, 2))
    points = np.empty((0, 3))
    while len(pixels) < n:
        px = rng.uniform([0, 0], [cam.width - 1, cam.height - 1], (2 * n, 2))
        rays = cam.bearing(px)
        keep = rays[:, 2] > np.cos(np.radians(85))
        pixels = np.concatenate([pixels, px[keep]])
        points = np.concatenate([points, rays[keep] / rays[keep, 2:3] * rng.uniform(0.5, 4.0, (keep.sum(), 1))])
    return pixels[:n], points[:n]


def _contenders(cam, pixels: np.ndarray, points: np.ndarray) -> dict[str, tuple]:
    k = np.array(cam.distortion)
    zero = np.zeros(3)
    kk = cam.matrix
    px3 = np.ascontiguousarray(pixels[:, None])
    pts3 = np.ascontiguousarray(points[:, None])
    if cam.model == "radtan":
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 1e-14)
        return {
            "project": (lambda: cam.project(points), lambda: cv2.projectPoints(points, zero, zero, kk, k)),
            "project + Jacobian": (
                lambda: cam.project_jacobian(points),
                lambda: cv2.projectPoints(points, zero, zero, kk, k),  # returns (pixels, jacobian)
            ),
            "undistort": (
                lambda: cam.unproject(pixels),
                lambda: cv2.undistortPointsIter(px3, kk, k, None, None, crit),
            ),
        }
    return {
        "project": (lambda: cam.project(points), lambda: cv2.fisheye.projectPoints(pts3, zero, zero, kk, k)),
        "project + Jacobian": (
            lambda: cam.project_jacobian(points),
            lambda: cv2.fisheye.projectPoints(pts3, zero, zero, kk, k),  # returns (pixels, jacobian)
        ),
        "undistort": (lambda: cam.unproject(pixels), lambda: cv2.fisheye.undistortPoints(px3, kk, k)),
    }


def _accuracy(cam, pixels: np.ndarray, points: np.ndarray) -> tuple[float, float, float]:
    """Largest pixel difference of the projections, ray angle of the undistortions (both vs OpenCV), round trip."""
    contenders = _contenders(cam, pixels, points)
    theirs_px = contenders["project"][1]()[0][:, 0]
    theirs_xy = contenders["undistort"][1]()[:, 0]
    ours_xy = cam.unproject(pixels)
    a = np.c_[ours_xy, np.ones(len(ours_xy))]
    b = np.c_[theirs_xy, np.ones(len(theirs_xy))]
    angle = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))
    trip = np.abs(cam.project(cam.bearing(pixels)) - pixels).max()
    return float(np.abs(cam.project(points) - theirs_px).max()), float(angle.max()), float(trip)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=float, nargs="+", default=[1e3, 1e5])
    ap.add_argument("--markdown", help="also write the table to this file (never overwritten)")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(20261203)
    cv2.setNumThreads(1)
    rows = []
    accuracy = []
    for cam in (EUROC, TUMVI):
        pixels, points = _inputs(cam, int(max(args.points)), rng)
        accuracy.append((cam.model, len(pixels), *_accuracy(cam, pixels, points)))
        for n in (int(v) for v in args.points):
            pixels, points = _inputs(cam, n, rng)
            for op, (ours, theirs) in _contenders(cam, pixels, points).items():
                t = best_of_interleaved({"dualpose": ours, "opencv": theirs}, k=15)
                rows.append((cam.model, n, op, t["dualpose"], t["opencv"]))
    lines = [
        f"Python {platform.python_version()}, NumPy {np.__version__}, OpenCV {cv2.__version__}, "
        f"{platform.machine()}, 1 thread; best of 15 interleaved rounds.",
        "",
        "| model | points | operation | dualpose (µs) | OpenCV (µs) | ratio OpenCV/dualpose |",
        "|---|---:|---|---:|---:|---:|",
    ]
    for model, n, op, ours, theirs in rows:
        lines.append(f"| {model} | {n:.0e} | {op} | {ours * 1e6:.1f} | {theirs * 1e6:.1f} | {theirs / ours:.2f} |")
    lines += [
        "",
        "| model | points | max \\|Δ pixel\\| vs OpenCV | max ray angle vs OpenCV (rad) | max round trip (px) |",
        "|---|---:|---:|---:|---:|",
    ]
    for model, n, dpx, dang, trip in accuracy:
        lines.append(f"| {model} | {n:.0e} | {dpx:.1e} | {dang:.1e} | {trip:.1e} |")
    return emit("\n".join(lines), args.markdown)


if __name__ == "__main__":
    sys.exit(main())
