"""Many trajectory evaluations at once: the job behind ``dualpose eval --batch MANIFEST`` (docs/scaling.md, "Many
runs").

The pairs come from a **manifest** (CSV, a header line naming the columns ``reference``, ``estimate``, ``algorithm``,
``dataset``, ``run``, in any order, more columns ignored; ``#`` comment lines and blank lines skipped; relative paths
are relative to the manifest's folder) or from a **results directory in the layout of rpg_trajectory_evaluation**
(Zhang and Scaramuzza 2018, its README "Datasets organization"):

.. code-block:: text

    PLATFORM/ALGORITHM/PLATFORM_ALGORITHM_DATASET/stamped_groundtruth.txt
                                                 stamped_traj_estimate.txt      (one run: run 0)
                                                 stamped_traj_estimate0.txt ... (runs 0, 1, ...)
                                                 eval_cfg.yaml                  (optional: align_type, align_num_frames)

given as the ``PLATFORM`` folder.  There the alignment of each folder is its ``eval_cfg.yaml`` (``align_type``
sim3 / se3 / posyaw / none, ``align_num_frames``, -1 = all), or that toolbox's default without the file: sim3 over
all poses.  Every pair is evaluated with :func:`dualpose.evaluation.metrics.evaluate` (the settings of
``dualpose eval``), one task per pair on :func:`dualpose.jobs.scheduler.run_tasks`.
"""

from __future__ import annotations

import csv
import os
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from dualpose.evaluation.metrics import evaluate
from dualpose.io import detect_format, read_trajectory
from dualpose.jobs.scheduler import file_bytes, run_tasks
from dualpose.jobs.table import Cell, JobResult, ResultsTable, outcome_rows, summarize

if TYPE_CHECKING:
    import distributed

__all__ = [
    "EVAL_COLUMNS", "EVAL_METRICS", "MANIFEST_COLUMNS", "EvalPair", "EvalSettings", "evaluate_pair",
    "read_eval_manifest", "rpg_pairs", "run_eval_batch",
]  # fmt: skip

#: the columns a manifest must name
MANIFEST_COLUMNS: tuple[str, ...] = ("reference", "estimate", "algorithm", "dataset", "run")

#: the metrics of the results table (summarised per dataset and algorithm)
EVAL_METRICS: tuple[str, ...] = (
    "ate_rmse_m", "ate_mean_m", "ate_median_m", "ate_max_m", "orientation_rmse_deg", "rpe_translation_rmse_m",
    "rpe_rotation_rmse_deg",
)  # fmt: skip

#: columns of the results table of :func:`run_eval_batch`
EVAL_COLUMNS: tuple[str, ...] = (
    "row", "dataset", "algorithm", "run", "reference", "estimate", "status", "error", "warnings", "alignment",
    "scale", "matched_poses", "rpe_pairs", *EVAL_METRICS,
)  # fmt: skip

#: rpg_trajectory_evaluation's alignment names -> ``evaluate``'s
_RPG_ALIGN = {"sim3": "sim3", "se3": "se3", "posyaw": "posyaw", "none": "none"}


@dataclass(frozen=True)
class EvalSettings:
    """The options of ``dualpose eval`` (see :func:`dualpose.evaluation.metrics.evaluate` for each)."""

    align: str = "se3"
    n_align: int | None = None
    max_diff: float = 0.01
    offset: float = 0.0
    interpolate: bool = False
    rpe_delta: float = 1.0
    rpe_unit: str = "frames"
    rpe_all_pairs: bool = False
    t_start: float | None = None
    t_end: float | None = None


@dataclass(frozen=True)
class EvalPair:
    """One evaluation: files, labels and settings; ``problem`` is the reason a manifest row cannot be evaluated
    (the row is then reported failed without reading anything)."""

    reference: str
    estimate: str
    algorithm: str
    dataset: str
    run: str
    settings: EvalSettings = EvalSettings()
    problem: str | None = None


