"""Trajectory files for the many-run job tests (``tests/jobs``): seeded references and noisy estimates written as a
manifest folder and as an rpg_trajectory_evaluation results folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import dualpose as dp
from dualpose.io import write_tum
from dualpose.types import Trajectory

#: datasets and algorithms of the generated evaluation files; estimate noise (m) per algorithm
DATASETS = ("MH_01", "V1_02")
ALGORITHMS = {"vio_mono": 0.05, "vio_stereo": 0.01}
RUNS = 3


def _reference(k: int) -> Trajectory:
    """A smooth 3-D path with turning attitude, 200 poses at 20 Hz (k varies the shape)."""
    t = 1000.0 + np.arange(200) / 20.0
    pos = np.stack([np.sin(0.3 * t) * (2 + k), np.cos(0.2 * t), 0.1 * t - 100.0], axis=1)
    rv = np.stack([0.2 * np.sin(0.5 * t), 0.1 * np.cos(0.7 * t), 0.4 * t], axis=1)
    return Trajectory(t, pos, dp.quat_from_rotvec(rv), name="reference")


def _estimate(ref: Trajectory, sigma: float, seed: int) -> Trajectory:
    rng = np.random.default_rng(seed)
    pos = ref.positions + rng.normal(scale=sigma, size=ref.positions.shape)
    q = dp.quat_mul(ref.quats, dp.quat_from_rotvec(rng.normal(scale=sigma, size=(len(ref), 3))))
    return Trajectory(ref.stamps, pos, q, name="estimate")


def write_eval_manifest(tmp_path: Path) -> Path:
    """``manifest.csv`` of 2 datasets x 2 algorithms x 3 runs (relative paths) and one row whose estimate is
    missing (``ghost``); the files are in ``tmp_path``."""
    lines = ["# generated for the tests", "dataset,algorithm,run,reference,estimate"]
    for d, dataset in enumerate(DATASETS):
        ref = _reference(d)
        write_tum(tmp_path / f"{dataset}_gt.txt", ref)
        for a, (alg, sigma) in enumerate(ALGORITHMS.items()):
            for run in range(RUNS):
                name = f"{dataset}_{alg}_{run}.txt"
                write_tum(tmp_path / name, _estimate(ref, sigma, 100 * d + 10 * a + run))
                lines.append(f"{dataset},{alg},{run},{dataset}_gt.txt,{name}")
    lines.append(f"{DATASETS[0]},ghost,0,{DATASETS[0]}_gt.txt,missing_estimate.txt")
    path = tmp_path / "manifest.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def write_rpg_results(tmp_path: Path) -> Path:
    """An rpg_trajectory_evaluation folder ``laptop/ALG/laptop_ALG_DATASET``: vio_mono with 3 numbered runs and
    ``eval_cfg.yaml`` (se3, all frames), vio_stereo with one unnumbered estimate and no config (sim3)."""
    root = tmp_path / "laptop"
    for d, dataset in enumerate(DATASETS):
        ref = _reference(d)
        for alg, sigma in ALGORITHMS.items():
            folder = root / alg / f"laptop_{alg}_{dataset}"
            folder.mkdir(parents=True)
            write_tum(folder / "stamped_groundtruth.txt", ref)
            if alg == "vio_mono":
                (folder / "eval_cfg.yaml").write_text("align_type: se3\nalign_num_frames: -1\n", encoding="utf-8")
                for run in range(RUNS):
                    write_tum(folder / f"stamped_traj_estimate{run}.txt", _estimate(ref, sigma, 10 * d + run))
            else:
                write_tum(folder / "stamped_traj_estimate.txt", _estimate(ref, sigma, 10 * d + 7))
    return root
