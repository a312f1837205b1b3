"""``dualpose register``: rigid pose from corresponding points (and directions) in CSV files.

Input files: comma-separated, one correspondence per line, optional header line; points and directions have
three columns ``x, y, z``, weights one column.  Row i of MODEL.csv corresponds to row i of MEASURED.csv.  The pose
maps model coordinates to measured coordinates: ``measured ≈ R model + t``.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING, Any

from dualpose.cli._args import float_in, seed

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

_EPILOG = """\
CSV format: comma-separated numbers, one correspondence per line; an optional header line; blank lines and
lines starting with '#' are skipped.  Points/directions: 3 columns x,y,z.  Weights: 1 column.
Output: the rotation as a quaternion [x, y, z, w] (scalar last) and as a 4x4 homogeneous matrix, the
translation, and diagnostics (cost, RMS residual, degeneracy).  Exit status 0 on success, 2 on bad input.
"""


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Register ``dualpose register``."""
    p = subparsers.add_parser(
        "register",
        help="pose from point/direction correspondences in CSV files",
        description="Estimate the rigid transform measured ≈ R model + t from corresponding points (Walker 1991).",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", metavar="MODEL.csv", help="model points x,y,z (model frame)")
    p.add_argument("measured", metavar="MEASURED.csv", help="measured points x,y,z, same order as MODEL.csv")
    p.add_argument(
        "--directions", nargs=2, metavar=("MODEL_DIRS.csv", "MEASURED_DIRS.csv"),
        help="corresponding unit directions (e.g. surface normals), x,y,z",
    )  # fmt: skip
    p.add_argument("--weights", metavar="W.csv", help="one weight per point (default 1)")
    p.add_argument("--direction-weights", metavar="W.csv", help="one weight per direction (default 1)")
    p.add_argument("--method", choices=("dq", "horn", "svd"), default="dq", help="solver (default dq, Walker 1991)")
    p.add_argument("--scale", action="store_true", help="also estimate a scale (Umeyama similarity; points only)")
    p.add_argument("--ransac", action="store_true", help="robust fit: RANSAC on point triples, refit on inliers")
    p.add_argument("--threshold", type=float_in(0.0, 1e12, lo_open=True),
                   help="RANSAC inlier distance, > 0 (required with --ransac; refused without it)")
    p.add_argument("--confidence", type=float_in(0.0, 1.0, lo_open=True), default=0.999,
                   help="RANSAC confidence in (0, 1] (default 0.999; refused without --ransac)")
    p.add_argument("--seed", type=seed, default=0, help="RANSAC random seed, >= 0 (default 0)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    return p


def _fail(msg: str) -> int:
    print(f"dualpose register: error: {msg}", file=sys.stderr)
    return 2


def _read_pair(path_a: str, path_b: str, what: str, noun: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two files of corresponding 3-vectors; ValueError when their lengths differ."""
    from dualpose.io.csv_points import read_columns

    a = read_columns(path_a, 3, f"{what} (x, y, z)")
    b = read_columns(path_b, 3, f"{what} (x, y, z)")
    if len(a) != len(b):
        raise ValueError(f"{path_a} has {len(a)} {noun} but {path_b} has {len(b)}")
    return a, b


def _read_weights(path: str, n: int, noun: str) -> object:
    """One weight per line for ``n`` correspondences; ValueError otherwise."""
    from dualpose.io.csv_points import read_columns

    w = read_columns(path, 1, "weights")
    if len(w) != n:
        raise ValueError(f"{path} has {len(w)} weight(s) for {n} {noun}")
    return w


def run(args: argparse.Namespace) -> int:
    """Entry point of ``dualpose register``."""
    import numpy as np

    from dualpose.registration import register_pose, register_pose_ransac

    if not args.ransac and args.threshold is not None:
        return _fail("--threshold is the RANSAC inlier distance: it needs --ransac")
    try:
        model, measured = _read_pair(args.model, args.measured, "points", "point(s)")
        kw: dict[str, Any] = {"method": args.method}
        if args.weights:
            kw["point_weights"] = _read_weights(args.weights, len(model), "point(s)")
        if args.directions:
            path_d0, path_d1 = args.directions
            d0, d1 = _read_pair(path_d0, path_d1, "directions", "direction(s)")
            kw.update(model_directions=d0, measured_directions=d1)
            if args.direction_weights:
                kw["direction_weights"] = _read_weights(args.direction_weights, len(d0), "direction(s)")
        elif args.direction_weights:
            return _fail("--direction-weights needs --directions")
        inliers = None
        if args.ransac:
            if args.threshold is None:
                return _fail("--ransac needs --threshold (the inlier distance)")
            if args.directions or args.scale:
                return _fail("--ransac supports points only (no --directions, no --scale)")
            rob = register_pose_ransac(
                model, measured, threshold=args.threshold, confidence=args.confidence, seed=args.seed,
                point_weights=kw.get("point_weights"), method=args.method,
            )  # fmt: skip
            est, inliers = rob.pose, rob.inlier_mask
        else:
            est = register_pose(model, measured, scale=args.scale, **kw)
    except ValueError as exc:  # CsvFormatError too
        return _fail(str(exc))

    out = {
        "method": est.method,
        "quat_xyzw": est.quat.tolist(),
        "translation": est.translation.tolist(),
        "scale": est.scale,
        "matrix": est.as_matrix().tolist(),
        "cost": est.cost,
        "rmsd": est.rmsd,
        "n_points": est.n_points,
        "n_directions": est.n_directions,
        "degeneracy": est.degeneracy,
        "rotation_unique": est.rotation_unique,
        "translation_observable": est.translation_observable,
        "eigen_gap": est.eigen_gap,
    }
    if inliers is not None:
        out["inliers"] = np.flatnonzero(inliers).tolist()
        out["n_inliers"] = int(inliers.sum())
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    with np.printoptions(precision=9, suppress=True, floatmode="maxprec"):
        print(f"pose measured ≈ {'s R' if args.scale else 'R'} model + t   (method {est.method})")
        print(f"  quaternion [x, y, z, w]  {np.array2string(est.quat, separator=', ')}")
        print(f"  translation              {np.array2string(est.translation, separator=', ')}")
        if args.scale:
            print(f"  scale                    {est.scale:.12g}")
        print("  4x4 matrix")
        for row in est.as_matrix():
            print("    " + np.array2string(row, separator=", "))
    print("diagnostics")
    print(f"  correspondences          {est.n_points} point(s), {est.n_directions} direction(s)")
    if inliers is not None:
        print(f"  RANSAC inliers           {int(inliers.sum())} of {len(inliers)}")
    print(f"  cost E                   {est.cost:.6g}")
    print(f"  RMS residual             {est.rmsd:.6g}")
    print(f"  degeneracy               {est.degeneracy}" + ("" if est.rotation_unique else " (rotation not unique)"))
    if not est.translation_observable:
        print("  translation              unobservable (directions only)")
    print(f"  eigen gap                {est.eigen_gap:.6g}")
    return 0
