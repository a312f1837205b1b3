"""TUM / EuRoC readers and writers: the real files in ../shared/data/tum, round trips, and bad-file errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dualpose.io import (
    ImuData,
    Trajectory,
    detect_format,
    read_euroc_groundtruth,
    read_euroc_imu,
    read_trajectory,
    read_tum,
    seconds_from_ns,
    write_euroc_groundtruth,
    write_euroc_imu,
    write_tum,
)
from realdata import data_dir

DATA = data_dir("tum")


@pytest.fixture(scope="module")
def data_dir() -> Path:
    if not DATA.is_dir():
        pytest.skip(f"data directory {DATA} missing")
    return DATA


def _lines(path: Path) -> list[str]:
    return [ln for ln in path.read_text().splitlines() if ln.strip() and not ln.lstrip().startswith("#")]


# ---------------------------------------------------------------- real files


def test_tum_groundtruth_file_matches_text(data_dir):
    path = data_dir / "fr2_desk_groundtruth.txt"
    traj = read_tum(path)
    lines = _lines(path)
    assert len(traj) == len(lines) == 20957  # 20960 lines minus the 3 comment lines
    # first and last rows, field by field from the text (independent of the parser)
    for k in (0, -1):
        f = [float(x) for x in lines[k].split()]
        assert traj.stamps[k] == f[0]
        np.testing.assert_array_equal(traj.positions[k], f[1:4])
        np.testing.assert_array_equal(traj.quats[k], f[4:8])  # TUM is already xyzw: no reordering
    assert traj.stamps_ns is None
    assert traj.name == str(path)


def test_euroc_groundtruth_file_keeps_nanoseconds_and_reorders_quaternion(data_dir):
    path = data_dir / "V102_groundtruth.csv"
    traj = read_euroc_groundtruth(path)
    lines = _lines(path)
    assert len(traj) == len(lines)
    assert traj.stamps_ns.dtype == np.int64
    for k in (0, 1, len(lines) // 2, -1):
        f = lines[k].split(",")
        assert int(traj.stamps_ns[k]) == int(f[0])  # exact, all 19 digits
        np.testing.assert_array_equal(traj.positions[k], [float(x) for x in f[1:4]])
        w, x, y, z = (float(v) for v in f[4:8])
        np.testing.assert_array_equal(traj.quats[k], [x, y, z, w])  # wxyz in the file -> xyzw
        np.testing.assert_array_equal(traj.extra["velocity"][k], [float(v) for v in f[8:11]])
        np.testing.assert_array_equal(traj.extra["gyro_bias"][k], [float(v) for v in f[11:14]])
        np.testing.assert_array_equal(traj.extra["accel_bias"][k], [float(v) for v in f[14:17]])
    assert traj.stamps_ns[0] == 1403715524907143168
    # 200 Hz: 5 ms steps, exactly representable in ns
    assert set(np.diff(traj.stamps_ns[:100]).tolist()) <= {4999936, 5000192, 4999680, 5000000, 5000448}


def test_detect_format_on_the_real_files(data_dir):
    assert detect_format(data_dir / "fr2_desk_ORB.txt") == "tum"
    assert detect_format(data_dir / "fr2_desk_groundtruth.txt") == "tum"
    assert detect_format(data_dir / "V102.txt") == "tum"
    assert detect_format(data_dir / "V102_groundtruth.csv") == "euroc_groundtruth"
    assert len(read_trajectory(data_dir / "V102_groundtruth.csv")) == 16702


def test_same_values_as_evo_readers(data_dir):
    file_interface = pytest.importorskip("evo.tools.file_interface")
    for name in ("fr2_desk_ORB.txt", "V102.txt"):
        ours = read_tum(data_dir / name)
        ref = file_interface.read_tum_trajectory_file(str(data_dir / name))
        np.testing.assert_array_equal(ours.stamps, ref.timestamps)
        np.testing.assert_array_equal(ours.positions, ref.positions_xyz)
    ours = read_euroc_groundtruth(data_dir / "V102_groundtruth.csv")
    ref = file_interface.read_euroc_csv_trajectory(str(data_dir / "V102_groundtruth.csv"))
    np.testing.assert_array_equal(ours.positions, ref.positions_xyz)
    np.testing.assert_array_equal(ours.quats[:, [3, 0, 1, 2]], ref.orientations_quat_wxyz)  # evo keeps wxyz
    # evo rounds the 19-digit ns to float64 first; ours splits seconds and ns: within one float64 ulp of 1.4e9
    assert np.abs(ours.stamps - ref.timestamps).max() <= np.spacing(1.4e9)


# ---------------------------------------------------------------- round trips


def _random_motion(rng: np.random.Generator, n: int = 50, ns: bool = False) -> Trajectory:
    stamps_ns = np.int64(1_403_715_524_907_143_168) + np.cumsum(rng.integers(1, 10_000_000, n)).astype(np.int64)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    extra = {k: rng.normal(size=(n, 3)) for k in ("velocity", "gyro_bias", "accel_bias")} if ns else {}
    return Trajectory(seconds_from_ns(stamps_ns), rng.normal(size=(n, 3)) * 10, q, stamps_ns if ns else None, "", extra)


def test_tum_round_trip_is_exact(tmp_path, rng):
    traj = _random_motion(rng)
    write_tum(tmp_path / "a.txt", traj)
    back = read_tum(tmp_path / "a.txt")
    np.testing.assert_array_equal(back.stamps, traj.stamps)
    np.testing.assert_array_equal(back.positions, traj.positions)
    np.testing.assert_array_equal(back.quats, traj.quats)
    assert (tmp_path / "a.txt").read_text().startswith("# timestamp tx ty tz qx qy qz qw\n")


def test_tum_written_from_nanoseconds_keeps_them_in_the_text(tmp_path, rng):
    traj = _random_motion(rng, ns=True)
    write_tum(tmp_path / "a.txt", traj, header=False)
    first = (tmp_path / "a.txt").read_text().splitlines()[0].split()[0]
    whole, frac = divmod(int(traj.stamps_ns[0]), 10**9)
    assert first == f"{whole}.{frac:09d}"
    np.testing.assert_array_equal(read_tum(tmp_path / "a.txt").stamps, traj.stamps)


def test_euroc_groundtruth_round_trip_is_exact(tmp_path, rng):
    traj = _random_motion(rng, ns=True)
    write_euroc_groundtruth(tmp_path / "gt.csv", traj)
    assert detect_format(tmp_path / "gt.csv") == "euroc_groundtruth"
    back = read_euroc_groundtruth(tmp_path / "gt.csv")
    np.testing.assert_array_equal(back.stamps_ns, traj.stamps_ns)
    np.testing.assert_array_equal(back.quats, traj.quats)
    np.testing.assert_array_equal(back.positions, traj.positions)
    for k in traj.extra:
        np.testing.assert_array_equal(back.extra[k], traj.extra[k])
    # the file stores w first
    row = (tmp_path / "gt.csv").read_text().splitlines()[1].split(",")
    assert float(row[4]) == traj.quats[0, 3] and float(row[5]) == traj.quats[0, 0]
    # without the extra columns: 8 columns
    short = Trajectory(traj.stamps, traj.positions, traj.quats, traj.stamps_ns)
    write_euroc_groundtruth(tmp_path / "gt8.csv", short)
    assert len((tmp_path / "gt8.csv").read_text().splitlines()[1].split(",")) == 8
    assert read_euroc_groundtruth(tmp_path / "gt8.csv").extra == {}


def test_euroc_imu_round_trip_is_exact(tmp_path, rng):
    ns = np.int64(1_403_715_524_907_143_168) + np.arange(0, 200 * 5_000_000, 5_000_000, dtype=np.int64)
    imu = ImuData(ns, seconds_from_ns(ns), rng.normal(size=(200, 3)), rng.normal(size=(200, 3)) + [0, 0, 9.81])
    write_euroc_imu(tmp_path / "imu.csv", imu)
    assert detect_format(tmp_path / "imu.csv") == "euroc_imu"
    back = read_euroc_imu(tmp_path / "imu.csv")
    np.testing.assert_array_equal(back.stamps_ns, ns)
    np.testing.assert_array_equal(back.gyro, imu.gyro)
    np.testing.assert_array_equal(back.accel, imu.accel)
    assert len(back) == 200
    with pytest.raises(ValueError, match="IMU file"):
        read_trajectory(tmp_path / "imu.csv")


def test_seconds_from_ns_is_more_exact_than_dividing(rng):
    ns = np.int64(1_403_715_524_000_000_000) + rng.integers(0, 10**9, 1000)
    exact = [float(int(n) // 10**9) + (int(n) % 10**9) / 1e9 for n in ns]  # float sum of exact parts
    np.testing.assert_array_equal(seconds_from_ns(ns), exact)
    with pytest.raises(TypeError, match="integer"):
        seconds_from_ns(np.array([1.5]))


# ---------------------------------------------------------------- never overwrite


def test_writers_never_overwrite_unless_asked(tmp_path, rng):
    traj = _random_motion(rng, ns=True)
    target = tmp_path / "out.txt"
    target.write_text("precious\n")
    with pytest.raises(FileExistsError, match="out.txt"):
        write_tum(target, traj)
    with pytest.raises(FileExistsError, match="overwrite"):
        write_euroc_groundtruth(target, traj)
    assert target.read_text() == "precious\n"
    write_tum(target, traj, overwrite=True)
    assert len(read_tum(target)) == len(traj)


# ---------------------------------------------------------------- bad files: file name and line number


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("# c\n1 0 0 0 0 0 0 1\n2 0 0 0 0 0 1\n", r"bad\.txt:3: expected 8 fields"),
        ("1 0 0 0 0 0 0 1\n\n2 0 0 x 0 0 0 1\n", r"bad\.txt:3: .*'x' is not a number"),
        ("1 0 0 0 0 0 0 1\n2 0 0 nan 0 0 0 1\n", r"bad\.txt:2: .*non-finite"),
        ("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 0\n", r"bad\.txt:2: zero quaternion"),
        ("# only a comment\n\n", r"bad\.txt: no data rows"),
    ],
)
def test_bad_tum_file_names_file_and_line(tmp_path, text, message):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_tum(path)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("#h\n1,0,0,0,1,0,0,0\n2,0,0,0,1,0,0\n", r"bad\.csv:3: expected 8 to 17 fields"),
        ("#h\n1,0,0,0,1,0,0,0\n2.5,0,0,0,1,0,0,0\n", r"bad\.csv:3: timestamp \[ns\]: '2.5' is not an integer"),
        ("#h\n1,0,0,0,1,0,0,0\n99999999999999999999,0,0,0,1,0,0,0\n", r"bad\.csv:3: .*does not fit in int64"),
        ("1,0,0,0,1,0,0,0\n2,0,0,0,1,0,0,0,0\n", r"bad\.csv:2: expected 8 fields like the first row"),
        ("1,0,0,0,1,0,0,0,0,0\n", r"bad\.csv:1: expected 8 or 17 fields"),
        ("1,0,0,0,0,0,0,0\n", r"bad\.csv:1: zero quaternion"),
        ("1,0,0,0,1,0,0,inf\n", r"bad\.csv:1: .*non-finite"),
    ],
)
def test_bad_euroc_groundtruth_names_file_and_line(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_euroc_groundtruth(path)


def test_bad_euroc_imu_names_file_and_line(tmp_path):
    path = tmp_path / "imu.csv"
    path.write_text("#timestamp\n1,0,0,0,0,0,9.8\n2,0,0,0,0,0\n")
    with pytest.raises(ValueError, match=r"imu\.csv:3: expected 7 fields"):
        read_euroc_imu(path)
    path.write_text("1,0,0,0,0,0,9.8\n2,0,zero,0,0,0,9.8\n")
    with pytest.raises(ValueError, match=r"imu\.csv:2: .*'zero' is not a number"):
        read_euroc_imu(path)


def test_detect_format_rejects_unknown_content_with_line(tmp_path):
    path = tmp_path / "x.txt"
    path.write_text("# header\n\n1 2 3\n")
    with pytest.raises(ValueError, match=r"x\.txt:3: cannot tell the file format"):
        detect_format(path)
    path.write_text("# nothing\n")
    with pytest.raises(ValueError, match="no data lines"):
        detect_format(path)
    with pytest.raises(FileNotFoundError):
        detect_format(tmp_path / "missing.txt")
    path.write_text("1 0 0 0 0 0 0 1\n")
    with pytest.raises(ValueError, match="fmt must be"):
        read_trajectory(path, "g2o")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="expected 12 fields"):  # KITTI is a format now: 8 fields do not fit it
        read_trajectory(path, "kitti")


def test_crlf_and_bom_and_tabs_are_accepted(tmp_path):
    path = tmp_path / "w.txt"
    path.write_bytes(b"\xef\xbb\xbf# t x y z qx qy qz qw\r\n1.5\t1 2 3 0 0 0 1\r\n")
    traj = read_tum(path)
    assert traj.stamps.tolist() == [1.5] and traj.positions.tolist() == [[1.0, 2.0, 3.0]]


def test_trajectory_validates_shapes():
    with pytest.raises(ValueError, match=r"positions must have shape \(N, 3\)"):
        Trajectory(np.zeros(2), np.zeros((3, 3)), np.tile([0, 0, 0, 1.0], (2, 1)))
    with pytest.raises(ValueError, match=r"quats must have shape"):
        Trajectory(np.zeros(2), np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="quats must be nonzero; pose index 1"):
        Trajectory(np.zeros(2), np.zeros((2, 3)), np.array([[0, 0, 0, 1.0], [0, 0, 0, 0]]))
    with pytest.raises(ValueError, match="positions must be finite; first bad pose index 1"):
        Trajectory(np.zeros(2), np.array([[0, 0, 0], [0, np.nan, 0]]), np.tile([0, 0, 0, 1.0], (2, 1)))
    t = Trajectory(np.arange(3.0), np.zeros((3, 3)), np.tile([0, 0, 0, 1.0], (3, 1)), np.arange(3) * 1_000_000_000)
    sub = t.take([2, 0])
    assert sub.stamps.tolist() == [2.0, 0.0] and sub.stamps_ns.tolist() == [2_000_000_000, 0]
