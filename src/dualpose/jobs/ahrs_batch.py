"""The orientation filter over many recordings: the job behind ``dualpose ahrs --batch SOURCE...`` (docs/scaling.md,
"Many runs").

A SOURCE is

* a BROAD trial (``.mat``, :func:`dualpose.io.load_broad`; scored with BROAD's metric against its optical reference,
  :func:`dualpose.pipelines.ahrs_offline.broad_scores`) or an EuRoC IMU CSV (``imu0/data.csv``,
  :func:`dualpose.io.euroc.read_euroc_imu`; 6D only, no reference: the metrics are NaN; the first second is taken
  as the rest period, as for a bag);
* a directory: its ``*.mat`` files and the EuRoC IMU CSVs in it or below it (``**/imu0/data.csv``, ``*.csv``
  holding EuRoC IMU samples), sorted by path;
* a glob pattern (``data/broad/*_A.mat``);
* a manifest CSV whose header names a ``recording`` column (relative paths from the manifest's folder) and
  optionally ``dataset``.

Each recording is one task (:func:`dualpose.jobs.scheduler.run_tasks`) running
:func:`dualpose.estimation.ahrs.estimate_orientation` as ``dualpose ahrs FILE`` does (``offline=True``: the RTS
smoother of ``dualpose ahrs FILE --offline``).  The ``dataset`` of a recording is the manifest's, else the name of
its folder (for ``imu0/data.csv``, of the EuRoC sequence folder above ``mav0``).
"""

from __future__ import annotations

import csv
import glob
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from dualpose.estimation.ahrs import estimate_orientation
from dualpose.io import detect_format, load_broad
from dualpose.io.broad import BroadTrial
from dualpose.io.euroc import read_euroc_imu
from dualpose.jobs.scheduler import file_bytes, run_tasks
from dualpose.jobs.table import Cell, JobResult, ResultsTable, outcome_rows, summarize
from dualpose.pipelines.ahrs_offline import broad_scores, smooth_broad_trial

if TYPE_CHECKING:
    import distributed

__all__ = ["AHRS_COLUMNS", "AHRS_METRICS", "AhrsRecording", "ahrs_recordings", "ahrs_task",
           "run_ahrs_batch"]  # fmt: skip

#: the scored metrics (BROAD's, degrees over the movement samples)
AHRS_METRICS: tuple[str, ...] = ("total_rmse_deg", "heading_rmse_deg", "inclination_rmse_deg")

#: columns of the results table of :func:`run_ahrs_batch`
AHRS_COLUMNS: tuple[str, ...] = (
    "row", "dataset", "recording", "mode", "status", "error", "samples", "rate_hz", *AHRS_METRICS, "acc_rejected",
    "mag_rejected", "rest_samples", "rest_updates", "mag_time_offset_ms",
)  # fmt: skip

#: seconds at the start of an EuRoC IMU file taken as the rest period
_EUROC_REST_S = 1.0


@dataclass(frozen=True)
class AhrsRecording:
    """One task: a recording file, its dataset label and the filter options."""

    path: str
    dataset: str
    use_mag: bool = True
    offline: bool = False
    mag_calibration: bool = False


def _dataset_of(path: Path) -> str:
    parts = path.resolve().parts
    if len(parts) >= 4 and parts[-2] == "imu0" and parts[-3] == "mav0":
        return parts[-4]
    return path.resolve().parent.name


def _is_euroc_imu(path: Path) -> bool:
    try:
        return detect_format(path) == "euroc_imu"
    except (OSError, ValueError):
        return False


def _directory_files(d: Path) -> list[Path]:
    mats = [p for p in d.glob("*.mat") if p.is_file()]
    csvs = {p for p in d.glob("**/imu0/data.csv") if p.is_file()}
    csvs |= {p for p in d.glob("*.csv") if p.is_file() and _is_euroc_imu(p)}
    return sorted(mats + sorted(csvs))


