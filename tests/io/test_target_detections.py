"""Target-corner files and rig sensor files (dualpose.io.target.detections, dualpose.io.sensors_yaml): the EuRoC
imu_april recording in ../shared/data/euroc, and the errors of malformed files (file and line)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dualpose.io import RecordingError, read_rig_sensors, read_target_detections
from dualpose.types import EquidistantCamera, FrameCorrespondences, RadTanCamera
from realdata import data_dir

EUROC = data_dir("euroc/imu_april", full=True)
#: the whole recording, or its 5 s cut in tests/data (for the tests that hold on any stretch of it)
EUROC_ANY = data_dir("euroc/imu_april")


@pytest.fixture(scope="module")
def euroc_dir() -> Path:
    if not EUROC.is_dir():
        pytest.skip(f"EuRoC imu_april data missing ({EUROC})")
    return EUROC


@pytest.fixture(scope="module")
def euroc_any_dir() -> Path:
    if not EUROC_ANY.is_dir():
        pytest.skip(f"EuRoC imu_april data missing ({EUROC_ANY})")
    return EUROC_ANY


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


# ------------------------------------------------------------------------------------------ real files


@pytest.mark.parametrize("cam", ["cam0", "cam1"])
def test_euroc_aprilgrid_files(euroc_dir, cam):
    det = read_target_detections(euroc_dir / f"{cam}_aprilgrid.csv")
    lines = (euroc_dir / f"{cam}_aprilgrid.csv").read_text().splitlines()[1:]
    assert det.offsets[-1] == sum(1 for s in lines if ",," not in s)  # every corner row
    assert len(det) == len({s.split(",")[0] for s in lines}) == 1439
    assert (det.counts == 0).sum() == 23
    assert det.stamps_ns.dtype == np.int64 and (np.diff(det.stamps_ns) > 0).all()
    assert det.stamps_ns[0] == int(lines[0].split(",")[0])
    np.testing.assert_allclose(np.diff(det.t), 0.05, atol=5e-6)  # 20 Hz, no frame missing
    first = [float(v) for v in lines[0].split(",")]
    np.testing.assert_array_equal(det.pixels[0], first[1:3])
    np.testing.assert_array_equal(det.points[0], first[3:6])
    assert (det.tag_id[0], det.corner_id[0]) == (int(first[6]), int(first[7]))
    assert set(np.unique(det.corner_id)) <= {0, 1, 2, 3} and det.tag_id.max() <= 35
    np.testing.assert_array_equal(det.points[:, 2], 0.0)
    if cam == "cam0":  # the 1.2 s stretch without detections: consecutive empty frames spanning 1.2 s
        empty = det.counts == 0
        edges = np.diff(np.concatenate([[0], empty.astype(int), [0]]))
        starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        longest = int(np.argmax(stops - starts))
        span = det.t[stops[longest]] - det.t[starts[longest] - 1]  # last frame with corners to the next one
        assert span == pytest.approx(1.2, abs=0.06)


@pytest.mark.parametrize("variant", ["plain", "crlf-bom", "comment"])
def test_array_and_line_readers_agree(euroc_any_dir, tmp_path, variant):
    """The whole-array parse of the plain layout and the line-by-line reader give the same rows (the first 3000
    lines of cam0, with empty frames spliced in; a trailing comment sends the file to the line reader)."""
    from dualpose.io.target import detections as td

    lines = (euroc_any_dir / "cam0_aprilgrid.csv").read_text().splitlines()[:3000]
    stamp = [int(s.split(",")[0]) for s in lines[1:]]
    k = 1 + next(i for i in range(1200, len(stamp)) if stamp[i] != stamp[i - 1])  # first row of a frame
    lines.insert(k, f"{stamp[k - 2] + 1},,,,,,,")  # an empty frame between two frames
    lines.append(f"{stamp[-1] + 1}")  # a timestamp-only row, the short form
    if variant == "comment":
        lines[5] += "  # trailing comment"
    text = "\r\n".join(lines) if variant == "crlf-bom" else "\n".join(lines) + "\n"
    p = tmp_path / "c.csv"
    p.write_bytes((b"\xef\xbb\xbf" if variant == "crlf-bom" else b"") + text.encode())
    raw = p.read_bytes()
    fast = td._rows_fast(raw)
    assert (fast is None) == (variant == "comment")
    slow = td._rows_lines(str(p), raw)
    for a, b in zip(fast or slow, slow, strict=True):
        np.testing.assert_array_equal(a, b)
    det = read_target_detections(p)
    assert (det.counts == 0).sum() == 2 and det.offsets[-1] == 2999


def test_euroc_corrections_and_select(euroc_dir):
    rig = read_rig_sensors(euroc_dir / "sensors.yaml")
    det = read_target_detections(euroc_dir / "cam0_aprilgrid.csv")
    cam = rig.camera("cam0")
    corr = det.correspondences(cam)
    assert isinstance(corr, FrameCorrespondences)
    np.testing.assert_array_equal(corr.offsets, det.offsets)
    np.testing.assert_allclose(corr.pixels, cam.ideal_pixels(det.pixels))
    # ideal pixels map back to the measured ones through the pinhole rays
    k = det.offsets[100]
    rays = np.c_[(corr.pixels[k : k + 8] - [cam.cx, cam.cy]) / [cam.fx, cam.fy], np.ones(8)]
    np.testing.assert_allclose(cam.project(rays), det.pixels[k : k + 8], atol=1e-9)
    np.testing.assert_array_equal(det.correspondences().pixels, det.pixels)
    # a lens whose invertible region ends inside the image: the outer detections are refused, or left out
    folded = RadTanCamera(cam.fx, cam.fy, cam.cx, cam.cy, -0.9, 0.0, 0.0, 0.0, cam.width, cam.height)
    with pytest.raises(ValueError, match="outside the invertible region.*drop_invalid=True"):
        det.correspondences(folded)
    kept = det.correspondences(folded, drop_invalid=True)
    _, valid = folded.ideal_pixels(det.pixels, return_valid=True)
    assert 0 < valid.sum() < len(valid) and kept.offsets[-1] == valid.sum()
    np.testing.assert_array_equal(kept.counts, np.add.reduceat(valid, det.offsets[:-1]) * (det.counts > 0))
    np.testing.assert_array_equal(kept.points, det.points[valid])
    keep = (det.t < det.t[0] + 10) | (det.t > det.t[0] + 12)  # a 2 s outage
    sub = det.select(keep)
    assert len(sub) == keep.sum() and sub.offsets[-1] == det.counts[keep].sum()
    j = int(np.flatnonzero(keep)[300])
    np.testing.assert_array_equal(sub.frame(300)[0], det.frame(j)[0])
    ours, theirs = slice(sub.offsets[300], sub.offsets[301]), slice(det.offsets[j], det.offsets[j + 1])
    np.testing.assert_array_equal(sub.tag_id[ours], det.tag_id[theirs])
    with pytest.raises(ValueError, match="boolean mask"):
        det.select(np.ones(3, dtype=bool))


def test_euroc_sensors_yaml(euroc_any_dir):
    rig = read_rig_sensors(euroc_any_dir / "sensors.yaml")
    assert list(rig.cameras) == ["cam0", "cam1"]
    c0 = rig.cameras["cam0"]
    assert c0 == RadTanCamera(
        458.654, 457.296, 367.215, 248.375, -0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 752, 480
    )
    assert rig.cameras["cam1"].distortion == (-0.28368365, 0.07451284, -0.00010473, -3.555e-05)
    assert rig.camera_rates == {"cam0": 20.0, "cam1": 20.0}
    assert rig.imu_rate == 200.0 and rig.imu_noise.update_rate == 200.0
    assert rig.imu_noise.gyroscope_noise_density == 0.00016968
    assert rig.imu_noise.gyroscope_random_walk == 1.9393e-05
    assert rig.imu_noise.accelerometer_noise_density == 0.002
    assert rig.imu_noise.accelerometer_random_walk == 0.003
    assert rig.gravity_magnitude == 9.81007
    t = rig.T_cam0_cam1
    assert t.shape == (4, 4) and t[0, 3] == 0.1100741378 and t[2, 1] == 0.014089835847
    np.testing.assert_allclose(rig.relative_pose("cam1", "cam0") @ t, np.eye(4), atol=1e-12)
    assert rig.target["type"] == "aprilgrid" and rig.target["tag_size_m"] == 0.088
    with pytest.raises(ValueError, match=r"unknown camera 'cam2'; available: \['cam0', 'cam1'\]"):
        rig.camera("cam2")


# ------------------------------------------------------------------------------------------ corner-file errors

_HEADER = "#timestamp [ns],u [px],v [px],X [m],Y [m],Z [m],tag_id,corner_idx\n"
_ROWS = (
    "100,1.5,2.5,0.0,0.0,0.0,0,0\n"
    "100,3.5,4.5,0.1,0.0,0.0,0,1\n"
    "200,,,,,,,\n"
    "300\n"
    "400,5.5,6.5,0.1,0.1,0.0,3,2\n"
)


def test_small_corner_file(tmp_path):
    det = read_target_detections(_write(tmp_path, "c.csv", _HEADER + _ROWS))
    np.testing.assert_array_equal(det.stamps_ns, [100, 200, 300, 400])
    np.testing.assert_array_equal(det.counts, [2, 0, 0, 1])
    np.testing.assert_array_equal(det.pixels, [[1.5, 2.5], [3.5, 4.5], [5.5, 6.5]])
    np.testing.assert_array_equal(det.tag_id, [0, 0, 3])
    np.testing.assert_array_equal(det.corner_id, [0, 1, 2])
    assert det.frame(1)[0].shape == (0, 2)
    np.testing.assert_array_equal(det.t, det.stamps_ns * 1e-9)


@pytest.mark.parametrize(
    ("rows", "line", "message"),
    [
        ("100,1,2,3,4,5,0\n", 2, "expected 8 fields"),
        ("100,1,x,3,4,5,0,0\n", 2, "not a number"),
        ("100,1,2,3,4,nan,0,0\n", 2, "non-finite"),
        ("1e2,1,2,3,4,5,0,0\n", 2, "timestamp"),
        ("100,1,2,3,4,5,0.5,0\n", 2, "tag_id and corner_idx must be whole"),
        ("200,1,2,3,4,5,0,0\n100,1,2,3,4,5,0,1\n", 3, "earlier than the row before"),
        ("100,1,2,3,4,5,0,0\n200,1,2,3,4,5,0,0\n100,1,2,3,4,5,0,1\n", 4, "earlier"),
        ("100,1,2,3,4,5,0,0\n100\n", 3, "timestamp-only row"),
        ("100\n100\n", 3, "repeated timestamp-only"),
        ("100,1,2,3,4,5,7,1\n100,1,2,3,4,5,7,2\n100,9,9,3,4,5,7,1\n", 4, "tag 7 corner 1 appears twice"),
    ],
)
def test_malformed_corner_files(tmp_path, rows, line, message):
    p = _write(tmp_path, "bad.csv", _HEADER + rows)
    with pytest.raises(RecordingError, match=rf"bad\.csv:{line}: .*{message}"):
        read_target_detections(p)


def test_empty_corner_file(tmp_path):
    with pytest.raises(RecordingError, match="no data rows"):
        read_target_detections(_write(tmp_path, "e.csv", _HEADER))


# ------------------------------------------------------------------------------------------ YAML


_SENSORS = """\
imu0: {rate_hz: 100.0, gyroscope_noise_density: 1e-4, gyroscope_random_walk: 1e-5,
  accelerometer_noise_density: 2e-3, accelerometer_random_walk: 3e-3}
