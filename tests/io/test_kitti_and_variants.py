"""KITTI pose files, comma-separated TUM, trailing comments, detection messages and argument types."""

from __future__ import annotations

import numpy as np
import pytest
from evo.tools import file_interface

import dualpose as dp
from dualpose.io import Trajectory, detect_format, read_kitti, read_trajectory, read_tum, write_kitti, write_tum


def _traj(n: int = 40, seed: int = 0) -> Trajectory:
    rng = np.random.default_rng(seed)
    q = dp.quat_normalize(rng.normal(size=(n, 4)))
    return Trajectory(np.arange(n) * 0.1, rng.normal(size=(n, 3)), q, name="t")


def test_kitti_round_trip_and_evo_agrees(tmp_path):
    tr = _traj()
    path = tmp_path / "poses.txt"
    write_kitti(path, tr)
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_kitti(path, tr)
    assert detect_format(path) == "kitti"
    back = read_trajectory(path)
    np.testing.assert_array_equal(back.stamps, np.arange(40.0))  # no times file: the pose index, seconds
    np.testing.assert_allclose(back.positions, tr.positions, atol=1e-15)
    assert np.all(dp.quat_angle(back.quats, tr.quats) < 1e-14)
    evo = file_interface.read_kitti_poses_file(str(path))
    np.testing.assert_allclose(evo.positions_xyz, back.positions, atol=1e-15)
    assert np.all(dp.quat_angle(back.quats, evo.orientations_quat_wxyz[:, [1, 2, 3, 0]]) < 1e-12)
    times = tmp_path / "times.txt"
    times.write_text("\n".join(f"{t:.6e}" for t in tr.stamps) + "\n")
    np.testing.assert_array_equal(read_kitti(path, times).stamps, np.round(tr.stamps, 7))
    np.testing.assert_array_equal(read_trajectory(path, times=times).stamps, read_kitti(path, times).stamps)
    times.write_text("0\n1\n")
    with pytest.raises(ValueError, match=r"times.txt: 2 stamps for the 40 poses"):
        read_kitti(path, times)


def test_kitti_rounded_files_read_and_reflections_refused_with_the_line(tmp_path):
    tr = _traj(5, 1)
    r = dp.matrix_from_quat(tr.quats)
    rows = np.concatenate([r, tr.positions[:, :, None]], axis=2).reshape(-1, 12)
    path = tmp_path / "k.txt"
    path.write_text("\n".join(" ".join(f"{v:e}" for v in row) for row in rows) + "\n")  # 7 digits, as KITTI
    assert np.all(dp.quat_angle(read_kitti(path).quats, tr.quats) < 1e-5)
    rows[3, 8:11] *= -1  # third row of R negated: a reflection
    path.write_text("# kitti\n" + "\n".join(" ".join(f"{v:.17g}" for v in row) for row in rows) + "\n")
    with pytest.raises(ValueError, match=r"k\.txt:5: the rotation block is not a rotation matrix \(det = -1"):
        read_kitti(path)


def test_comma_tum_and_trailing_comments(tmp_path):
    tr = _traj(10, 2)
    plain = tmp_path / "plain.txt"
    write_tum(plain, tr)
    lines = plain.read_text().splitlines()
    comma = tmp_path / "comma.txt"
    comma.write_text("\n".join([lines[0]] + [ln.replace(" ", ", ") + "  # pose" for ln in lines[1:]]) + "\n")
    assert detect_format(comma) == "tum"  # the header decides; without it integer stamps would look like EuRoC
    no_header = tmp_path / "nh.txt"
    no_header.write_text("\n".join(ln.replace(" ", ",") for ln in lines[2:]) + "\n")  # stamps 0.1, 0.2, ...
    assert detect_format(no_header) == "tum"
    a, b = read_tum(plain), read_trajectory(comma)
    np.testing.assert_array_equal(a.stamps, b.stamps)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.quats, b.quats)
    commented = tmp_path / "c.txt"
    commented.write_text("\n".join([lines[0]] + [ln + " # from the tracker" for ln in lines[1:]]) + "\n")
    np.testing.assert_array_equal(read_trajectory(commented).positions, a.positions)


def test_detection_failure_lists_the_formats(tmp_path):
    path = tmp_path / "x.txt"
    path.write_text("1 2 3 4 5\n")
    with pytest.raises(ValueError, match=r"x\.txt:1: cannot tell the file format .*TUM.*KITTI.*EuRoC"):
        detect_format(path)


@pytest.mark.parametrize("bad", [None, 3, b"x.txt"])
def test_non_path_arguments_are_type_errors(bad):
    with pytest.raises(TypeError, match=r"^path must be a str or os.PathLike file path; got "):
        read_trajectory(bad)
    with pytest.raises(TypeError, match=r"^path must be a str or os.PathLike"):
        read_tum(bad)
    with pytest.raises(TypeError, match=r"^path must be a str or os.PathLike"):
        detect_format(bad)


def test_times_of_the_wrong_type(tmp_path):
    path = tmp_path / "k.txt"
    write_kitti(path, _traj(3))
    with pytest.raises(TypeError, match=r"^times must be a str or os.PathLike file path; got int"):
        read_kitti(path, 3)
