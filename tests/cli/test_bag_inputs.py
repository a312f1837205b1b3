"""ROS bag topics (``FILE.bag:/topic``) as the inputs of ``dualpose eval``, ``calibrate hand-eye`` and ``ahrs``: the
same results as from the equivalent text files; bag errors exit 1 with the bag and topic named."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

import dualpose as dp
from dualpose.cli.main import main
from dualpose.io import Trajectory, seconds_from_ns, write_tum
from dualpose.io.rosbag import write_trajectory_bag

pytest.importorskip("rosbags", reason="rosbags (dualpose[ros]) not installed")


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(spec.name, mod)  # dataclasses look their module up in sys.modules
    spec.loader.exec_module(mod)
    return mod


TESTS = Path(__file__).parents[1]
bagmaker = _load("bagmaker", TESTS / "io" / "bagmaker.py")
handeye_sim = _load("handeye_sim", TESTS / "calibration" / "handeye_sim.py")


def _trajectories(rng: np.random.Generator) -> tuple[Trajectory, Trajectory]:
    n = 300
    ns = 1_600_000_000_000_000_000 + np.arange(n) * 20_000_000
    t = seconds_from_ns(ns) - seconds_from_ns(ns[:1])
    p = np.stack([np.cos(t), np.sin(2 * t), 0.1 * t], axis=1)
    q = dp.quat_normalize(np.stack([0.1 * np.sin(t), 0.2 * np.cos(t), np.sin(0.5 * t), np.ones(n)], axis=1))
    ref = Trajectory(seconds_from_ns(ns), p, q, ns)
    est_ns = ns[::2] + 3_000_000
    noise = rng.normal(scale=0.01, size=(est_ns.shape[0], 3))
    est = Trajectory(seconds_from_ns(est_ns), p[::2] + noise, dp.quat_normalize(q[::2] + 0.01), est_ns)
    return ref, est


def test_eval_on_bags_equals_eval_on_tum_files(tmp_path, rng, capsys):
    ref, est = _trajectories(rng)
    write_tum(tmp_path / "ref.tum", ref)
    write_tum(tmp_path / "est.tum", est)
    write_trajectory_bag(tmp_path / "ref.bag", ref, "/gt", "world")
    write_trajectory_bag(tmp_path / "est.mcap", est, "/est", "world")
    assert main(["eval", str(tmp_path / "ref.tum"), str(tmp_path / "est.tum"), "--json", "--quiet"]) == 0
    text = json.loads(capsys.readouterr().out)
    assert main(["eval", f"{tmp_path / 'ref.bag'}:/gt", f"{tmp_path / 'est.mcap'}:/est", "--json", "--quiet"]) == 0
    bag = json.loads(capsys.readouterr().out)
    assert bag["settings"]["reference_format"] == "rosbag"
    for key in ("ate_rmse_m", "rpe_rmse_m", "orientation_rmse_deg", "matched_poses"):
        assert bag[key] == text[key]
    assert main(["eval", f"{tmp_path / 'ref.bag'}:/nope", str(tmp_path / "est.tum"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "ref.bag: no topic /nope; topics in the bag: /gt (geometry_msgs/PoseStamped)" in err


def test_hand_eye_on_bags_equals_hand_eye_on_csv(tmp_path, capsys):
    rec = handeye_sim.simulate(0.0123, 5, duration=12.0)
    handeye_sim.write_rows(tmp_path / "cam.csv", rec.camera, ", ")
    handeye_sim.write_rows(tmp_path / "body.csv", rec.body, " ")
    for name, rows, suffix in (("cam", rec.camera, ".db3"), ("body", rec.body, ".bag")):
        rows = np.asarray(rows)
        ns = np.round(rows[:, 0] * 1e9).astype(np.int64)
        tr = Trajectory(seconds_from_ns(ns), rows[:, 1:4], rows[:, 4:8], ns)
        write_trajectory_bag(tmp_path / f"{name}{suffix}", tr, f"/{name}", "target")
    assert main(["calibrate", "hand-eye", str(tmp_path / "cam.csv"), str(tmp_path / "body.csv"), "--json"]) == 0
    csv = json.loads(capsys.readouterr().out)
    args = [f"{tmp_path / 'cam.db3'}:/cam", f"{tmp_path / 'body.bag'}:/body", "--json", "--bag-time", "receive"]
    assert main(["calibrate", "hand-eye", *args]) == 0
    bag = json.loads(capsys.readouterr().out)
    assert abs(bag["time_offset_s"] - csv["time_offset_s"]) < 1e-6
    np.testing.assert_allclose(bag["rotation_xyzw"], csv["rotation_xyzw"], atol=1e-7)
    np.testing.assert_allclose(bag["translation_m"], csv["translation_m"], atol=1e-7)
    assert bag["camera_rows"]["kept"] == csv["camera_rows"]["kept"]
    assert main(["calibrate", "hand-eye", f"{tmp_path / 'cam.db3'}:/body", str(tmp_path / "body.csv")]) == 1
    assert "cam.db3: no topic /body; topics in the bag: /cam" in capsys.readouterr().err


def test_ahrs_on_an_imu_bag(tmp_path, capsys):
    """A rig turning about the vertical at 0.5 rad/s after 2 s at rest, 200 Hz, with the earth field: 6D and 9D
    (--mag-topic) run on every sample; without --mag-topic 9D is refused with the fix named."""
    n = 1200
    ns = 1_000_000_000 + np.arange(n) * 5_000_000
    t = (ns - ns[0]) * 1e-9
    rate = np.where(t >= 2.0, 0.5, 0.0)
    yaw = np.cumsum(rate) / 200.0
    gyro = np.stack([np.zeros(n), np.zeros(n), rate], axis=1)
    accel = np.tile([0.0, 0.0, 9.81], (n, 1))
    field_enu = np.array([0.0, 20e-6, -40e-6])  # tesla
    mag = np.stack([np.cos(yaw) * field_enu[0] + np.sin(yaw) * field_enu[1],
                    -np.sin(yaw) * field_enu[0] + np.cos(yaw) * field_enu[1], np.full(n, field_enu[2])], axis=1)
    m = bagmaker._Msgs(True)
    bag = tmp_path / "imu.bag"
    bagmaker.write_bag(bag, {
        "/imu": ("sensor_msgs/msg/Imu", [(s, m.make("sensor_msgs/msg/Imu", s, "imu", np.r_[g, a]))
                                         for s, g, a in zip(ns.tolist(), gyro, accel, strict=True)]),
        "/mag": ("sensor_msgs/msg/MagneticField", [(s, m.make("sensor_msgs/msg/MagneticField", s, "imu", f))
                                                   for s, f in zip(ns.tolist(), mag, strict=True)]),
    })  # fmt: skip
    assert main(["ahrs", f"{bag}:/imu", "--no-mag", "--rest-seconds", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mode"] == "6D" and out["samples"] == n and abs(out["rate_hz"] - 200.0) < 1e-6
    assert out["total_rmse_deg"] is None  # no reference in a bag
    assert main(["ahrs", f"{bag}:/imu", "--mag-topic", "/mag", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mode"] == "9D" and out["samples"] == n
    assert main(["ahrs", f"{bag}:/imu"]) == 1
    assert "no --mag-topic (magnetometer): use --no-mag for 6D" in capsys.readouterr().err
    assert main(["ahrs", f"{bag}:/mag", "--no-mag"]) == 1
    assert "message type sensor_msgs/MagneticField does not hold IMU samples" in capsys.readouterr().err
    assert main(["ahrs", str(tmp_path / "x.mat"), "--mag-topic", "/mag"]) == 2


def test_fuse_out_bag_writes_the_estimate(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["fuse", "--out", str(out), "--out-bag", "mcap", "--json"]) == 0
    capsys.readouterr()
    from dualpose.io import read_tum
    from dualpose.io.rosbag import read_bag_trajectory

    tum = read_tum(out / "trajectory.tum")
    bag = read_bag_trajectory(f"{out / 'trajectory.mcap'}:/dualpose/pose")
    np.testing.assert_array_equal(bag.positions, tum.positions)
    np.testing.assert_array_equal(bag.quats, tum.quats)
    np.testing.assert_allclose(bag.stamps, tum.stamps, atol=1e-9)
    assert main(["fuse", "--out", str(out), "--out-bag", "mcap"]) == 2  # never replaced without --force
    assert "earlier run's output" in capsys.readouterr().err
    assert main(["fuse", "--out-bag", "bag"]) == 2
    assert "--out-bag writes into the --out directory" in capsys.readouterr().err
