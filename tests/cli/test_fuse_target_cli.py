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
from dualpose.pipelines.track_target import EUROC_T_BS, extrinsic_from_matrix
from dualpose.types.calibration import CameraImuCalibration
from realdata import CUTS

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


def _tum(path: Path) -> np.ndarray:
    return np.array([[float(v) for v in r.split()] for r in path.read_text().splitlines() if not r.startswith("#")])


def test_output_smoothed_by_default_with_the_filter_beside_it_and_filter_on_request(recording_dir, tmp_path,
                                                                                    capsys):  # fmt: skip
    """Offline default: trajectory.tum is the RTS-smoothed run and trajectory_filter.tum the causal filter's, which
    is the stream's output (``run_relocking``'s states); ``--output filter`` writes the filter as trajectory.tum and
    no second file."""
    from dualpose.pipelines.track_target import prepare_track, run_relocking

    rec, calib, _, _ = recording_dir
    setup = prepare_track(rec, calib, "cam0")
    tr = run_relocking(setup.recording, setup.start.x, setup.start.P, "eskf")
    out = tmp_path / "smoothed"
    assert main(["fuse", "--data", str(rec), "--calibration", str(calib), "--out", str(out), "--json"]) == 0
    m = json.loads(capsys.readouterr().out)
    assert m["output"] == "smoothed" and m["smoother"]["segments"] == 1
    smoothed, filtered = _tum(out / "trajectory.tum"), _tum(out / "trajectory_filter.tum")
    np.testing.assert_allclose(filtered[:, 1:4], tr.position, rtol=0, atol=1e-9)  # TUM text: 9 decimals
    assert len(smoothed) == len(filtered) == len(tr.t)
    assert 1e-5 < np.abs(smoothed[:, 1:4] - filtered[:, 1:4]).max() < 0.05  # smoothed, not the filter again
    out2 = tmp_path / "filter"
    assert main(["fuse", "--data", str(rec), "--calibration", str(calib), "--output", "filter", "--out",
                 str(out2)]) == 0  # fmt: skip
    assert "causal filter" in capsys.readouterr().out
    np.testing.assert_array_equal(_tum(out2 / "trajectory.tum"), filtered)
    assert not (out2 / "trajectory_filter.tum").exists()


def test_output_options_that_do_not_fit_are_usage_errors(recording_dir, capsys):
    rec, calib, _, _ = recording_dir
    assert main(["fuse", "--data", str(rec), "--calibration", str(calib), "--filter", "hol22", "--output",
                 "smoothed"]) == 2  # fmt: skip
    assert "--output smoothed needs --filter eskf" in _error(capsys)
    assert main(["fuse", "--output", "filter"]) == 2  # the simulated run: --smooth there
    assert "only used with a calibration-target recording" in _error(capsys)
    code, _, err = run_lines([], "fuse", "--stream", "--sensors", str(rec / "sensors.yaml"), "--calibration",
                             str(calib), "--output", "smoothed")  # fmt: skip
    assert code == 2 and "--output" in err and "causal" in err


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


@pytest.fixture(scope="module")
def april_cut_with_gap(tmp_path_factory):
    """The imu_april cut of tests/data (5 s) with 0.5 s of IMU samples deleted 3 s in (100 sample periods), and
    EuRoC's published cam0 extrinsic (Burri et al. 2016) as the calibration."""
    src = CUTS / "euroc" / "imu_april"
    d = tmp_path_factory.mktemp("april_gap")
    shutil.copytree(src, d / "rec")
    rows = (src / "imu0.csv").read_text().splitlines(keepends=True)
    t0 = int(rows[1].split(",")[0])
    kept = [r for r in rows if r.startswith("#") or not 3.0e9 <= int(r.split(",")[0]) - t0 < 3.5e9]
    assert len(rows) - len(kept) == 100
    (d / "rec" / "imu0.csv").write_text("".join(kept))
    q, p = extrinsic_from_matrix(EUROC_T_BS["cam0"])
    cal = CameraImuCalibration("cam0", q, p, 0.0, 0.35)
    write_camera_imu_calibration(d / "calib.json", cal)
    return d / "rec", d / "calib.json", cal


def test_an_imu_gap_in_a_target_recording_is_doubted_batch_and_stream(april_cut_with_gap, capsys):
    """``fuse --data`` on a target recording runs the set-up checks of ``fuse --data`` on a plain recording: the gap
    is warned about, listed in ``input_doubts`` and the exit status is 3; the stream warns and exits 3 too."""
    from dualpose.io.target.recording import read_target_recording

    rec, calib, cal = april_cut_with_gap
    code = main(["fuse", "--data", str(rec), "--camera", "cam0", "--calibration", str(calib), "--json"])
    cap = capsys.readouterr()
    assert code == 3 and "dualpose fuse: warning:" in cap.err and "IMU gap(s)" in cap.err
    m = json.loads(cap.out)
    assert [d["code"] for d in m["input_doubts"]] == ["imu_gap"]
    args = ("fuse", "--stream", "--sensors", str(rec / "sensors.yaml"), "--calibration", str(calib))
    code, out, err = run_lines(stream_lines(read_target_recording(rec), cal), *args)
    assert code == 3 and err.count("IMU gap") == 1 and "stdin line" in err and "IMU gap of 0.505 s" in err, err
    assert len(out.splitlines()) > 500  # the poses are still written


def test_a_gyroscope_in_deg_per_s_and_an_unused_camera_are_doubted_by_the_target_stream(april_cut_with_gap):
    """The stream's own doubts, read from ``TrackStream.doubts``: a gyroscope in deg/s (the check of ``fuse --data``
    over the start of the IMU), the start-up's gravity direction (the rates ×57.3 leave the camera–IMU alignment
    determined to more than 1°; 0.13° with the true rates) and correspondences the gate mostly rejects."""
    import dataclasses
    import warnings

    from dualpose.io.target.recording import read_target_recording
    from dualpose.pipelines.track_target import TrackStream, stream_track_lines

    rec, _, cal = april_cut_with_gap
    src = read_target_recording(rec)
    imu = src.imu
    deg = dataclasses.replace(src, imu=type(imu)(imu.stamps_ns, imu.stamps, np.degrees(imu.gyro), imu.accel, imu.name))
    stream = TrackStream(src.rig, "cam0", cal)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = list(stream_track_lines(stream_lines(deg, cal), stream))
    assert out and [d.code for d in stream.doubts] == ["gyro_unit", "gravity_sigma", "camera_rejected"]
    assert stream.start is not None and stream.start.alignment.gravity_sigma_deg > 1.0