cam0:
  resolution: [512, 512]
  intrinsics_fx_fy_cx_cy: [190.9, 190.9, 254.9, 256.8]
  distortion_model: equidistant
  distortion_k1_k2_k3_k4: [0.0034, 0.0007, -0.0020, 0.0002]
"""


def test_sensors_yaml_equidistant_and_defaults(tmp_path):
    rig = read_rig_sensors(_write(tmp_path, "s.yaml", _SENSORS))
    cam = rig.cameras["cam0"]
    assert isinstance(cam, EquidistantCamera) and cam.distortion == (0.0034, 0.0007, -0.0020, 0.0002)
    assert np.isnan(rig.camera_rates["cam0"]) and np.isnan(rig.gravity_magnitude) and rig.target == {}
    assert rig.imu_noise.update_rate == 100.0


def test_kalibr_camchain(tmp_path):
    r = 0.5**0.5
    text = f"""\
cam0:
  camera_model: pinhole
  intrinsics: [458.654, 457.296, 367.215, 248.375]
  distortion_model: radtan
  distortion_coeffs: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
  resolution: [752, 480]
  T_cam_imu:
  - [0.0, -1.0, 0.0, 0.1]
  - [1.0, 0.0, 0.0, 0.2]
  - [0.0, 0.0, 1.0, 0.3]
  - [0.0, 0.0, 0.0, 1.0]
  timeshift_cam_imu: 0.0025
  rostopic: /cam0/image_raw
