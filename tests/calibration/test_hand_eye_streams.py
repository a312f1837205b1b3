"""Pose-stream cleaning, interpolation, the pose-file reader and the coarse rate-correlation offset."""

from __future__ import annotations

import numpy as np
import pytest
from handeye_sim import simulate, write_rows

import dualpose as dp
from dualpose.calibration import clean_pose_stream, coarse_time_offset, interpolate_stream
from dualpose.io.pose_csv import read_pose_csv


def _rows(n: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    t = np.arange(n) * 0.1
    return t, rng.normal(size=(n, 3)), dp.quat_from_rotvec(0.1 * np.arange(n)[:, None] * np.array([0.0, 0.0, 1.0]))


def test_sort_exact_duplicates_and_sign_equivalence():
    t, p, q = _rows()
    order = np.array([3, 0, 5, 1, 4, 2, 1, 4])  # unsorted, rows 1 and 4 repeated
    qq = q[order].copy()
    qq[6] *= -1.0  # the repeat of row 1 with the opposite quaternion sign is still the same row
    s, rep = clean_pose_stream(t[order], p[order], qq)
    assert not rep.was_sorted and rep.exact_duplicates == 2 and rep.merged_stamps == 0 and rep.rows_out == 6
    np.testing.assert_array_equal(s.stamps, t)
    np.testing.assert_allclose(s.positions, p)
    assert np.all(np.einsum("ij,ij->i", s.quats[1:], s.quats[:-1]) >= 0)  # continuous signs
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", s.quats, q)), 1.0, atol=1e-12)


def test_conflicting_stamp_is_averaged_independent_of_order():
    t, p, q = _rows()
    p2 = p[2] + [0.01, 0.0, 0.0]
    q2 = dp.quat_mul(dp.quat_from_rotvec([0.02, 0.0, 0.0]), q[2])
    a, rep_a = clean_pose_stream(np.r_[t, t[2]], np.vstack([p, p2]), np.vstack([q, q2]))
    b, _ = clean_pose_stream(np.r_[t[2], t], np.vstack([p2, p]), np.vstack([q2, q]))
    assert rep_a.merged_stamps == 1 and len(a) == 6
    np.testing.assert_allclose(a.positions[2], (p[2] + p2) / 2)
    assert dp.quat_angle(a.quats[2], dp.quat_mul(dp.quat_from_rotvec([0.01, 0.0, 0.0]), q[2])) < 1e-9
    np.testing.assert_allclose(a.positions, b.positions)
    np.testing.assert_allclose(a.quats, b.quats)


def test_cleaning_errors():
    t, p, q = _rows(3)
    with pytest.raises(ValueError, match="need at least 3"):
        clean_pose_stream(np.zeros(3), p, q, "cam.csv", min_rows=3)
    q[1] = 0.0
    with pytest.raises(ValueError, match="zero quaternion"):
        clean_pose_stream(t, p, q)


def test_interpolation_slerp_linear_and_gaps():
    t = np.array([0.0, 1.0, 2.0, 10.0])
    p = np.array([[0.0, 0, 0], [1, 0, 0], [1, 2, 0], [0, 0, 0]])
    q = dp.quat_from_rotvec(np.array([[0.0, 0, 0], [0, 0, 1.0], [0, 0, 1.0], [0, 0, 0]]))
    s, _ = clean_pose_stream(t, p, q)
    pos, quat, ok = interpolate_stream(s, [0.0, 0.25, 1.5, 5.0, -0.1, 2.0], max_gap=1.5)
    np.testing.assert_allclose(pos[:3], [[0, 0, 0], [0.25, 0, 0], [1, 1, 0]], atol=1e-12)
    assert dp.quat_angle(quat[1], dp.quat_from_rotvec([0, 0, 0.25])) < 1e-12
    assert ok.tolist() == [True, True, True, False, False, True]  # 5.0 lies in an 8 s gap; -0.1 before the start


def test_reader_formats_and_errors(tmp_path):
    rows = np.array([[1.0, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 1.0], [1.5, 0.4, 0.5, 0.6, 0.0, 0.0, 1.0, 0.0]])
    for sep in (", ", " ", "\t"):
        f = tmp_path / "poses.csv"
        write_rows(f, rows, sep)
        t, p, q = read_pose_csv(f)
        np.testing.assert_array_equal(np.column_stack([t, p, q]), rows)
    bad = tmp_path / "bad.csv"
    bad.write_text("# header\n1, 0, 0, 0, 0, 0, 0, 1\n2, 0, 0, x, 0, 0, 0, 1\n")
    with pytest.raises(ValueError, match=r"bad\.csv:3: .*'x' is not a number"):
        read_pose_csv(bad)
    short = tmp_path / "short.csv"
    short.write_text("1, 0, 0, 0, 0, 0, 0, 1\n2, 0, 0, 0, 0, 0, 1\n")
    with pytest.raises(ValueError, match=r"short\.csv:2: expected 8 fields"):
        read_pose_csv(short)
    with pytest.raises(FileNotFoundError, match="missing.csv"):
        read_pose_csv(tmp_path / "missing.csv")


@pytest.mark.parametrize("tau", [3600.0123, -0.04])
def test_coarse_offset_finds_hours_and_milliseconds(tau):
    rec = simulate(tau, seed=5)
    cam, _ = clean_pose_stream(rec.camera[:, 0], rec.camera[:, 1:4], rec.camera[:, 4:])
    body, _ = clean_pose_stream(rec.body[:, 0], rec.body[:, 1:4], rec.body[:, 4:])
    c = coarse_time_offset(cam, body)
    assert abs(c.offset - tau) < 0.01 and c.correlation > 0.8
