"""ROS bag reading and writing (dualpose.io.rosbag): bags written message by message with rosbags' own serializer
and writers (ROS 1 .bag, ROS 2 .db3 and .mcap), read back and compared with rosbags' own deserializer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dualpose as dp
from dualpose.io import Trajectory
from dualpose.io.rosbag import (
    BagError,
    BagSource,
    bag_topics,
    parse_bag_source,
    read_bag_imu,
    read_bag_magnetic_field,
    read_bag_trajectory,
    write_trajectory_bag,
)

pytest.importorskip("rosbags", reason="rosbags (dualpose[ros]) not installed")
from bagmaker import FORMATS, T0, _Msgs, deserialized, write_bag, write_imu_bag


def _values(rng: np.random.Generator, n: int, width: int = 7) -> np.ndarray:
    v = rng.normal(size=(n, width))
    if width == 7:
        v[:, 3:7] = dp.quat_normalize(v[:, 3:7])
    return v


TRAJECTORY_TYPES = (
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "geometry_msgs/msg/TransformStamped",
    "nav_msgs/msg/Odometry",
)


@pytest.mark.parametrize("suffix", FORMATS)
@pytest.mark.parametrize("msgtype", TRAJECTORY_TYPES)
def test_trajectory_types_match_rosbags_deserializer(tmp_path, rng, suffix, msgtype):
    n = 40
    m = _Msgs(suffix == ".bag")
    vals = _values(rng, n)
    head = T0 + np.arange(n) * 50_000_000 + rng.integers(0, 1000, n)
    recv = head + 3_000_000
    frames = [("map" * (k % 4))[: k % 7] for k in range(n)]  # frame_id lengths vary: offsets differ per message
    msgs = [(recv[k], m.make(msgtype, head[k], frames[k], vals[k])) for k in range(n)]
    path = tmp_path / f"poses{suffix}"
    write_bag(path, {"/other": ("sensor_msgs/msg/MagneticField", []), "/poses": (msgtype, msgs)})
    ref = deserialized(path, "/poses")
    expect = []
    for _, msg in ref:
        pose = msg.transform if hasattr(msg, "transform") else msg.pose
        pose = pose.pose if hasattr(pose, "pose") else pose
        p, q = (pose.translation, pose.rotation) if hasattr(pose, "translation") else (pose.position, pose.orientation)
        expect.append([p.x, p.y, p.z, q.x, q.y, q.z, q.w])
    tr = read_bag_trajectory(f"{path}:/poses")
    assert isinstance(tr, Trajectory) and tr.name == f"{path}:/poses"
    np.testing.assert_array_equal(tr.positions, np.asarray(expect)[:, 0:3])
    np.testing.assert_array_equal(tr.quats, np.asarray(expect)[:, 3:7])
    np.testing.assert_array_equal(tr.stamps_ns, head)
    np.testing.assert_array_equal(tr.stamps, dp_seconds(head))
    np.testing.assert_array_equal(read_bag_trajectory(f"{path}:/poses", stamps="receive").stamps_ns, recv)


def dp_seconds(ns):
    from dualpose.io import seconds_from_ns

    return seconds_from_ns(ns)


@pytest.mark.parametrize("suffix", FORMATS)
def test_imu_and_magnetic_field(tmp_path, rng, suffix):
    n = 25
    m = _Msgs(suffix == ".bag")
    imu = rng.normal(size=(n, 6))
    mag = rng.normal(size=(n, 3)) * 5e-5
    head = T0 + np.arange(n) * 5_000_000
    path = tmp_path / f"imu{suffix}"
    write_bag(path, {
        "/imu0": ("sensor_msgs/msg/Imu", [(head[k] + 7, m.make("sensor_msgs/msg/Imu", head[k], "imu_link", imu[k]))
                                          for k in range(n)]),
        "/mag": ("sensor_msgs/msg/MagneticField",
                 [(head[k], m.make("sensor_msgs/msg/MagneticField", head[k] + 1, "imu", mag[k])) for k in range(n)]),
    })  # fmt: skip
    ref = deserialized(path, "/imu0")
    data = read_bag_imu(f"{path}:/imu0")
    np.testing.assert_array_equal(data.gyro, [[r.angular_velocity.x, r.angular_velocity.y, r.angular_velocity.z]
                                              for _, r in ref])  # fmt: skip
    np.testing.assert_array_equal(data.accel, imu[:, 3:6])
    np.testing.assert_array_equal(data.stamps_ns, head)
    np.testing.assert_array_equal(read_bag_imu(f"{path}:/imu0", stamps="receive").stamps_ns, head + 7)
    ns, field = read_bag_magnetic_field(f"{path}:/mag")
    np.testing.assert_array_equal(field, mag)
    np.testing.assert_array_equal(ns, head + 1)


@pytest.mark.parametrize("suffix", FORMATS)
def test_tf_chain_composes_static_and_moving_transforms(tmp_path, rng, suffix):
    """/tf: world -> odom (static, /tf_static), odom -> base (moving, 20 Hz), base -> camera (static in /tf_static,
    asked in reverse: the pose of odom in camera too); compared with the composition done here by matrices."""
    m = _Msgs(suffix == ".bag")
    n = 30
    ns = T0 + np.arange(n) * 50_000_000
    q_wo, p_wo = dp.quat_normalize(rng.normal(size=4)), rng.normal(size=3)
    q_bc, p_bc = dp.quat_normalize(rng.normal(size=4)), rng.normal(size=3)
    moving = _values(rng, n)
    TF = m.t["tf2_msgs/msg/TFMessage"]
    tf_msgs = []
    for k in range(n):  # two transforms per message: odom->base and an unrelated one
        tfs = [m.transform(ns[k], "odom", "base", moving[k, :3], moving[k, 3:]),
               m.transform(ns[k], "other", "thing", [0, 0, k], [0, 0, 0, 1])]  # fmt: skip
        tf_msgs.append((ns[k], TF(transforms=tfs if k % 2 else tfs[::-1])))
    static = TF(transforms=[m.transform(ns[0], "/world", "odom", p_wo, q_wo),
                            m.transform(ns[0], "base", "camera_optical_frame", p_bc, q_bc)])  # fmt: skip
    path = tmp_path / f"tf{suffix}"
    write_bag(path, {"/tf": ("tf2_msgs/msg/TFMessage", tf_msgs),
                     "/tf_static": ("tf2_msgs/msg/TFMessage", [(ns[0], static)])})  # fmt: skip

    def mat(q, p):
        out = np.eye(4)
        out[:3, :3] = dp.matrix_from_quat(q)
        out[:3, 3] = p
        return out

    tr = read_bag_trajectory(f"{path}:/tf:world:camera_optical_frame")
    np.testing.assert_array_equal(tr.stamps_ns, ns)
    for k in range(n):
        want = mat(q_wo, p_wo) @ mat(moving[k, 3:], moving[k, :3]) @ mat(q_bc, p_bc)
        got = mat(tr.quats[k], tr.positions[k])
        np.testing.assert_allclose(got, want, atol=1e-12)
    inv = read_bag_trajectory(f"{path}:/tf:camera_optical_frame:odom")
    for k in range(n):
        want = np.linalg.inv(mat(moving[k, 3:], moving[k, :3]) @ mat(q_bc, p_bc))
        np.testing.assert_allclose(mat(inv.quats[k], inv.positions[k]), want, atol=1e-12)
    with pytest.raises(BagError, match=r"no chain of transforms from frame 'world' to 'moon'.*odom->base"):
        read_bag_trajectory(f"{path}:/tf:world:moon")


@pytest.mark.parametrize("suffix", FORMATS)
def test_write_round_trip_and_rosbags_reads_it(tmp_path, rng, suffix):
    n = 50
    ns = T0 + np.arange(n) * 33_333_333
    vals = _values(rng, n)
    tr = Trajectory(dp_seconds(ns), vals[:, :3], vals[:, 3:], ns, "est")
    path = tmp_path / f"out{suffix}"
    assert write_trajectory_bag(path, tr, "/estimate", "map") == path
    assert bag_topics(path) == {"/estimate": "geometry_msgs/msg/PoseStamped"}
    back = read_bag_trajectory(f"{path}:/estimate")
    np.testing.assert_array_equal(back.stamps_ns, ns)
    np.testing.assert_array_equal(back.positions, tr.positions)
    np.testing.assert_array_equal(back.quats, tr.quats)
    ref = deserialized(path, "/estimate")
    assert [t for t, _ in ref] == ns.tolist()
    assert {msg.header.frame_id for _, msg in ref} == {"map"}
    np.testing.assert_array_equal([[msg.pose.position.x, msg.pose.orientation.w] for _, msg in ref], vals[:, [0, 6]])
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_trajectory_bag(path, tr, "/estimate", "map")
    write_trajectory_bag(path, tr.take(np.arange(10)), "/estimate", "map", overwrite=True)
    assert len(read_bag_trajectory(f"{path}:/estimate")) == 10
    with pytest.raises(ValueError, match="does not match"):
        write_trajectory_bag(tmp_path / f"x{suffix}", tr, ros_version=2 if suffix == ".bag" else 1)


def test_write_without_ns_stamps_and_bad_arguments(tmp_path):
    tr = Trajectory([1.5, 2.25], np.zeros((2, 3)), [[0, 0, 0, 1], [0, 0, 1, 0]])
    write_trajectory_bag(tmp_path / "a.mcap", tr)
    np.testing.assert_array_equal(read_bag_trajectory(f"{tmp_path / 'a.mcap'}:/pose").stamps_ns,
                                  [1_500_000_000, 2_250_000_000])  # fmt: skip
    with pytest.raises(ValueError, match=r"\.bag \(ROS 1\), \.db3 or \.mcap"):
        write_trajectory_bag(tmp_path / "a.csv", tr)
    with pytest.raises(ValueError, match="topic must be a str starting with '/'"):
        write_trajectory_bag(tmp_path / "b.bag", tr, "pose")
    with pytest.raises(TypeError, match="trajectory"):
        write_trajectory_bag(tmp_path / "b.bag", np.zeros((2, 8)))


@pytest.fixture(scope="module")
def mixed_bag(tmp_path_factory) -> Path:
    """A ROS 1 bag with poses out of order and duplicated, and an IMU topic."""
    m = _Msgs(True)
    path = tmp_path_factory.mktemp("bags") / "mixed.bag"
    q = [0, 0, 0, 1]
    heads = [T0, T0 + 10, T0 + 5, T0 + 20, T0 + 20]
    poses = [(T0 + 100 * k, m.make("geometry_msgs/msg/PoseStamped", h, "w", [k, 0, 0, *q]))
             for k, h in enumerate(heads)]  # fmt: skip
    dup = [(T0 + 100 * k, m.make("geometry_msgs/msg/PoseStamped", T0 + [0, 1, 1][k], "w", [k, 0, 0, *q]))
           for k in range(3)]  # fmt: skip
    imu = [(T0 + k, m.make("sensor_msgs/msg/Imu", T0 + k, "imu", np.ones(6))) for k in range(3)]
    write_bag(path, {"/unsorted": ("geometry_msgs/msg/PoseStamped", poses),
                     "/dup": ("geometry_msgs/msg/PoseStamped", dup), "/imu": ("sensor_msgs/msg/Imu", imu)})  # fmt: skip
    return path


def test_errors_name_bag_and_topic(mixed_bag):
    with pytest.raises(BagError, match=r"mixed\.bag: no topic /nope; topics in the bag: /dup \(geometry_msgs/PoseSt"
                                       r"amped\), /imu \(sensor_msgs/Imu\), /unsorted"):  # fmt: skip
        read_bag_trajectory(f"{mixed_bag}:/nope")
    with pytest.raises(BagError, match=r"/imu: message type sensor_msgs/Imu does not hold poses"):
        read_bag_trajectory(f"{mixed_bag}:/imu")
    with pytest.raises(BagError, match=r"/unsorted: message type geometry_msgs/PoseStamped does not hold IMU"):
        read_bag_imu(f"{mixed_bag}:/unsorted")
    with pytest.raises(BagError, match=r"name the topic of the poses: .*mixed\.bag:/TOPIC; topics in the bag"):
        read_bag_trajectory(str(mixed_bag))
    with pytest.raises(BagError, match=r"/unsorted: header stamps must be strictly increasing; message 2 has an "
                                       r"earlier stamp than message 1 .*--bag-time receive"):  # fmt: skip
        read_bag_trajectory(f"{mixed_bag}:/unsorted")
    with pytest.raises(BagError, match=r"/dup: header stamps .* message 2 has the same stamp as message 1"):
        read_bag_trajectory(f"{mixed_bag}:/dup")
    assert len(read_bag_trajectory(f"{mixed_bag}:/unsorted", stamps="receive")) == 5
    raw = read_bag_trajectory(f"{mixed_bag}:/dup", strict=False)
    np.testing.assert_array_equal(raw.stamps_ns, [T0, T0 + 1, T0 + 1])
    with pytest.raises(BagError, match=r"no /tf or /tf_static topic"):
        read_bag_trajectory(f"{mixed_bag}:/tf:a:b")
    with pytest.raises(FileNotFoundError, match="no such bag"):
        read_bag_trajectory(f"{mixed_bag.with_name('missing.bag')}:/x")
    with pytest.raises(ValueError, match="stamps must be 'header' or 'receive'"):
        read_bag_trajectory(f"{mixed_bag}:/dup", stamps="recv")


def test_not_a_bag(tmp_path):
    for name, data, message in (
        ("broken.bag", b"#ROSBAG V2.0\nthis is not a bag", r"broken\.bag: no bag header record"),
        ("old.bag", b"#ROSBAG V1.2\n", r"old\.bag: not a ROS 1 bag of format 2\.0"),
        ("empty.bag", b"", r"empty\.bag: not a ROS 1 bag"),
        ("broken.mcap", b"not an mcap file at all", r"broken\.mcap: cannot read the bag"),
    ):
        (tmp_path / name).write_bytes(data)
        with pytest.raises(BagError, match=message):
            read_bag_trajectory(f"{tmp_path / name}:/x")


@pytest.mark.parametrize("compression", ["bz2", "lz4"])
def test_compressed_ros1_chunks_and_two_connections_on_one_topic(tmp_path, rng, compression):
    """ROS 1 chunks compressed with bz2 / lz4, small chunks, and two connections (publishers) on one topic whose
    messages interleave in time: the poses in receive-time order, as rosbags' reader gives them."""
    from rosbags.rosbag1 import Writer

    m = _Msgs(True)
    path = tmp_path / f"c_{compression}.bag"
    n = 300
    vals = _values(rng, n)
    recv = T0 + rng.permutation(n).astype(np.int64) * 1000
    writer = Writer(path)
    writer.set_compression(getattr(Writer.CompressionFormat, compression.upper()))
    writer.chunk_threshold = 2000  # many chunks
    with writer:
        a = writer.add_connection("/pose", "geometry_msgs/msg/PoseStamped", typestore=m.store, callerid="/a")
        b = writer.add_connection("/pose", "geometry_msgs/msg/PoseStamped", typestore=m.store, callerid="/b")
        for k in np.argsort(recv):
            msg = m.make("geometry_msgs/msg/PoseStamped", recv[k], "w" * (k % 3), vals[k])
            writer.write(a if k % 2 else b, int(recv[k]), m.serialize(msg, "geometry_msgs/msg/PoseStamped"))
    ref = deserialized(path, "/pose")
    tr = read_bag_trajectory(f"{path}:/pose", stamps="receive")
    np.testing.assert_array_equal(tr.stamps_ns, [t for t, _ in ref])
    np.testing.assert_array_equal(tr.positions[:, 0], [msg.pose.position.x for _, msg in ref])
    np.testing.assert_array_equal(tr.quats[:, 3], [msg.pose.orientation.w for _, msg in ref])
    np.testing.assert_array_equal(tr.stamps_ns, np.sort(recv))