cam1:
  camera_model: pinhole
  intrinsics: [190.0, 191.0, 256.0, 255.0]
  distortion_model: equidistant
  distortion_coeffs: [0.003, 0.0007, -0.002, 0.0002]
  resolution: [512, 512]
  T_cn_cnm1:
  - [{r}, -{r}, 0.0, 0.11]
  - [{r}, {r}, 0.0, 0.0]
  - [0.0, 0.0, 1.0, 0.0]
  - [0.0, 0.0, 0.0, 1.0]
"""
    rig = read_rig_sensors(_write(tmp_path, "camchain.yaml", text))
    assert isinstance(rig.cameras["cam0"], RadTanCamera) and isinstance(rig.cameras["cam1"], EquidistantCamera)
    assert rig.cameras["cam1"].cx == 256.0 and rig.imu_noise is None
    assert rig.time_offsets == {"cam0": 0.0025}
    np.testing.assert_array_equal(rig.T_cam_imu["cam0"][0], [0.0, -1.0, 0.0, 0.1])
    t10 = rig.relative_pose("cam1", "cam0")  # x_cam1 = T_cn_cnm1 x_cam0
    assert t10[0, 3] == 0.11
    np.testing.assert_allclose(rig.T_cam0_cam1 @ t10, np.eye(4), atol=1e-15)


@pytest.mark.parametrize(
    ("text", "line", "message"),
    [
        (_SENSORS.replace("[512, 512]", "[512, 512"), None, "YAML syntax error"),
        (_SENSORS.replace("distortion_model: equidistant", "distortion_model: double-sphere"), 6,
         r"cam0\.distortion_model: unknown distortion model 'double-sphere'; accepted: \[.*'radtan'"),
        (_SENSORS.replace("  resolution: [512, 512]\n", ""), 3, r"cam0\.resolution: missing"),
        (_SENSORS.replace("[190.9, 190.9, 254.9, 256.8]", "[190.9, 190.9, 254.9]"), 5,
         "must be a list of 4 numbers"),
        (_SENSORS.replace("gyroscope_random_walk: 1e-5,", "gyroscope_random_walk: fast,"), 1,
         r"imu0\.gyroscope_random_walk: must be a finite number"),
        (_SENSORS.replace("[190.9, 190.9", "[-190.9, 190.9"), 3, "fx must be > 0"),
        (_SENSORS + "T_cam0_cam3: {data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}\n", 8,
         "names camera 'cam3'"),
        (_SENSORS + "T_cam0_cam0: {data: [2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}\n", 8, "rigid transform"),
        ("- just\n- a list\n", 1, "mapping at the top level"),
        (_SENSORS.replace("rate_hz: 100.0", "rate_hz: 0"), 1, r"imu0\.rate_hz: must be > 0"),
        (_SENSORS.replace("rate_hz: 100.0", "rate_hz: -100.0"), 1, r"imu0\.rate_hz: must be > 0"),
        (_SENSORS.replace("3e-3}", "3e-3, gravity_m_s2: 0}"), 2, r"imu0\.gravity_m_s2: must be > 0"),
        (_SENSORS.replace("3e-3}", "3e-3, gravity_m_s2: -9.81}"), 2, r"imu0\.gravity_m_s2: must be > 0"),
    ],
)  # fmt: skip
def test_bad_sensor_files(tmp_path, text, line, message):
    p = _write(tmp_path, "bad.yaml", text)
    where = rf"bad\.yaml:{line}: " if line is not None else r"bad\.yaml:\d+: "
    with pytest.raises(RecordingError, match=where + ".*" + message):
        read_rig_sensors(p)
