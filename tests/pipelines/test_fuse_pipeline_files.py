"""``run_fuse`` / ``dualpose fuse`` on recordings from files: the written simulated run gives the metrics of
``--data sim``, no ground truth gives null metrics, the rest period is detected, and bad recordings exit 2."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from dualpose import sim
from dualpose.cli.main import main
from dualpose.estimation import initialization
from dualpose.io import RecordingError, write_recording
from dualpose.io.recording import SENSORS_FILE
from dualpose.pipelines.fuse import TRUTH_METRICS, run_fuse

#: metrics that depend on wall-clock time
TIMING = ("filter_wall_time_s", "realtime_factor", "data")


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("fuse") / "eight"
    write_recording(out, sim.recording_from_simulation(sim.simulate_eight(0)))
    return out


@pytest.fixture
def copy(recording, tmp_path):
    dst = tmp_path / "rec"
    shutil.copytree(recording, dst)
    return dst


def _edit(path, fn) -> None:
    cfg = json.loads(path.read_text())
    fn(cfg)
    path.write_text(json.dumps(cfg))


@pytest.mark.parametrize("filter_name", ["eskf", "hol22"])
def test_files_give_the_metrics_of_the_simulation(recording, filter_name):
    a = run_fuse("sim", filter_name, seed=0).metrics
    b = run_fuse(recording, filter_name).metrics
    assert b["data"] == str(recording)
    assert set(a) == set(b)
    for key in a:
        if key in TIMING:
            continue
        if key == "evaluation":
            for k in ("ate_m", "orientation_deg", "rpe_translation_m"):
                for stat in ("rmse", "max", "median"):
                    assert b[key][k][stat] == pytest.approx(a[key][k][stat], rel=0, abs=1e-9)
        elif isinstance(a[key], float):
            assert b[key] == pytest.approx(a[key], rel=0, abs=1e-9), key
        else:
            assert b[key] == a[key], key


def test_without_ground_truth_the_truth_metrics_are_null(copy):
    _edit(copy / SENSORS_FILE, lambda c: c["files"].pop("groundtruth"))
    res = run_fuse(copy)
    m = res.metrics
    for key in TRUTH_METRICS:
        assert m[key] is None
    assert m["evaluation"] is None
    assert res.truth is None and res.position_error is None and res.error_index is None
    assert 0.85 <= m["nis_fraction_inside"] <= 1.0 and m["realtime_factor"] > 0
    # the estimate is still written with the exact IMU nanoseconds
    np.testing.assert_array_equal(res.estimate.stamps_ns, np.round(res.estimate.stamps * 1e9).astype(np.int64))


def test_rest_period_detected_when_not_given(copy):
    run = sim.simulate_eight(0)
    n = run.imu_noise
    rest = initialization.detect_rest(run.t, run.gyro, run.accel, n.gyroscope_noise_density,
                                      n.accelerometer_noise_density)  # fmt: skip
    assert 0.8 <= rest <= 1.0  # the eight starts moving at t = 1.0 s
    _edit(copy / SENSORS_FILE, lambda c: c.pop("rest_duration_s"))
    m = run_fuse(copy).metrics
    assert m["ate_rmse_m"] <= 0.01 and m["orientation_rmse_deg"] <= 0.5


def test_detect_rest_on_a_still_stream_and_validation():
    rng = np.random.default_rng(5)
    t = np.arange(500) / 100.0
    gyro = rng.normal(0, 0.01, (500, 3)) + [0.01, -0.02, 0.005]
    accel = rng.normal(0, 0.02, (500, 3)) + [0.0, 0.0, 9.81]
    assert initialization.detect_rest(t, gyro, accel, 0.001, 0.002) == pytest.approx(t[-1])
    accel[300:] += [0.5, 0.0, 0.0]  # a step at t = 3 s: rest ends at the last full window before it
    assert initialization.detect_rest(t, gyro, accel, 0.001, 0.002) == pytest.approx(2.99)
    with pytest.raises(ValueError, match="shorter than one"):
        initialization.detect_rest(t[:2], gyro[:2], accel[:2], 0.001, 0.002)


def test_no_frame_during_the_rest_is_a_recording_error(copy):
    _edit(copy / SENSORS_FILE, lambda c: c.update(rest_duration_s=0.01))  # first frame is at 0.0137 s
    with pytest.raises(RecordingError, match="cannot start the filter: no camera frame"):
        run_fuse(copy)


def test_cli_on_files(copy, tmp_path, capsys):
    assert main(["fuse", "--data", str(copy), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["data"] == str(copy) and out["ate_rmse_m"] <= 0.01

    _edit(copy / SENSORS_FILE, lambda c: c["files"].pop("groundtruth"))
    assert main(["fuse", "--data", str(copy), "--out", str(tmp_path / "o")]) == 0
    cap = capsys.readouterr()
    assert "n/a (no ground truth)" in cap.out and "1/4 load" in cap.err
    metrics = json.loads((tmp_path / "o" / "metrics.json").read_text())
    assert metrics["ate_rmse_m"] is None
    assert (tmp_path / "o" / "errors.png").read_bytes()[:4] == b"\x89PNG"
    first = next(ln for ln in (tmp_path / "o" / "trajectory.tum").read_text().splitlines() if ln[0] != "#")
    assert first.split()[0] == "0.000000000"

    lines = (copy / "imu.csv").read_text().splitlines()
    lines[9] = "90000000,0,0,0,0,zero,9.8"
    (copy / "imu.csv").write_text("\n".join(lines) + "\n")
    assert main(["fuse", "--data", str(copy)]) == 1  # data error
    err = capsys.readouterr().err
    assert f"{copy / 'imu.csv'}:10:" in err and "'zero' is not a number" in err