def test_a_type_with_the_standard_name_but_another_layout_is_refused(tmp_path):
    """A ROS 1 connection whose definition (md5sum) is not the standard geometry_msgs/PoseStamped's is refused
    rather than misread, even when its messages are long enough to parse; a too short one is refused too."""
    from rosbags.rosbag1 import Writer

    text = "std_msgs/Header header\nfloat64[7] x"
    path = tmp_path / "odd.bag"
    with Writer(path) as writer:
        msgdef = text + "\n" + "=" * 80 + "\nMSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n"
        conn = writer.add_connection("/pose", "geometry_msgs/msg/PoseStamped", msgdef=msgdef, md5sum="0" * 32)
        writer.write(conn, T0, bytes(4 + 8 + 4 + 56))
        short = writer.add_connection("/short", "geometry_msgs/msg/PoseStamped", msgdef=msgdef, md5sum="0" * 32)
        writer.write(short, T0, bytes(4 + 8 + 4 + 4))
    with pytest.raises(BagError, match=r"odd\.bag:/pose: the geometry_msgs/PoseStamped messages do not have the "
                                       r"standard layout \(md5sum 0{32}"):  # fmt: skip
        read_bag_trajectory(f"{path}:/pose")
    with pytest.raises(BagError, match=r"odd\.bag:/short: message 0 is shorter than a geometry_msgs/PoseStamped"):
        read_bag_trajectory(f"{path}:/short")


