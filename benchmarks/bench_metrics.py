"""dualpose.evaluation.metrics against evo (the reference implementation of ATE/RPE): agreement and speed.

Run ``.venv/bin/python benchmarks/bench_metrics.py [--markdown PATH]`` (evo is in the ``test`` extra).

For each pair in ``../shared/data/tum`` (fr2_desk ORB-SLAM vs ground truth; EuRoC V1_02 estimate vs ground-truth CSV),
each alignment (none, se3, sim3) and each RPE step (1 frame, 1 m) both libraries run the same pipeline --
association (max_diff 0.01 s), Umeyama alignment, ATE (translation), orientation error (APE rotation angle, deg),
RPE translation (m) and rotation (deg) -- and the table gives dualpose's RMSE and the largest difference to evo over
the statistics rmse, mean, median, std, min, max.  evo is driven through its library API exactly like
``evo_ape``/``evo_rpe`` (``sync.associate_trajectories``, ``PoseTrajectory3D.align``, ``metrics.APE/RPE``).

Speed: the same pipeline on already loaded trajectories (file parsing excluded), best of 5 wall-clock runs in this
process, and the file loading on its own.
"""

from __future__ import annotations

import argparse
import copy
import platform
from pathlib import Path

import numpy as np
from evo.core import metrics as em
from evo.core import sync
from evo.tools import file_interface as fi

from _common import best_of
from dualpose.evaluation.metrics import evaluate
from dualpose.io import read_trajectory

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "tum"
PAIRS = [("fr2_desk_groundtruth.txt", "fr2_desk_ORB.txt"), ("V102_groundtruth.csv", "V102.txt")]
KEYS = ("rmse", "mean", "median", "std", "min", "max")


def evo_read(path: Path):
    return fi.read_euroc_csv_trajectory(str(path)) if path.suffix == ".csv" else fi.read_tum_trajectory_file(str(path))


def evo_pipeline(ref0, est0, align: str, delta: float, unit: str) -> dict[str, dict]:
    ref, est = sync.associate_trajectories(copy.deepcopy(ref0), copy.deepcopy(est0), max_diff=0.01)
    if align != "none":
        est.align(ref, correct_scale=align == "sim3")
    u = em.Unit.frames if unit == "frames" else em.Unit.meters
    out = {}
    for name, metric in (
        ("ATE [m]", em.APE(em.PoseRelation.translation_part)),
        ("orientation [deg]", em.APE(em.PoseRelation.rotation_angle_deg)),
        ("RPE trans [m]", em.RPE(em.PoseRelation.translation_part, delta, u)),
        ("RPE rot [deg]", em.RPE(em.PoseRelation.rotation_angle_deg, delta, u)),
    ):
        metric.process_data((ref, est))
        out[name] = metric.get_all_statistics()
    return out


def ours_pipeline(ref, est, align: str, delta: float, unit: str) -> dict[str, dict]:
    ev = evaluate(ref, est, align=align, max_diff=0.01, rpe_delta=delta, rpe_unit=unit)
    return {
        "ATE [m]": ev.ate_stats.as_dict(),
        "orientation [deg]": ev.orientation_stats.as_dict(),
        "RPE trans [m]": ev.rpe_translation_stats.as_dict(),
        "RPE rot [deg]": ev.rpe_rotation_stats.as_dict(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--markdown", help="also write the tables to this Markdown file")
    args = ap.parse_args()
    lines = [
        "| pair | align | RPE step | metric | dualpose RMSE | evo RMSE | max abs diff (6 stats) |",
        "|---|---|---|---|---:|---:|---:|",
    ]
    speed = ["| pair | step | evo [ms] | dualpose [ms] | evo / dualpose |", "|---|---|---:|---:|---:|"]
    worst = 0.0
    for ref_name, est_name in PAIRS:
        ref_path, est_path = DATA / ref_name, DATA / est_name
        ours_ref, ours_est = read_trajectory(ref_path), read_trajectory(est_path)
        evo_ref, evo_est = evo_read(ref_path), evo_read(est_path)
        for align in ("none", "se3", "sim3"):
            for delta, unit in ((1, "frames"), (1.0, "m")):
                a = ours_pipeline(ours_ref, ours_est, align, delta, unit)
                b = evo_pipeline(evo_ref, evo_est, align, delta, unit)
                for metric in a:
                    if metric.startswith("ATE") or metric.startswith("orientation"):
                        if unit == "m":
                            continue  # absolute errors do not depend on the RPE step
                    diff = max(abs(a[metric][k] - b[metric][k]) for k in KEYS)
                    worst = max(worst, diff)
                    step = f"{delta} {unit}"
                    lines.append(
                        f"| {est_name} vs {ref_name} | {align} | {step} | {metric} | {a[metric]['rmse']:.9f} | "
                        f"{b[metric]['rmse']:.9f} | {diff:.1e} |"
                    )
        t_evo = best_of(lambda: evo_pipeline(evo_ref, evo_est, "se3", 1, "frames"), 5)  # noqa: B023
        t_ours = best_of(lambda: ours_pipeline(ours_ref, ours_est, "se3", 1, "frames"), 5)  # noqa: B023
        speed.append(
            f"| {est_name} vs {ref_name} | associate + se3 + ATE + orientation + RPE(1 frame) | {t_evo * 1e3:.1f} | "
            f"{t_ours * 1e3:.1f} | {t_evo / t_ours:.1f} |"
        )
        l_evo = best_of(lambda: (evo_read(ref_path), evo_read(est_path)), 3)  # noqa: B023
        l_ours = best_of(lambda: (read_trajectory(ref_path), read_trajectory(est_path)), 3)  # noqa: B023
        speed.append(
            f"| {est_name} vs {ref_name} | read both files | {l_evo * 1e3:.1f} | {l_ours * 1e3:.1f} | "
            f"{l_evo / l_ours:.1f} |"
        )
    import evo

    header = (
        f"evo {getattr(evo, '__version__', '?')}, numpy {np.__version__}, Python {platform.python_version()}, "
        f"{platform.machine()}; largest difference over all rows: {worst:.1e}"
    )
    text = "\n".join([header, "", *lines, "", *speed, ""])
    print(text)
    if args.markdown:
        Path(args.markdown).write_text(text)


if __name__ == "__main__":
    main()
