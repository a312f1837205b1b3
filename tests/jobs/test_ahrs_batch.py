"""ahrs --batch as a function: sources (files, directories, patterns, manifests) resolved to recordings, each row
equal to ``dualpose ahrs FILE --json`` on the file alone, a bad recording failed with its reason while the others
complete, and serial ≡ cluster."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from dualpose.cli.main import main
from dualpose.jobs.ahrs_batch import AHRS_COLUMNS, AHRS_METRICS, ahrs_recordings, run_ahrs_batch
from realdata import data_dir

BROAD = data_dir("broad")
EUROC_IMU = data_dir("euroc/imu_april") / "imu0.csv"
#: two short BROAD trials (in the cuts and the full set)
TRIALS = ("01_undisturbed_slow_rotation_A.mat", "24_disturbed_tapping_A.mat")


@pytest.fixture
def trials() -> list[Path]:
    paths = [BROAD / name for name in TRIALS]
    if not all(p.is_file() for p in paths):
        pytest.skip(f"BROAD trials missing in {BROAD}")
    return paths


def test_sources_resolve_in_order(trials: list[Path], tmp_path: Path) -> None:
    manifest = tmp_path / "fleet.csv"
    manifest.write_text(f"recording,dataset\n{trials[1]},tapping\n{trials[0]},\n", encoding="utf-8")
    recs = ahrs_recordings([str(BROAD / "01_*.mat"), manifest, trials[0].parent], use_mag=False)
    names = [Path(r.path).name for r in recs]
    assert names[0] == TRIALS[0] and names[1:3] == [TRIALS[1], TRIALS[0]]
    assert recs[1].dataset == "tapping" and recs[2].dataset == BROAD.name
    assert TRIALS[0] in names[3:] and all(not r.use_mag for r in recs)
    with pytest.raises(ValueError, match="the pattern matches no file"):
        ahrs_recordings([str(tmp_path / "*.mat")])
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="no BROAD .mat file or EuRoC IMU CSV"):
        ahrs_recordings([tmp_path / "empty"])


def test_rows_equal_the_single_file_command_and_bad_files_fail(
    trials: list[Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    broken = tmp_path / "broken.mat"
    broken.write_bytes(b"MATLAB 5.0 MAT-file, not really" + bytes(200))
    recs = ahrs_recordings([*trials, broken, tmp_path / "gone.mat"])
    res = run_ahrs_batch(recs, scheduler="serial")
    assert res.table.columns == AHRS_COLUMNS and res.failed == 2
    for path, row in zip(trials, res.table.rows, strict=False):
        assert main(["ahrs", str(path), "--json"]) == 0
        single = json.loads(capsys.readouterr().out)
        assert row["status"] == "ok" and row["mode"] == "9D" and row["samples"] == single["samples"]
        for key in (*AHRS_METRICS, "acc_rejected", "mag_rejected", "rest_updates", "mag_time_offset_ms"):
            assert row[key] == single[key], key
    bad, gone = res.table.rows[2:]
    assert bad["status"] == gone["status"] == "failed"
    assert "broken.mat" in str(bad["error"]) and str(gone["error"]).endswith("gone.mat: no such file")
    assert all(math.isnan(bad[k]) for k in AHRS_METRICS)


def test_euroc_imu_runs_6d_without_reference() -> None:
    if not EUROC_IMU.is_file():
        pytest.skip(f"EuRoC IMU file missing ({EUROC_IMU})")
    res = run_ahrs_batch(ahrs_recordings([EUROC_IMU], use_mag=False), scheduler="serial")
    (row,) = res.table.rows
    assert row["status"] == "ok" and row["mode"] == "6D" and row["rate_hz"] == pytest.approx(200.0, rel=1e-3)
    assert all(math.isnan(row[k]) for k in AHRS_METRICS) and math.isnan(row["mag_time_offset_ms"])
    res9 = run_ahrs_batch(ahrs_recordings([EUROC_IMU]), scheduler="serial")
    assert res9.failed == 1 and "no magnetometer field: use 6D (--no-mag)" in str(res9.table.rows[0]["error"])
    smoothed = run_ahrs_batch(ahrs_recordings([EUROC_IMU], use_mag=False, offline=True), scheduler="serial")
    assert smoothed.failed == 0 and smoothed.table.rows[0]["mode"] == "6D offline"


def test_serial_and_cluster_tables_are_identical(trials: list[Path], cluster_address: str) -> None:
    recs = ahrs_recordings(trials)
    serial = run_ahrs_batch(recs, scheduler="serial")
    parallel = run_ahrs_batch(recs, scheduler=cluster_address)
    assert serial.failed == 0
    assert parallel.table.to_csv_text() == serial.table.to_csv_text()
