"""``dualpose fuse`` on calibration-target recordings (``--data DIR --camera --calibration``, ``--stream --sensors``):
outputs, the stream against the batch run bit for bit, and the refusals (unknown camera, missing files, no time
overlap, wrong calibration keys, options that do not fit)."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from _pipes import run_lines

from dualpose.cli.fuse import OUTPUT_FILES
from dualpose.cli.main import main
from dualpose.io.target.recording import write_camera_imu_calibration

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pipelines"))
from _target_sim import simulated_target_recording, stream_lines, write_target_directory


@pytest.fixture(scope="module")
def recording_dir(tmp_path_factory):
    """The simulated target recording (cam0 only) on disk and its calibration JSON."""
    d = tmp_path_factory.mktemp("target")
    src, cal, _, _ = simulated_target_recording(0, reference=False)
    write_target_directory(d / "rec", src)
    write_camera_imu_calibration(d / "calib.json", cal)
    return d / "rec", d / "calib.json", src, cal


def test_fuse_target_writes_outputs_and_reports_the_startup(recording_dir, tmp_path, capsys):
    rec, calib, _, _ = recording_dir
    out = tmp_path / "out"
    assert main(["fuse", "--data", str(rec), "--camera", "cam0", "--calibration", str(calib), "--out", str(out),
                 "--json"]) == 0  # fmt: skip
    m = json.loads(capsys.readouterr().out)
    assert m["camera"] == "cam0" and m["filter"] == "eskf" and m["reference"] is None  # no second camera
    assert m["startup"]["gyro_bias_from"] == "start-up" and m["realtime_factor"] > 0
    for name in OUTPUT_FILES:
        assert (out / name).stat().st_size > 0
    rows = [r for r in (out / "trajectory.tum").read_text().splitlines() if not r.startswith("#")]
    assert len(rows) == m["imu_samples"]
    assert main(["fuse", "--data", str(rec), "--calibration", str(calib), "--filter", "hol22"]) == 0
    table = capsys.readouterr().out
    assert "hol22" in table and "gravity (start-up)" in table and "n/a" in table


def test_stream_cli_equals_the_batch_run_bit_for_bit(recording_dir):
    from dualpose.pipelines.track_target import prepare_track, run_relocking

    rec, calib, src, cal = recording_dir
    setup = prepare_track(rec, calib, "cam0")
    tr = run_relocking(setup.recording, setup.start.x, setup.start.P, "eskf")
    args = ("fuse", "--stream", "--sensors", str(rec / "sensors.yaml"), "--camera", "cam0", "--calibration", str(calib))
    code, out, err = run_lines(stream_lines(setup.source, cal), *args)
    assert code == 0, err
    got = np.array([[float(v) for v in line.split(",")] for line in out.splitlines()])
    np.testing.assert_array_equal(got, np.column_stack([tr.t, tr.position, tr.quat]))


def _error(capsys) -> str:
    return " ".join(capsys.readouterr().err.split())


def test_unknown_camera_lists_the_available_ones(recording_dir, capsys):
    rec, calib, _, _ = recording_dir
    assert main(["fuse", "--data", str(rec), "--camera", "cam7", "--calibration", str(calib)]) == 1
    err = _error(capsys)
    assert "cam7" in err and "available: cam0" in err


def test_missing_files_are_named(recording_dir, tmp_path, capsys):
    rec, calib, _, _ = recording_dir
    for missing in ("imu0.csv", "sensors.yaml", "cam0_aprilgrid.csv"):
        d = tmp_path / missing
        shutil.copytree(rec, d)
        (d / missing).unlink()
        assert main(["fuse", "--data", str(d), "--calibration", str(calib)]) == 1
        assert missing in _error(capsys)


def test_no_time_overlap_is_refused(recording_dir, tmp_path, capsys):
    rec, calib, _, _ = recording_dir
    d = tmp_path / "late"
    shutil.copytree(rec, d)
    lines = (d / "cam0_aprilgrid.csv").read_text().splitlines()
    shifted = [lines[0]] + [str(int(r.split(",")[0]) + 10**12) + r[len(r.split(",")[0]):] for r in lines[1:]]
    (d / "cam0_aprilgrid.csv").write_text("\n".join(shifted) + "\n")
    assert main(["fuse", "--data", str(d), "--calibration", str(calib)]) == 1
    assert "do not overlap the IMU" in _error(capsys)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda c: c.update(rotation_xyz=c.pop("rotation_xyzw")), "'rotation_xyz' instead of 'rotation_xyzw'?"),
        (lambda c: c.pop("translation_m"), "missing key(s) 'translation_m'"),
        (lambda c: c.update(time_offset_s="0.1"), "time_offset_s must be a finite number"),
        (lambda c: c.update(rotation_xyzw=[0, 0, 0, 2]), "rotation_xyzw must be a unit quaternion"),
        (lambda c: c.update(camera="cam1"), "the calibration is of camera 'cam1'"),
    ],
)
def test_wrong_calibration_files_are_refused(recording_dir, tmp_path, capsys, edit, message):
    rec, calib, _, _ = recording_dir
    c = json.loads(Path(calib).read_text())
    edit(c)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(c))
    assert main(["fuse", "--data", str(rec), "--calibration", str(bad)]) == 1
    err = _error(capsys)
    assert message in err


def test_options_that_do_not_fit_are_usage_errors(recording_dir, capsys):
    rec, calib, _, _ = recording_dir
    assert main(["fuse", "--data", str(rec)]) == 2
    assert "--calibration CALIB.json" in _error(capsys)
    assert main(["fuse", "--camera", "cam0"]) == 2  # the simulated run has no cameras to choose
    assert "only used with a calibration-target recording" in _error(capsys)
    assert main(["fuse", "--data", str(rec), "--calibration", str(calib), "--smooth"]) == 2
    code, _, err = run_lines([], "fuse", "--stream", "--sensors", str(rec / "sensors.yaml"))
    assert code == 2 and "--calibration CALIB.json" in err


def test_unknown_camera_on_imu_april(euroc_april, recording_dir, capsys):
    _, calib, _, _ = recording_dir
    assert main(["fuse", "--data", str(euroc_april), "--camera", "cam2", "--calibration", str(calib)]) == 1
    assert "available: cam0, cam1" in _error(capsys)


def test_truth_is_refused_with_a_target_recording_and_a_stream(recording_dir, tmp_path, capsys):
    rec, calib, _, _ = recording_dir
    truth = tmp_path / "truth.tum"
    truth.write_text("0 0 0 0 0 0 0 1\n")
    assert main(["fuse", "--data", str(rec), "--calibration", str(calib), "--truth", str(truth)]) == 2
    assert "--truth" in _error(capsys)
    assert main(["fuse", "--stream", "--sensors", str(rec / "sensors.yaml"), "--calibration", str(calib),
                 "--truth", str(truth)]) == 2  # fmt: skip
    assert "--truth" in _error(capsys)



def test_stream_with_a_missing_sensor_file_is_an_error_not_a_traceback(recording_dir, tmp_path):
    _, calib, _, _ = recording_dir
    code, _, err = run_lines([], "fuse", "--stream", "--sensors", str(tmp_path / "none.yaml"), "--calibration",
                             str(calib))  # fmt: skip
    assert code == 1 and "none.yaml" in err and "Traceback" not in err
