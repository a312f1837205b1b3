"""The results table of a many-run job and its per-group summary, written atomically (CSV; Parquet with pyarrow).

One row per task, in task order; columns fixed by the job.  Values are ``str``, ``int``, ``bool`` or ``float``
(NaN where a metric does not exist: a failed row, a recording without reference).  CSV cells hold floats as
``repr`` -- the shortest text that reads back as the same float64 -- so two runs with the same numbers write the
same bytes.  Every file is written to a temporary sibling and renamed over the target (an interrupted job leaves
either the old file or the new one, never half a file); an existing file is replaced only with ``overwrite=True``.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dualpose.jobs.scheduler import TaskFailure

__all__ = ["SUMMARY_COLUMNS", "JobResult", "ResultsTable", "atomic_path", "has_parquet", "outcome_rows", "summarize"]

Cell = str | int | float | bool

#: columns of :func:`summarize`'s table after the group columns
SUMMARY_COLUMNS: tuple[str, ...] = ("metric", "runs", "failed", "mean", "median", "std", "min", "max")


@contextmanager
def atomic_path(path: str | os.PathLike[str], *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary sibling of ``path`` to write; on success it is renamed to ``path`` (removed on error).

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is False.
    """
    target = Path(path)
    if target.exists() and not overwrite:
        raise FileExistsError(f"{target}: file exists (replace it with overwrite=True / --force)")
    tmp = target.with_name(f".{target.stem}.tmp-{os.getpid()}{target.suffix}")
    try:
        yield tmp
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()


def has_parquet() -> bool:
    """True when pyarrow is installed (the Parquet copy of the tables is then written)."""
    try:
        import pyarrow  # type: ignore[import-untyped, unused-ignore]  # noqa: F401
    except ImportError:
        return False
    return True


def _cell_text(value: Cell) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


@dataclass
class ResultsTable:
    """Rows of named columns, in order.

    Attributes
    ----------
    columns : tuple of str
        Column names, in file order.
    rows : list of dict
        One dict per row with every column (``str``, ``int``, ``bool`` or ``float``; NaN for a missing number).
    """

    columns: tuple[str, ...]
    rows: list[dict[str, Cell]]

    def __post_init__(self) -> None:
        for k, row in enumerate(self.rows):
            if set(row) != set(self.columns):
                missing = sorted(set(self.columns) - set(row))
                extra = sorted(set(row) - set(self.columns))
                raise ValueError(f"rows[{k}]: columns differ from the table's (missing {missing}, extra {extra})")

    def __len__(self) -> int:
        return len(self.rows)

    def column(self, name: str) -> list[Cell]:
        """The values of one column, in row order."""
        if name not in self.columns:
            raise KeyError(f"no column {name!r}; the columns are {self.columns}")
        return [row[name] for row in self.rows]

    def to_csv_text(self) -> str:
        """The table as CSV text (header line, one line per row, ``\\n`` line ends)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns)
        for row in self.rows:
            w.writerow([_cell_text(row[c]) for c in self.columns])
        return buf.getvalue()

    def write_csv(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
        """Write the CSV file atomically; returns its path."""
        with atomic_path(path, overwrite=overwrite) as tmp:
            tmp.write_text(self.to_csv_text(), encoding="utf-8")
        return Path(path)

    def write_parquet(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
        """Write a Parquet file atomically (needs pyarrow); column types follow the values (str, int64, float64,
        bool)."""
        import pyarrow as pa  # type: ignore[import-untyped, unused-ignore]
        import pyarrow.parquet as pq  # type: ignore[import-untyped, unused-ignore]

        data = {}
        for c in self.columns:
            values = self.column(c)
            kinds = {type(v) for v in values}
            kind = pa.float64() if kinds <= {float, int} and float in kinds else None
            data[c] = pa.array(values, type=kind)
        with atomic_path(path, overwrite=overwrite) as tmp:
            pq.write_table(pa.table(data), tmp)
        return Path(path)


@dataclass
class JobResult:
    """Output of a many-run job: the results table (a row per task, in input order), its summary per group
    (:func:`summarize`) and the count of failed rows."""

    table: ResultsTable
    summary: ResultsTable
    failed: int


def outcome_rows(
    columns: Sequence[str], base: Sequence[dict[str, Cell]], outcomes: Sequence[Mapping[str, object] | TaskFailure],
    failed: Mapping[str, Cell],
) -> list[dict[str, Cell]]:  # fmt: skip
    """The rows of a job's results table: row k is ``base[k]`` (its labels) with ``status`` "ok", ``error`` "" and
    the remaining ``columns`` from ``outcomes[k]``, or -- for a :class:`~dualpose.jobs.scheduler.TaskFailure` --
    ``status`` "failed", the reason in ``error``, the values of ``failed`` and NaN in every other column."""
    rows: list[dict[str, Cell]] = []
    for labels, out in zip(base, outcomes, strict=True):
        row: dict[str, Cell] = dict(labels)
        if isinstance(out, TaskFailure):
            row.update(status="failed", error=out.reason, **failed)
            row.update({c: math.nan for c in columns if c not in row})
        else:
            row.update(status="ok", error="")
            row.update({c: out[c] for c in columns if c not in row})  # type: ignore[misc]
        rows.append(row)
    return rows


def _finite(values: Sequence[Cell]) -> NDArray[np.float64]:
    arr = np.asarray([float(v) for v in values if isinstance(v, (int, float)) and not isinstance(v, bool)],
                     dtype=np.float64)
    out: NDArray[np.float64] = arr[np.isfinite(arr)]
    return out


def summarize(
    table: ResultsTable, group_by: Sequence[str], metrics: Sequence[str], ok: Callable[[dict[str, Cell]], bool]
) -> ResultsTable:
    """Per group and metric: runs, failed, mean, median, std (population, ddof 0), min and max over the runs.

    Parameters
    ----------
    table : ResultsTable
    group_by : sequence of str
        The group columns (``("dataset", "algorithm")``); groups appear in the order of their first row.
    metrics : sequence of str
        Numeric columns to summarise.
    ok : callable
        ``ok(row)``: False for a failed row, which is counted in ``failed`` and left out of the statistics.

    Returns
    -------
    ResultsTable
        Columns ``group_by + SUMMARY_COLUMNS``; ``runs`` counts the rows of the group with a finite value of the
        metric (a failed row or NaN is not a run); statistics are NaN when there is none.
    """
    groups: dict[tuple[Cell, ...], list[dict[str, Cell]]] = {}
    for row in table.rows:
        groups.setdefault(tuple(row[g] for g in group_by), []).append(row)
    rows: list[dict[str, Cell]] = []
    for key, members in groups.items():
        good = [r for r in members if ok(r)]
        for metric in metrics:
            v = _finite([r[metric] for r in good])
            stats = (
                (float(np.mean(v)), float(np.median(v)), float(np.std(v)), float(np.min(v)), float(np.max(v)))
                if v.size else (math.nan,) * 5
            )  # fmt: skip
            out: dict[str, Cell] = dict(zip(group_by, key, strict=True))
            out.update(metric=metric, runs=int(v.size), failed=len(members) - len(good))
            out.update(zip(("mean", "median", "std", "min", "max"), stats, strict=True))
            rows.append(out)
    return ResultsTable(tuple(group_by) + SUMMARY_COLUMNS, rows)