def test_parse_bag_source(tmp_path):
    assert parse_bag_source("traj.tum") is None
    assert parse_bag_source("dir/run.bag:/pose") == BagSource(Path("dir/run.bag"), "/pose")
    assert parse_bag_source("run.MCAP:/a/b") == BagSource(Path("run.MCAP"), "/a/b")
    assert parse_bag_source("run.db3") == BagSource(Path("run.db3"), None)
    assert parse_bag_source("r.bag:/tf:/world:base_link") == BagSource(Path("r.bag"), "/tf", "world", "base_link")
    assert str(parse_bag_source("r.bag:/tf:world:base")) == "r.bag:/tf:world:base"
    d = tmp_path / "ros2bag"
    d.mkdir()
    (d / "metadata.yaml").write_text("x")
    assert parse_bag_source(f"{d}:/imu") == BagSource(d, "/imu")
    assert parse_bag_source(str(tmp_path)) is None
    with pytest.raises(BagError, match="BAG:/tf:PARENT:CHILD"):
        parse_bag_source("r.bag:/tf:world")
    with pytest.raises(BagError, match="BAG:/tf:PARENT:CHILD"):
        parse_bag_source("r.bag:/pose:a:b")


def test_recording_reads_imu_and_ground_truth_from_bags(tmp_path):
    """A recording's sensor file may name bag topics (files.imu, files.groundtruth): the same recording as from
    its CSV files."""
    import json

    from dualpose import sim
    from dualpose.io import read_recording, write_recording

    rec = sim.recording_from_simulation(sim.simulate_eight(1, time_offset=0.0))
    out = tmp_path / "rec"
    write_recording(out, rec)
    csv = read_recording(out)
    write_imu_bag(out / "run.bag", "/imu0", csv.stamps_ns, csv.gyro, csv.accel)
    gt = csv.ground_truth
    write_trajectory_bag(out / "gt.mcap", Trajectory(gt.stamps, gt.positions, gt.quats, gt.stamps_ns), "/vicon")
    sensors = json.loads((out / "sensors.json").read_text())
    sensors["files"].update(imu="run.bag:/imu0", groundtruth="gt.mcap:/vicon", bag_time="receive")
    (out / "sensors.json").write_text(json.dumps(sensors))
    bag = read_recording(out)
    np.testing.assert_array_equal(bag.stamps_ns, csv.stamps_ns)
    np.testing.assert_array_equal(bag.gyro, csv.gyro)
    np.testing.assert_array_equal(bag.accel, csv.accel)
    np.testing.assert_array_equal(bag.ground_truth.quats, gt.quats)
    np.testing.assert_array_equal(bag.ground_truth.stamps_ns, gt.stamps_ns)
    sensors["files"]["imu"] = "run.bag:/imu"
    (out / "sensors.json").write_text(json.dumps(sensors))
    from dualpose.io import RecordingError

    with pytest.raises(RecordingError, match=r"run\.bag: no topic /imu; topics in the bag: /imu0 \(sensor_msgs/Imu\)"):
        read_recording(out)


def test_ros2_bag_directory(tmp_path, rng):
    """A ROS 2 bag directory (metadata.yaml and its storage files), as ros2 bag record writes it."""
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2

    m = _Msgs(False)
    vals = _values(rng, 20)
    ns = T0 + np.arange(20) * 1_000_000
    with Writer2(tmp_path / "rec", version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=m.store)
        for t, v in zip(ns.tolist(), vals, strict=True):
            writer.write(conn, t, m.serialize(m.make("nav_msgs/msg/Odometry", t, "odom", v), "nav_msgs/msg/Odometry"))
    tr = read_bag_trajectory(f"{tmp_path / 'rec'}:/odom")
    np.testing.assert_array_equal(tr.positions, vals[:, :3])
    np.testing.assert_array_equal(tr.stamps_ns, ns)
    assert bag_topics(tmp_path / "rec") == {"/odom": "nav_msgs/msg/Odometry"}