def read_eval_manifest(path: str | os.PathLike[str], settings: EvalSettings = EvalSettings()) -> list[EvalPair]:
    """The pairs of a manifest CSV, or of an rpg_trajectory_evaluation directory (:func:`rpg_pairs`).

    A row with an empty field becomes a pair with its ``problem`` (``MANIFEST:LINE: ...``) and is reported failed by
    the job; a file that is not a manifest (no header with the five columns) raises.

    Raises
    ------
    ValueError
        ``MANIFEST:1: ...`` for a missing header column; ``MANIFEST: no rows``.
    OSError
        The manifest cannot be read.
    """
    p = Path(path)
    if p.is_dir():
        return rpg_pairs(p, settings)
    with open(p, encoding="utf-8", newline="") as fh:
        lines = [(k, line) for k, line in enumerate(fh, start=1) if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise ValueError(f"{p}: no header line (expected the columns {', '.join(MANIFEST_COLUMNS)})")
    reader = csv.reader([line for _, line in lines])
    header = [h.strip().lower() for h in next(reader)]
    missing = [c for c in MANIFEST_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{p}:{lines[0][0]}: manifest header lacks the column(s) {', '.join(missing)} "
                         f"(found {', '.join(header) or 'none'}; needed {', '.join(MANIFEST_COLUMNS)})")  # fmt: skip
    col = {c: header.index(c) for c in MANIFEST_COLUMNS}
    pairs = []
    for (lineno, _), fields in zip(lines[1:], reader, strict=True):
        values = {c: fields[i].strip() if i < len(fields) else "" for c, i in col.items()}
        empty = [c for c in MANIFEST_COLUMNS if not values[c]]
        problem = f"{p}:{lineno}: empty field(s) {', '.join(empty)}" if empty else None
        for c in ("reference", "estimate"):
            if values[c] and not os.path.isabs(values[c]) and ":/" not in values[c]:
                values[c] = str(p.parent / values[c])
        pairs.append(EvalPair(settings=settings, problem=problem, **values))
    if not pairs:
        raise ValueError(f"{p}: no rows after the header")
    return pairs


def _rpg_settings(folder: Path, settings: EvalSettings) -> tuple[EvalSettings, str | None]:
    """``settings`` with the alignment of ``folder/eval_cfg.yaml`` (sim3 over all poses without the file)."""
    cfg = folder / "eval_cfg.yaml"
    if not cfg.is_file():
        return replace(settings, align="sim3", n_align=None), None
    import yaml

    try:
        data = yaml.safe_load(cfg.read_text(encoding="utf-8")) or {}
    except (OSError, yaml.YAMLError) as exc:
        return settings, f"{cfg}: {' '.join(str(exc).split())}"
    if not isinstance(data, dict):
        return settings, f"{cfg}: expected a mapping with align_type and align_num_frames"
    align = str(data.get("align_type", "sim3"))
    if align not in _RPG_ALIGN:
        return settings, f"{cfg}: align_type must be one of {', '.join(_RPG_ALIGN)}; got {align!r}"
    n = data.get("align_num_frames", -1)
    if isinstance(n, bool) or not isinstance(n, int) or (n < 3 and n != -1):
        return settings, f"{cfg}: align_num_frames must be -1 (all) or an integer >= 3; got {n!r}"
    n_align = None if n == -1 or align == "none" else n
    return replace(settings, align=_RPG_ALIGN[align], n_align=n_align), None


def rpg_pairs(platform_dir: str | os.PathLike[str], settings: EvalSettings = EvalSettings()) -> list[EvalPair]:
    """The pairs of an rpg_trajectory_evaluation results directory ``PLATFORM/ALGORITHM/PLATFORM_ALGORITHM_DATASET``
    (module docstring), sorted by algorithm, dataset and run.

    Raises
    ------
    ValueError
        No folder of that layout with ``stamped_groundtruth.txt`` under ``platform_dir``.
    """
    root = Path(platform_dir)
    platform = root.resolve().name
    pairs = []
    for alg_dir in sorted(d for d in root.iterdir() if d.is_dir()):
        prefix = f"{platform}_{alg_dir.name}_"
        for folder in sorted(d for d in alg_dir.iterdir() if d.is_dir() and d.name.startswith(prefix)):
            gt = folder / "stamped_groundtruth.txt"
            if not gt.is_file():
                continue
            dataset = folder.name[len(prefix):]
            runs = []
            for f in folder.iterdir():
                m = re.fullmatch(r"stamped_traj_estimate(\d*)\.txt", f.name)
                if m:
                    runs.append((int(m.group(1)) if m.group(1) else 0, f))
            folder_settings, problem = _rpg_settings(folder, settings)
            for run, est in sorted(runs):
                pairs.append(EvalPair(str(gt), str(est), alg_dir.name, dataset, str(run), folder_settings, problem))
    if not pairs:
        raise ValueError(f"{root}: no rpg_trajectory_evaluation result folders (ALGORITHM/{platform}_ALGORITHM_DATASET "
                         "with stamped_groundtruth.txt and stamped_traj_estimate[N].txt)")  # fmt: skip
    return pairs


def evaluate_pair(pair: EvalPair) -> dict[str, Cell]:
    """The metrics of one pair (the task of :func:`run_eval_batch`; pure: reads the two files, writes nothing).

    Returns the metric columns of :data:`EVAL_COLUMNS` (``alignment`` … ``rpe_rotation_rmse_deg``) and
    ``warnings`` (the warnings the reading and evaluation raised, ``"; "``-joined).

    Raises
    ------
    ValueError, OSError
        ``pair.problem``, or a file that cannot be read or evaluated (the message names file and line).
    """
    if pair.problem is not None:
        raise ValueError(pair.problem)
    s = pair.settings
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ref = read_trajectory(pair.reference, detect_format(pair.reference))
        est = read_trajectory(pair.estimate, detect_format(pair.estimate))
        ev = evaluate(
            ref, est, align=s.align, align_first_n=s.n_align, max_diff=s.max_diff, offset=s.offset,  # type: ignore[arg-type]
            sync="interpolate" if s.interpolate else "nearest", rpe_delta=s.rpe_delta, rpe_unit=s.rpe_unit,  # type: ignore[arg-type]
            rpe_all_pairs=s.rpe_all_pairs, t_start=s.t_start, t_end=s.t_end,
        )  # fmt: skip
    ate, rpe_t = ev.ate_stats, ev.rpe_translation_stats
    return {
        "warnings": "; ".join(dict.fromkeys(" ".join(str(w.message).split()) for w in caught)),
        "alignment": ev.alignment.method,
        "scale": float(ev.alignment.scale),
        "matched_poses": int(ev.idx_ref.shape[0]),
        "rpe_pairs": int(ev.rpe_pairs.shape[0]),
        "ate_rmse_m": ate.rmse,
        "ate_mean_m": ate.mean,
        "ate_median_m": ate.median,
        "ate_max_m": ate.max,
        "orientation_rmse_deg": ev.orientation_stats.rmse,
        "rpe_translation_rmse_m": rpe_t.rmse,
        "rpe_rotation_rmse_deg": ev.rpe_rotation_stats.rmse,
    }


def _pair_cost(pair: EvalPair) -> float:
    """The bytes of the pair's two files (0 for a row that fails without reading): what the evaluation grows with."""
    return 0.0 if pair.problem is not None else file_bytes(pair.reference, pair.estimate)


def run_eval_batch(
    pairs: list[EvalPair],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    client: distributed.Client | None = None,
) -> JobResult:
    """Evaluate every pair on a scheduler (:func:`dualpose.jobs.scheduler.run_tasks`).

    Parameters
    ----------
    pairs : list of EvalPair
        From :func:`read_eval_manifest` or :func:`rpg_pairs`.
    scheduler, workers, progress, client
        As :func:`dualpose.jobs.scheduler.run_tasks`.  On a cluster the pairs are grouped into the dask tasks by the
        size of their files (``run_tasks``'s ``cost``), so that the tasks take about as long as each other.

    Returns
    -------
    JobResult
        A row per pair with ``status`` "ok" or "failed" and, when failed, the reason in ``error`` (metrics NaN).
        The same pairs give the same table, bit for bit, on any scheduler.
    """
    outcomes = run_tasks(evaluate_pair, pairs, scheduler=scheduler, workers=workers, progress=progress,
                         client=client, cost=_pair_cost)
    base: list[dict[str, Cell]] = [{"row": k, "dataset": p.dataset, "algorithm": p.algorithm, "run": p.run,
                                     "reference": p.reference, "estimate": p.estimate} for k, p in enumerate(pairs)]
    rows = outcome_rows(EVAL_COLUMNS, base, outcomes, {"warnings": "", "alignment": "", "matched_poses": 0,
                                                        "rpe_pairs": 0})  # fmt: skip
    table = ResultsTable(EVAL_COLUMNS, rows)
    summary = summarize(table, ("dataset", "algorithm"), EVAL_METRICS, lambda r: r["status"] == "ok")
    return JobResult(table, summary, sum(r["status"] != "ok" for r in rows))
