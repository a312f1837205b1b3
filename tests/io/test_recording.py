"""Recording format of ``dualpose fuse --data``: writer/reader round trip, the TUM-style IMU and YAML variants, and
bad files reported with file and line."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from dualpose import sim
from dualpose.io import RecordingError, read_recording, write_recording
from dualpose.io.recording import SENSORS_FILE, read_correspondences, read_imu
from dualpose.sim import recording_from_simulation


@pytest.fixture(scope="module")
def run() -> sim.SimulatedRun:
    return sim.simulate_eight(3, time_offset=0.012)


@pytest.fixture(scope="module")
def written(run, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("rec") / "eight"
    write_recording(out, sim.recording_from_simulation(run))
    return out


@pytest.fixture
def copy(written, tmp_path) -> Path:
    """A private copy of the written recording to break."""
    dst = tmp_path / "rec"
    shutil.copytree(written, dst)
    return dst


def test_round_trip_reproduces_the_run(run, written):
    rec = read_recording(written)
    ref = recording_from_simulation(run)
    # times go through integer nanoseconds: within half a nanosecond, everything else exact
    np.testing.assert_allclose(rec.t, run.t, rtol=0, atol=5e-10)
    np.testing.assert_array_equal(rec.gyro, run.gyro)
    np.testing.assert_array_equal(rec.accel, run.accel)
    np.testing.assert_array_equal(rec.stamps_ns, np.round(run.t * 1e9).astype(np.int64))
    np.testing.assert_allclose(rec.frames.t, run.frames.t, rtol=0, atol=5e-10)
    np.testing.assert_array_equal(rec.frames.offsets, run.frames.offsets)
    np.testing.assert_array_equal(rec.frames.pixels, run.frames.pixels)
    np.testing.assert_array_equal(rec.frames.points, run.frames.points)
    np.testing.assert_array_equal(rec.camera.matrix, run.camera.matrix)
    assert (rec.camera.width, rec.camera.height) == (run.camera.width, run.camera.height)
    assert rec.imu_noise == run.imu_noise
    np.testing.assert_array_equal(rec.q_bc, run.q_bc)
    np.testing.assert_array_equal(rec.p_bc, run.p_bc)
    assert rec.pixel_sigma == run.pixel_sigma and rec.time_offset == run.time_offset == 0.012
    np.testing.assert_array_equal(rec.gravity, ref.gravity)
    assert rec.rest_seconds == ref.rest_seconds == 0.9
    gt = rec.ground_truth
    np.testing.assert_array_equal(gt.positions, run.truth["position"])
    np.testing.assert_allclose(gt.quats, run.truth["quat"], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(gt.extra["accel_bias"], run.truth["accel_bias"])
    np.testing.assert_array_equal(gt.stamps_ns, rec.stamps_ns)


def test_writer_never_overwrites_without_permission(run, written):
    before = (written / SENSORS_FILE).read_text()
    with pytest.raises(FileExistsError, match="file exists"):
        write_recording(written, sim.recording_from_simulation(run))
    assert (written / SENSORS_FILE).read_text() == before
    with pytest.raises(TypeError, match="must be a dualpose.types.Recording"):
        write_recording(written, "not a run", overwrite=True)


def _fail_after_imu(monkeypatch):
    """Make the ground-truth writer (called after the IMU and correspondence files are written) raise."""
    import dualpose.io.recording as recording_module

    def broken(*args, **kwargs):
        raise OSError("disk full (test)")

    monkeypatch.setattr(recording_module, "write_euroc_groundtruth", broken)


@pytest.mark.parametrize("existing", ["missing", "empty", "other files", "earlier recording"])
def test_writer_failing_half_way_leaves_nothing_partial(run, written, tmp_path, monkeypatch, existing):
    # the recording directory appears complete or not at all; a directory's other files are left alone
    out = tmp_path / "rec"
    if existing == "empty":
        out.mkdir()
    elif existing == "other files":
        out.mkdir()
        (out / "notes.txt").write_text("mine\n")
    elif existing == "earlier recording":
        shutil.copytree(written, out)
    before = {p.name: p.read_bytes() for p in out.iterdir()} if out.exists() else None
    _fail_after_imu(monkeypatch)
    with pytest.raises(OSError, match="disk full"):
        write_recording(out, sim.recording_from_simulation(run), overwrite=True)
    after = {p.name: p.read_bytes() for p in out.iterdir()} if out.exists() else None
    assert after == before
    assert [p.name for p in tmp_path.iterdir() if p.name != "rec"] == []  # no temporary sibling left behind
    monkeypatch.undo()
    write_recording(out, sim.recording_from_simulation(run), overwrite=True)
    expected = {SENSORS_FILE, "imu.csv", "correspondences.csv", "groundtruth.csv"}
    assert expected <= {p.name for p in out.iterdir()}
    if existing == "other files":
        assert (out / "notes.txt").read_text() == "mine\n"
    assert read_recording(out).gyro.shape == read_recording(written).gyro.shape


def test_sensor_file_path_and_files_elsewhere(written, tmp_path):
    # the sensor file may be given directly and may name data files in another directory
    data = tmp_path / "data"
    data.mkdir()
    for name in ("imu.csv", "correspondences.csv"):
        shutil.copy(written / name, data / name)
    cfg = json.loads((written / SENSORS_FILE).read_text())
    cfg["files"] = {"imu": "data/imu.csv", "correspondences": "data/correspondences.csv"}
    (tmp_path / "my_rig.json").write_text(json.dumps(cfg))
    rec = read_recording(tmp_path / "my_rig.json")
    assert rec.ground_truth is None
    np.testing.assert_array_equal(rec.gyro, read_recording(written).gyro)


def test_tum_style_imu_text_and_headerless_csv(written, copy):
    imu = read_imu(written / "imu.csv")
    whole, frac = np.divmod(imu.stamps_ns, 1_000_000_000)
    rows = [
        f"{w}.{f:09d} " + " ".join(repr(v) for v in row)
        for w, f, row in zip(whole, frac, np.hstack([imu.gyro, imu.accel]).tolist(), strict=True)
    ]
    (copy / "imu.txt").write_text("# t wx wy wz ax ay az\n" + "\n".join(rows) + "\n")
    text = read_imu(copy / "imu.txt")
    np.testing.assert_array_equal(text.stamps_ns, imu.stamps_ns)
    np.testing.assert_array_equal(text.gyro, imu.gyro)
    # a plain header line (no '#') on the correspondence file is accepted
    body = (written / "correspondences.csv").read_text().splitlines()[1:]
    (copy / "corr.csv").write_text("timestamp_ns,u_px,v_px,X_m,Y_m,Z_m\n" + "\n".join(body) + "\n")
    a = read_correspondences(written / "correspondences.csv")
    b = read_correspondences(copy / "corr.csv")
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def test_yaml_sensor_file(written, copy):
    yaml = pytest.importorskip("yaml")
    cfg = json.loads((copy / SENSORS_FILE).read_text())
    (copy / SENSORS_FILE).unlink()
    (copy / "sensors.yaml").write_text(yaml.safe_dump(cfg))
    a, b = read_recording(copy), read_recording(written)
    np.testing.assert_array_equal(a.camera.matrix, b.camera.matrix)
    assert a.imu_noise == b.imu_noise


def _edit_json(path: Path, fn) -> None:
    cfg = json.loads(path.read_text())
    fn(cfg)
    path.write_text(json.dumps(cfg, indent=2))


def _replace_line(path: Path, lineno: int, text: str) -> None:
    lines = path.read_text().splitlines()
    lines[lineno - 1] = text
    path.write_text("\n".join(lines) + "\n")


def _line_of(path: Path, needle: str) -> int:
    return next(i for i, ln in enumerate(path.read_text().splitlines(), start=1) if needle in ln)


@pytest.mark.parametrize(
    ("breaker", "file", "line", "match"),
    [
        (lambda d: _replace_line(d / "imu.csv", 5, "40000000,0.1,0.2,0.3"), "imu.csv", 5, "expected 7 fields"),
        (lambda d: _replace_line(d / "imu.csv", 6, "10000000,0,0,0,0,0,9.8"), "imu.csv", 6, "strictly increasing"),
        (lambda d: _replace_line(d / "imu.csv", 7, "60000000,0,0,x,0,0,9.8"), "imu.csv", 7, "'x' is not a number"),
        (
            lambda d: _replace_line(d / "correspondences.csv", 30, "13700000,1,2,3,4,5"),
            "correspondences.csv",
            30,
            "non-decreasing",
        ),
        (
            lambda d: _replace_line(d / "correspondences.csv", 4, "13700000,1,nan,3,4,5"),
            "correspondences.csv",
            4,
            "non-finite",
        ),
        (lambda d: _replace_line(d / SENSORS_FILE, 3, '  "version": 1,,'), SENSORS_FILE, 3, "JSON syntax error"),
    ],
)
def test_bad_data_files_name_file_and_line(copy, breaker, file, line, match):
    breaker(copy)
    with pytest.raises(RecordingError, match=match) as exc:
        read_recording(copy)
    assert f"{file}:{line}:" in str(exc.value)
    assert isinstance(exc.value, ValueError)


@pytest.mark.parametrize(
    ("edit", "key", "match"),
    [
        (lambda c: c["imu"].update(gyroscope_noise_densty=1e-3), "gyroscope_noise_densty", "unknown key"),
        (lambda c: c["camera"].update(q_bc=[0.0, 0.0, 0.5, 0.5]), "q_bc", "unit quaternion"),
        (lambda c: c["camera"].update(fx=-3.0), '"fx"', "must be > 0"),
        (lambda c: c["camera"].update(width=320.5), '"width"', "positive whole number"),
        (lambda c: c.update(gravity=[0, -9.81]), '"gravity"', "list of 3"),
    ],
)
def test_bad_sensor_values_name_the_key_and_its_line(copy, edit, key, match):
    _edit_json(copy / SENSORS_FILE, edit)
    with pytest.raises(RecordingError, match=match) as exc:
        read_recording(copy)
    assert f"{SENSORS_FILE}:{_line_of(copy / SENSORS_FILE, key)}:" in str(exc.value)


def test_value_checks_of_the_types_layer_name_the_sensor_file_keys(copy):
    """A value refused by the recording's own checks is named by its key in the sensor file (``imu.``, not the
    dataclass's ``imu_noise.``)."""
    _edit_json(copy / SENSORS_FILE, lambda c: c["imu"].update(accelerometer_noise_density=1e300))
    with pytest.raises(RecordingError, match=r"sensors\.json: imu\.accelerometer_noise_density must be") as exc:
        read_recording(copy)
    assert "imu_noise" not in str(exc.value)