def _manifest_rows(path: Path) -> list[tuple[Path, str | None]] | None:
    """The (recording, dataset) rows of a manifest, or None when ``path`` is not one (no ``recording`` header)."""
    with open(path, encoding="utf-8", newline="") as fh:
        lines = [(k, line) for k, line in enumerate(fh, start=1) if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        return None
    reader = csv.reader([line for _, line in lines])
    header = [h.strip().lower() for h in next(reader)]
    if "recording" not in header:
        return None
    i, j = header.index("recording"), header.index("dataset") if "dataset" in header else None
    rows: list[tuple[Path, str | None]] = []
    for (lineno, _), fields in zip(lines[1:], reader, strict=True):
        rec = fields[i].strip() if i < len(fields) else ""
        if not rec:
            raise ValueError(f"{path}:{lineno}: empty recording field")
        p = Path(rec) if os.path.isabs(rec) else path.parent / rec
        rows.append((p, fields[j].strip() if j is not None and j < len(fields) and fields[j].strip() else None))
    return rows


def ahrs_recordings(
    sources: Sequence[str | os.PathLike[str]], *, use_mag: bool = True, offline: bool = False,
    mag_calibration: bool = False,
) -> list[AhrsRecording]:  # fmt: skip
    """The recordings named by ``sources`` (module docstring), in order of the sources.

    A named file that does not exist is kept (its task then fails with the reason) so that it shows in the table.

    Raises
    ------
    ValueError
        No recording found in a directory or by a pattern, or a manifest row without a recording.
    """
    out: list[AhrsRecording] = []

    def add(p: Path, dataset: str | None = None) -> None:
        out.append(AhrsRecording(str(p), dataset or _dataset_of(p), use_mag, offline, mag_calibration))

    for src in sources:
        text = os.fspath(src)
        p = Path(text)
        if p.is_dir():
            files = _directory_files(p)
            if not files:
                raise ValueError(f"{p}: no BROAD .mat file or EuRoC IMU CSV (imu0/data.csv) in this directory")
            for f in files:
                add(f)
        elif any(ch in text for ch in "*?["):
            files = sorted(Path(f) for f in glob.glob(text, recursive=True) if Path(f).is_file())
            if not files:
                raise ValueError(f"{text}: the pattern matches no file")
            for f in files:
                add(f)
        elif p.suffix.lower() == ".csv" and p.is_file() and (rows := _manifest_rows(p)) is not None:
            if not rows:
                raise ValueError(f"{p}: manifest without rows")
            for f, dataset in rows:
                add(f, dataset)
        else:
            add(p)
    return out


def _euroc_trial(path: str) -> BroadTrial:
    imu = read_euroc_imu(path)
    if len(imu) < 2:
        raise ValueError(f"{path}: fewer than 2 IMU samples")
    t = (imu.stamps_ns - imu.stamps_ns[0]) * 1e-9
    n = len(imu)
    return BroadTrial(
        name=str(path), rate=1.0 / float(np.median(np.diff(t))), gyr=imu.gyro, acc=imu.accel,
        mag=np.full((n, 3), np.nan), quat=np.full((n, 4), np.nan), pos=np.full((n, 3), np.nan),
        movement=t >= _EUROC_REST_S, info=f"EuRoC IMU {path}", has_mag=False,
    )  # fmt: skip


def ahrs_task(rec: AhrsRecording) -> dict[str, Cell]:
    """Run the filter on one recording and score it (the task of :func:`run_ahrs_batch`; pure: reads one file).

    Returns the columns of :data:`AHRS_COLUMNS` from ``samples`` on.

    Raises
    ------
    ValueError, OSError
        An unreadable or invalid file (the message names it), or 9D asked of a recording without magnetometer.
    """
    path = Path(rec.path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    trial = load_broad(path) if path.suffix.lower() == ".mat" else _euroc_trial(rec.path)
    if rec.use_mag and not trial.has_mag:
        raise ValueError(f"{path}: no magnetometer field: use 6D (--no-mag)")
    cal = "auto" if rec.mag_calibration else None
    n_rest = max(trial.static_start, 10)
    scores: dict[str, float] | None
    if rec.offline:
        smoothed, scores = smooth_broad_trial(trial, use_mag=rec.use_mag, mag_calibration=cal)
        result = smoothed.forward
    else:
        result = estimate_orientation(trial.gyr, trial.acc, trial.mag if rec.use_mag else None, trial.rate,
                                      use_mag=rec.use_mag, n_rest=n_rest, mag_calibration=cal)  # fmt: skip
        scores = broad_scores(result.quat, trial, use_mag=rec.use_mag)
    offset = result.mag_time_offset_ms if rec.use_mag else None
    out: dict[str, Cell] = {
        "samples": int(result.quat.shape[0]),
        "rate_hz": float(trial.rate),
        "acc_rejected": int(result.acc_rejected),
        "mag_rejected": int(result.mag_rejected),
        "rest_samples": int(result.rest_samples),
        "rest_updates": int(result.rest_updates),
        "mag_time_offset_ms": math.nan if offset is None else float(offset),
    }
    for key in AHRS_METRICS:
        out[key] = math.nan if scores is None else float(scores[key])
    return out


def run_ahrs_batch(
    recordings: Sequence[AhrsRecording],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    client: distributed.Client | None = None,
) -> JobResult:
    """Run the filter on every recording on a scheduler (:func:`dualpose.jobs.scheduler.run_tasks`).

    Parameters
    ----------
    recordings : sequence of AhrsRecording
        From :func:`ahrs_recordings`.
    scheduler, workers, progress, client
        As :func:`dualpose.jobs.scheduler.run_tasks`.  On a cluster the recordings are grouped into the dask tasks by
        the size of their files (``run_tasks``'s ``cost``).

    Returns
    -------
    JobResult
        ``status`` "ok" or "failed" (reason in ``error``, numbers NaN / 0) per recording; the same recordings give
        the same table, bit for bit, on any scheduler.
    """
    recs = list(recordings)
    outcomes = run_tasks(ahrs_task, recs, scheduler=scheduler, workers=workers, progress=progress,
                         client=client, cost=lambda r: file_bytes(r.path))
    base: list[dict[str, Cell]] = [{"row": k, "dataset": r.dataset, "recording": r.path,
                                     "mode": ("9D" if r.use_mag else "6D") + (" offline" if r.offline else "")}
                                    for k, r in enumerate(recs)]  # fmt: skip
    rows = outcome_rows(AHRS_COLUMNS, base, outcomes, {"samples": 0, "acc_rejected": 0, "mag_rejected": 0,
                                                        "rest_samples": 0, "rest_updates": 0})  # fmt: skip
    table = ResultsTable(AHRS_COLUMNS, rows)
    summary = summarize(table, ("dataset", "mode"), AHRS_METRICS, lambda r: r["status"] == "ok")
    return JobResult(table, summary, sum(r["status"] != "ok" for r in rows))
