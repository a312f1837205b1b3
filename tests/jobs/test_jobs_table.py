"""The results table: exact CSV text, Parquet read back equal, atomic writes that never replace a file unasked and
leave nothing behind when writing fails, and the per-group summary."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from dualpose.jobs.table import ResultsTable, atomic_path, summarize

ROWS = [
    {"dataset": "a", "algorithm": "x", "status": "ok", "v": 0.1, "n": 3},
    {"dataset": "a", "algorithm": "x", "status": "ok", "v": 1 / 3, "n": 4},
    {"dataset": "a", "algorithm": "y", "status": "failed", "v": math.nan, "n": 0},
    {"dataset": "b", "algorithm": "x", "status": "ok", "v": 2.5e-300, "n": 5},
]
COLUMNS = ("dataset", "algorithm", "status", "v", "n")


def test_csv_text_round_trips_every_float() -> None:
    text = ResultsTable(COLUMNS, ROWS).to_csv_text()
    lines = text.splitlines()
    assert lines[0] == "dataset,algorithm,status,v,n"
    assert lines[2] == "a,x,ok,0.3333333333333333,4" and lines[3] == "a,y,failed,nan,0"
    assert [float(line.split(",")[3]) for line in lines[1:]][1] == 1 / 3
    with pytest.raises(ValueError, match=r"rows\[0\]: columns differ"):
        ResultsTable(("dataset",), ROWS)


def test_parquet_reads_back(tmp_path: Path) -> None:
    pq = pytest.importorskip("pyarrow.parquet", reason="pyarrow is not installed (the test extra installs it)")
    table = ResultsTable(COLUMNS, ROWS)
    table.write_parquet(tmp_path / "t.parquet")
    back = pq.read_table(tmp_path / "t.parquet").to_pydict()
    assert back["v"][:2] == [0.1, 1 / 3] and math.isnan(back["v"][2]) and back["n"] == [3, 4, 0, 5]
    assert back["dataset"] == ["a", "a", "a", "b"]


def test_atomic_writes(tmp_path: Path) -> None:
    target = tmp_path / "results.csv"
    table = ResultsTable(COLUMNS, ROWS)
    table.write_csv(target)
    with pytest.raises(FileExistsError, match="results.csv: file exists"):
        table.write_csv(target)
    before = target.read_bytes()
    with pytest.raises(RuntimeError, match="half-way"), atomic_path(target, overwrite=True) as tmp:
        tmp.write_text("partial", encoding="utf-8")
        raise RuntimeError("half-way")
    assert target.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["results.csv"]
    ResultsTable(COLUMNS, ROWS[:1]).write_csv(target, overwrite=True)
    assert target.read_text(encoding="utf-8").count("\n") == 2


def test_summary_per_group() -> None:
    s = summarize(ResultsTable(COLUMNS, ROWS), ("dataset", "algorithm"), ("v",), lambda r: r["status"] == "ok")
    rows = {(r["dataset"], r["algorithm"]): r for r in s.rows}
    ax = rows[("a", "x")]
    assert (ax["runs"], ax["failed"], ax["mean"], ax["median"], ax["min"], ax["max"]) == (
        2, 0, np.mean([0.1, 1 / 3]), np.median([0.1, 1 / 3]), 0.1, 1 / 3)  # fmt: skip
    assert ax["std"] == np.std([0.1, 1 / 3])
    ay = rows[("a", "y")]
    assert ay["runs"] == 0 and ay["failed"] == 1 and math.isnan(ay["mean"])
    assert list(rows) == [("a", "x"), ("a", "y"), ("b", "x")]