def test_missing_things_are_named(copy, tmp_path):
    with pytest.raises(RecordingError, match="no such file or directory"):
        read_recording(tmp_path / "nowhere")
    with pytest.raises(RecordingError, match="needs a sensors.json"):
        read_recording(tmp_path)
    _edit_json(copy / SENSORS_FILE, lambda c: c["camera"].pop("fx"))
    with pytest.raises(RecordingError, match=r"camera\.fx: missing"):
        read_recording(copy)
    _edit_json(copy / SENSORS_FILE, lambda c: c["camera"].update(fx=213.0))
    (copy / "groundtruth.csv").unlink()
    with pytest.raises(RecordingError, match="groundtruth.csv: ground-truth file not found"):
        read_recording(copy)
    (copy / "imu.csv").unlink()
    with pytest.raises(RecordingError, match="imu.csv: IMU file not found"):
        read_recording(copy)


def test_the_documented_example_sensor_file_is_valid(written, copy):
    doc = (Path(__file__).resolve().parents[2] / "docs" / "fusion.md").read_text()
    example = doc.split("```json\n", 1)[1].split("```", 1)[0]
    (copy / SENSORS_FILE).write_text(example)
    a, b = read_recording(copy), read_recording(written)
    np.testing.assert_array_equal(a.q_bc, b.q_bc)
    np.testing.assert_array_equal(a.camera.matrix, b.camera.matrix)
    assert a.rest_seconds == 0.9 and a.ground_truth is not None
