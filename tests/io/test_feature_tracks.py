"""Feature-track readers: GTSAM's EqVIO replay CSV against an independent parse with the standard library's csv
module, and the plain track CSV (round trip, pixels, streaming, errors naming file and line)."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from dualpose.io.feature_tracks import (
    is_eqvio_csv,
    iter_track_csv,
    read_eqvio_csv,
    read_track_csv,
    write_track_csv,
)
from dualpose.types import CameraIntrinsics
from dualpose.types.features import FeatureTracks, TrackFrame


def test_eqvio_csv_matches_an_independent_parse(euroc_v101) -> None:
    path, _ = euroc_v101
    rec = read_eqvio_csv(path)
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    imu = [r for r in rows if r["row_type"] == "imu"]
    vis = [r for r in rows if r["row_type"] == "vision_feature"]
    meta = {r["key"]: r["value"] for r in rows if r["row_type"] == "meta"}
    assert len(rec.t) == len(imu) and len(rec.tracks.track_id) == len(vis)
    t0 = float(imu[0]["t_abs"])
    np.testing.assert_allclose(rec.t, [float(r["t_abs"]) - t0 for r in imu], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(rec.gyro[:, 1], [float(r["gy"]) for r in imu])
    np.testing.assert_array_equal(rec.accel[:, 2], [float(r["az"]) for r in imu])
    np.testing.assert_array_equal(rec.tracks.track_id, [int(r["landmark_id"]) for r in vis])
    np.testing.assert_array_equal(rec.tracks.uv[:, 1], [float(r["v_norm"]) for r in vis])
    assert len(rec.tracks) == len({r["t_abs"] for r in vis})
    q = np.array([float(meta[f"T_ci_q{c}"]) for c in "xyzw"])
    np.testing.assert_allclose(rec.q_bc, q / np.linalg.norm(q), rtol=0, atol=1e-15)
    assert rec.feature_sigma == math.sqrt(float(meta["eqf.measurement_noise_variance_norm"]))
    assert rec.imu_noise.gyroscope_noise_density == math.sqrt(float(meta["eqf.input_var_gyr"]))
    assert rec.focal_length == float(meta["camera_fx"]) and rec.t0 == t0
    assert rec.imu_noise.update_rate == pytest.approx(200.0, rel=1e-3)
    assert is_eqvio_csv(path)


def test_eqvio_errors_name_file_and_line(tmp_path, euroc_v101) -> None:
    path, gt = euroc_v101
    lines = path.read_text().splitlines()
    bad = tmp_path / "bad.csv"
    k = next(i for i, line in enumerate(lines) if line.startswith("imu,"))
    lines[k] = lines[k].replace("imu,", "imu,x", 1)
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=rf"bad.csv:{k + 1}: .*'x1403"):
        read_eqvio_csv(bad)
    assert not is_eqvio_csv(gt)


def _tracks() -> FeatureTracks:
    frames = [TrackFrame(0.05 * k, [1, 2, 3 + k], [[0.1 * k, -0.2], [0.3, 0.01 * k], [-0.5, 0.25]]) for k in range(4)]
    return FeatureTracks.from_frames(frames)


def test_plain_track_csv_round_trip_and_stream(tmp_path) -> None:
    tr = _tracks()
    p = tmp_path / "tracks.csv"
    write_track_csv(p, tr)
    back = read_track_csv(p)
    for name in ("t", "offsets", "track_id", "uv"):
        np.testing.assert_array_equal(getattr(back, name), getattr(tr, name))
    streamed = list(iter_track_csv(p))
    assert len(streamed) == len(tr)
    for k, f in enumerate(streamed):
        np.testing.assert_array_equal(f.uv, tr.frame(k).uv)
        np.testing.assert_array_equal(f.track_id, tr.frame(k).track_id)
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_track_csv(p, tr)


def test_pixel_tracks_are_normalised_with_the_camera(tmp_path) -> None:
    cam = CameraIntrinsics(fx=400.0, fy=380.0, cx=320.0, cy=240.0, width=640, height=480)
    p = tmp_path / "px.csv"
    p.write_text("# coordinates: pixels\nt,track_id,u,v\n0.0,7,360,202\n0.0,8,320,240\n0.05,7,364,200\n")
    tr = read_track_csv(p, camera=cam)
    np.testing.assert_allclose(tr.uv, [[0.1, -0.1], [0.0, 0.0], [0.11, -40 / 380]], rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="need a camera model"):
        read_track_csv(p)


@pytest.mark.parametrize(
    ("body", "line", "message"),
    [
        ("0.0,1,0.1,0.2\n0.0,1,0.3,0.4\n", 3, "track_id 1 appears twice"),
        ("0.1,1,0.1,0.2\n0.0,2,0.3,0.4\n", 3, "time order"),
        ("0.0,1.5,0.1,0.2\n", 2, "whole number"),
        ("0.0,1,abc,0.2\n", 2, "not a number"),
    ],
)
def test_plain_track_csv_errors_name_the_line(tmp_path, body: str, line: int, message: str) -> None:
    p = tmp_path / "t.csv"
    p.write_text("t,track_id,u,v\n" + body)
    with pytest.raises(ValueError, match=rf"t.csv:{line}: .*{message}"):
        read_track_csv(p)


def test_track_frame_checks_its_arguments() -> None:
    with pytest.raises(ValueError, match=r"uv must have shape \(2, 2\)"):
        TrackFrame(0.0, [1, 2], np.zeros((3, 2)))
    with pytest.raises(ValueError, match="unique"):
        TrackFrame(0.0, [1, 1], np.zeros((2, 2)))


def test_bulk_and_line_by_line_parses_agree(euroc_v101) -> None:
    from dualpose.io.feature_tracks import _read_eqvio_checked

    path, _ = euroc_v101
    a, b = read_eqvio_csv(path), _read_eqvio_checked(path)
    for name in ("t", "gyro", "accel", "q_bc", "p_bc"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for name in ("t", "offsets", "track_id", "uv"):
        np.testing.assert_array_equal(getattr(a.tracks, name), getattr(b.tracks, name))
    assert a.meta == b.meta and a.feature_sigma == b.feature_sigma


def test_eqvio_landmark_twice_in_a_frame_is_refused_with_its_line(tmp_path, euroc_v101) -> None:
    path, _ = euroc_v101
    lines = path.read_text().splitlines()
    k = [i for i, line in enumerate(lines) if line.startswith("vision_feature,")][100]
    lines.insert(k + 1, lines[k])  # the same feature observed twice in one frame
    bad = tmp_path / "dup.csv"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=rf"dup.csv:{k + 2}: landmark_id \d+ appears twice"):
        read_eqvio_csv(bad)
