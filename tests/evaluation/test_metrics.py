"""Trajectory metrics on analytic cases: known transforms, perfect data, brute-force association."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from dualpose.evaluation.align import align_positions, umeyama_alignment
from dualpose.evaluation.metrics import (
    associate,
    ate_errors,
    error_statistics,
    evaluate,
    orientation_errors_deg,
    rpe_errors,
    rpe_pairs,
)
from dualpose.types import Trajectory
from dualpose.types.trajectory import interpolate_poses


def _smooth_trajectory(rng: np.random.Generator, n: int = 400) -> Trajectory:
    """A wiggly 3-D path with varying orientation, stamped at 50 Hz."""
    t = np.arange(n) / 50.0
    w = rng.uniform(0.2, 1.5, size=(3, 3))
    pos = np.stack([np.sin(w[k, 0] * t + w[k, 1]) * w[k, 2] * 2 + 0.1 * t for k in range(3)], axis=1)
    rotvec = np.stack([0.8 * np.sin(w[k, 1] * t + k) for k in range(3)], axis=1)
    q = Rotation.from_rotvec(rotvec).as_quat()  # scipy: xyzw, like dualpose
    return Trajectory(1.6e9 + t, pos, q, name="truth")


def _similarity(rng: np.random.Generator, scale: float) -> tuple[Rotation, np.ndarray, float]:
    return Rotation.random(random_state=rng.integers(1 << 31)), rng.normal(size=3) * 5, scale


def _transformed(traj: Trajectory, rot: Rotation, trans: np.ndarray, scale: float) -> Trajectory:
    pos = scale * rot.apply(traj.positions) + trans
    q = (rot * Rotation.from_quat(traj.quats)).as_quat()
    return Trajectory(traj.stamps, pos, q, name="estimate")


# ------------------------------------------------------------------------------------------------ alignment


@pytest.mark.parametrize("with_scale", [False, True])
def test_umeyama_recovers_a_known_transform(rng, with_scale):
    src = rng.normal(size=(50, 3))
    rot, trans, scale = _similarity(rng, 2.5 if with_scale else 1.0)
    dst = scale * rot.apply(src) + trans
    a = umeyama_alignment(src, dst, with_scale=with_scale)
    np.testing.assert_allclose(a.rotation, rot.as_matrix(), atol=1e-13)
    np.testing.assert_allclose(a.translation, trans, atol=1e-12)
    assert a.scale == pytest.approx(scale, abs=1e-13)
    assert np.linalg.det(a.rotation) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(a.matrix[:3, :3], scale * rot.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(a.apply(src, np.tile([0, 0, 0, 1.0], (50, 1)))[0], dst, atol=1e-12)


def test_umeyama_never_returns_a_reflection(rng):
    src = rng.normal(size=(30, 3)) * [3.0, 2.0, 0.5]  # flat enough that the best rotation is determined
    dst = src * [1.0, 1.0, -1.0]  # a mirror image: the best proper rotation is not the identity mirror
    a = umeyama_alignment(src, dst)
    assert np.linalg.det(a.rotation) == pytest.approx(1.0, abs=1e-14)
    # it is the least-squares optimum among rotations: no random rotation does better
    best = np.sum((dst - src @ a.rotation.T - a.translation) ** 2)
    for r in Rotation.random(200, random_state=1).as_matrix():
        c = dst.mean(0) - r @ src.mean(0)
        assert np.sum((dst - src @ r.T - c) ** 2) >= best - 1e-9


def test_umeyama_rejects_degenerate_and_bad_input(rng):
    line = np.outer(np.linspace(0, 1, 10), [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="degenerate"):
        umeyama_alignment(line, line + 1)
    with pytest.raises(ValueError, match="at least 3"):
        umeyama_alignment(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"source must have shape \(N, 3\)"):
        umeyama_alignment(np.zeros((5, 2)), np.zeros((5, 2)))
    with pytest.raises(ValueError, match="target must have the same shape"):
        umeyama_alignment(np.zeros((5, 3)), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="finite"):
        umeyama_alignment(np.full((5, 3), np.nan), np.zeros((5, 3)))
    with pytest.raises(ValueError, match="method must be"):
        align_positions(np.zeros((5, 3)), np.zeros((5, 3)), "affine")  # type: ignore[arg-type]
    none = align_positions(np.zeros((5, 3)), np.ones((5, 3)), "none")
    assert none.scale == 1.0 and np.array_equal(none.rotation, np.eye(3)) and not none.translation.any()


# ------------------------------------------------------------------------------------------------ perfect data


@pytest.mark.parametrize("align", ["se3", "sim3"])
def test_perfect_estimate_in_another_frame_has_zero_error(rng, align):
    truth = _smooth_trajectory(rng)
    rot, trans, scale = _similarity(rng, 0.37 if align == "sim3" else 1.0)
    est = _transformed(truth, rot.inv(), -rot.inv().apply(trans) / scale, 1.0 / scale)
    ev = evaluate(truth, est, align=align, rpe_delta=5)
    assert ev.ate.max() < 1e-12
    assert ev.orientation_deg.max() < 1e-9
    assert ev.rpe_translation.max() < 1e-12
    assert ev.rpe_rotation_deg.max() < 1e-9
    assert ev.alignment.scale == pytest.approx(scale, rel=1e-12)
    np.testing.assert_allclose(ev.alignment.rotation, rot.as_matrix(), atol=1e-12)
    d = ev.as_dict()
    assert d["ate_rmse_m"] < 1e-12 and d["matched_poses"] == len(truth) and d["rpe_pairs"] == (len(truth) - 1) // 5


def test_rpe_is_invariant_to_a_rigid_change_of_world_frame_without_alignment(rng):
    truth = _smooth_trajectory(rng)
    rot, trans, _ = _similarity(rng, 1.0)
    ev = evaluate(truth, _transformed(truth, rot, trans, 1.0), align="none", rpe_delta=0.3, rpe_unit="m")
    assert ev.ate.min() > 1e-3  # not aligned: large absolute error
    assert ev.rpe_translation.max() < 1e-12 and ev.rpe_rotation_deg.max() < 1e-9


def test_known_errors_constant_offset_scale_and_rotation(rng):
    truth = _smooth_trajectory(rng)
    offset = np.array([0.3, -0.4, 1.2])
    shifted = Trajectory(truth.stamps, truth.positions + offset, truth.quats)
    ev = evaluate(truth, shifted, align="none")
    np.testing.assert_allclose(ev.ate, np.linalg.norm(offset), rtol=1e-14)  # ATE = |offset| everywhere
    assert ev.rpe_translation.max() < 1e-12  # a constant offset cancels in relative motion
    # twice as large: RPE translation error = length of each step (the estimate moves 2 d, the truth d)
    doubled = Trajectory(truth.stamps, 2.0 * truth.positions, truth.quats)
    ev = evaluate(truth, doubled, align="none", rpe_delta=3)
    steps = np.linalg.norm(
        truth.positions[3::3][: len(ev.rpe_pairs)] - truth.positions[0:-3:3][: len(ev.rpe_pairs)], axis=1
    )
    np.testing.assert_allclose(ev.rpe_translation, steps, rtol=1e-12)
    # the Sim(3) alignment removes exactly that scale
    assert evaluate(truth, doubled, align="sim3").alignment.scale == pytest.approx(0.5, rel=1e-13)
    # orientation rotated by a constant 2 degrees about the body z axis: orientation error 2 degrees at every pose
    body = Rotation.from_rotvec([0.0, 0.0, np.deg2rad(2.0)])
    turned = Trajectory(truth.stamps, truth.positions, (Rotation.from_quat(truth.quats) * body).as_quat())
    ev = evaluate(truth, turned, align="none")
    np.testing.assert_allclose(ev.orientation_deg, 2.0, rtol=1e-10)
    assert ev.ate.max() == 0.0


def test_rpe_errors_against_4x4_matrices(rng):
    truth = _smooth_trajectory(rng, 60)
    noisy_p = truth.positions + 0.01 * rng.normal(size=truth.positions.shape)
    noisy_q = (Rotation.from_quat(truth.quats) * Rotation.from_rotvec(0.02 * rng.normal(size=(60, 3)))).as_quat()
    pairs = rpe_pairs(noisy_p, 4)
    t_err, r_err = rpe_errors(truth.positions, truth.quats * 3.0, noisy_p, -noisy_q, pairs)  # scale/sign-free

    def mat(p, q):
        m = np.tile(np.eye(4), (len(p), 1, 1))
        m[:, :3, :3] = Rotation.from_quat(q).as_matrix()
        m[:, :3, 3] = p
        return m

    mq, mp = mat(truth.positions, truth.quats), mat(noisy_p, noisy_q)
    i, j = pairs[:, 0], pairs[:, 1]
    e = np.linalg.inv(np.linalg.inv(mq[i]) @ mq[j]) @ (np.linalg.inv(mp[i]) @ mp[j])
    np.testing.assert_allclose(t_err, np.linalg.norm(e[:, :3, 3], axis=1), rtol=1e-10)
    np.testing.assert_allclose(r_err, np.degrees(Rotation.from_matrix(e[:, :3, :3]).magnitude()), rtol=1e-9)


# ------------------------------------------------------------------------------------------------ pairs


def _consecutive_by_path_reference(p: np.ndarray, delta: float) -> list[tuple[int, int]]:
    """The greedy definition, written as the obvious loop (test oracle)."""
    ids, run = [0], 0.0
    for k in range(1, len(p)):
        run += np.linalg.norm(p[k] - p[k - 1])
        if run >= delta:
            ids.append(k)
            run = 0.0
    return list(zip(ids[:-1], ids[1:], strict=True))


@pytest.mark.parametrize("delta", [0.05, 0.5, 2.0, 1000.0])
def test_rpe_pairs_by_path_length_match_the_greedy_loop(rng, delta):
    p = np.cumsum(rng.uniform(0.0, 0.05, size=(500, 3)), axis=0)
    got = [tuple(x) for x in rpe_pairs(p, delta, "m").tolist()]
    assert got == _consecutive_by_path_reference(p, delta)


def test_rpe_pairs_frames_and_all_pairs(rng):
    p = rng.normal(size=(10, 3))
    assert rpe_pairs(p, 3).tolist() == [[0, 3], [3, 6], [6, 9]]
    assert rpe_pairs(p, 4, all_pairs=True).tolist() == [[i, i + 4] for i in range(6)]
    assert rpe_pairs(p, 20).shape == (0, 2)
    line = np.outer(np.arange(11.0), [1.0, 0, 0])  # unit steps along x
    assert rpe_pairs(line, 3.0, "m", all_pairs=True).tolist() == [[i, i + 3] for i in range(8)]
    assert rpe_pairs(line, 2.5, "m", all_pairs=True, rel_tol=0.1).shape == (0, 2)  # 2 or 3 m: 0.5 m off > 0.25
    assert rpe_pairs(line, 2.5, "m", all_pairs=True, rel_tol=0.2).tolist() == [
        [i, i + 2] for i in range(9)
    ]  # tie -> nearer index
    for bad, unit in ((0, "frames"), (1.5, "frames"), (0.0, "m"), (-1.0, "m")):
        with pytest.raises(ValueError, match="delta must be"):
            rpe_pairs(p, bad, unit)
    with pytest.raises(ValueError, match="unit must be"):
        rpe_pairs(p, 1, "s")  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------------------ association


def _associate_brute_force(ref, est, max_diff, offset):
    est = est + offset
    short, long, swap = (ref, est, False) if len(est) > len(ref) else (est, ref, True)
    a, b = [], []
    for k, s in enumerate(short):
        d = np.abs(long - s)
        j = int(np.argmin(d))  # first of equal distances: the earlier stamp when long is sorted
        if d[j] <= max_diff:
            a.append(k)
            b.append(j)
    return (b, a) if swap else (a, b)


@given(
    st.lists(st.integers(0, 400), min_size=1, max_size=40),
    st.lists(st.integers(0, 400), min_size=1, max_size=40),
    st.integers(0, 30),
    st.integers(-20, 20),
)
def test_association_equals_brute_force_nearest(ref_ms, est_ms, max_diff_ms, offset_ms):
    # millisecond grids on binary-exact values (multiples of 1/1024 s) so that ties are real ties
    ref = np.unique(np.array(ref_ms)) / 1024.0
    est = np.unique(np.array(est_ms)) / 1024.0
    want = _associate_brute_force(ref, est, max_diff_ms / 1024.0, offset_ms / 1024.0)
    if not want[0]:
        with pytest.raises(ValueError, match="no matching timestamps"):
            associate(ref, est, max_diff_ms / 1024.0, offset_ms / 1024.0)
        return
    got = associate(ref, est, max_diff_ms / 1024.0, offset_ms / 1024.0)
    assert got[0].tolist() == want[0] and got[1].tolist() == want[1]


def test_association_basics_and_errors():
    ref = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.5])
    est = np.array([0.104, 0.309, 0.5, 0.9])  # shorter: every est stamp looks for its nearest ref stamp
    i_ref, i_est = associate(ref, est, max_diff=0.01)
    assert i_ref.tolist() == [1, 3, 5] and i_est.tolist() == [0, 1, 2]
    i_ref, i_est = associate(ref, est - 0.2, max_diff=0.01, offset=0.2)  # offset undoes a clock shift
    assert i_ref.tolist() == [1, 3, 5]
    # unsorted longer sequence: sorted internally, indices refer to the original order
    perm = np.array([3, 0, 5, 1, 4, 2])
    i_ref, i_est = associate(ref[perm], est, max_diff=0.01)
    assert perm[i_ref].tolist() == [1, 3, 5]
    with pytest.raises(ValueError, match="no matching timestamps"):
        associate(ref, est + 100.0)
    with pytest.raises(ValueError, match="max_diff must be"):
        associate(ref, est, max_diff=-1.0)
    with pytest.raises(ValueError, match=r"stamps_est must have shape \(N,\)"):
        associate(ref, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="stamps_ref must be finite"):
        associate(np.array([np.nan]), est)


# ------------------------------------------------------------------------------------------------ statistics


def test_error_statistics_by_hand():
    s = error_statistics([3.0, 4.0, 0.0, 5.0])
    assert s.rmse == pytest.approx(np.sqrt(50.0 / 4)) and s.mean == 3.0 and s.median == 3.5
    assert s.std == pytest.approx(np.sqrt(((0 - 3) ** 2 + 0 + 1 + 4) / 4)) and s.min == 0.0 and s.max == 5.0
    assert s.sse == 50.0 and s.n == 4
    with pytest.raises(ValueError, match=r"errors must have shape \(K,\)"):
        error_statistics([])
    with pytest.raises(ValueError, match="errors must be finite"):
        error_statistics([1.0, np.nan])


def test_per_pose_error_functions_validate_input():
    with pytest.raises(ValueError, match="matched arrays must have the same length"):
        ate_errors(np.zeros((3, 3)), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="positions_est must be finite"):
        ate_errors(np.zeros((3, 3)), np.full((3, 3), np.inf))
    with pytest.raises(ValueError, match="quats_ref must be finite"):
        orientation_errors_deg(np.full((2, 4), np.nan), np.tile([0, 0, 0, 1.0], (2, 1)))
    with pytest.raises(ValueError, match="zero"):
        orientation_errors_deg(np.zeros((2, 4)), np.tile([0, 0, 0, 1.0], (2, 1)))
    with pytest.raises(ValueError, match=r"quats_est must have shape \(N, 4\)"):
        orientation_errors_deg(np.tile([0, 0, 0, 1.0], (2, 1)), np.zeros((2, 3)))
    q = np.tile([0, 0, 0, 1.0], (3, 1))
    with pytest.raises(ValueError, match="pairs must be an integer array"):
        rpe_errors(np.zeros((3, 3)), q, np.zeros((3, 3)), q, np.array([[0.0, 1.0]]))
    with pytest.raises(ValueError, match="pairs must index 0..2"):
        rpe_errors(np.zeros((3, 3)), q, np.zeros((3, 3)), q, np.array([[0, 3]]))
    with pytest.raises(TypeError, match="reference must be a dualpose.io.Trajectory"):
        evaluate(np.zeros(3), np.zeros(3))  # type: ignore[arg-type]
    truth = Trajectory(np.arange(5.0), np.eye(5, 3) * 3, np.tile([0, 0, 0, 1.0], (5, 1)))
    with pytest.raises(ValueError, match="gives no pose pair"):
        evaluate(truth, truth, align="none", rpe_delta=10)


def test_origin_scale_only_and_first_n_alignment(rng):
    truth = _smooth_trajectory(rng)
    rot, trans, _ = _similarity(rng, 1.0)
    moved = _transformed(truth, rot, trans, 1.0)
    ev = evaluate(truth, moved, align="origin")
    assert ev.ate.max() < 1e-12 and ev.orientation_deg.max() < 1e-9  # a rigid change of frame: origin undoes it
    np.testing.assert_allclose(ev.alignment.rotation, rot.inv().as_matrix(), atol=1e-12)
    # scale only: a uniformly scaled copy (same frame) comes back exactly, and nothing is rotated or shifted
    ev = evaluate(truth, Trajectory(truth.stamps, 3.0 * truth.positions, truth.quats), align="scale")
    assert ev.alignment.scale == pytest.approx(1.0 / 3.0, rel=1e-13) and ev.ate.max() < 1e-12
    assert np.array_equal(ev.alignment.rotation, np.eye(3)) and not ev.alignment.translation.any()
    # first n: drift after pose 100 does not affect the alignment, which is then exact on the first 100 poses
    drifted = truth.positions.copy()
    drifted[100:] += np.outer(np.arange(len(truth) - 100) * 1e-3, [1.0, 0.5, 0.0])
    est = _transformed(Trajectory(truth.stamps, drifted, truth.quats), rot, trans, 1.0)
    ev = evaluate(truth, est, align="se3", align_first_n=100)
    assert ev.ate[:100].max() < 1e-12 and ev.ate[-1] > 0.1
    assert evaluate(truth, est, align="se3").ate[:100].max() > 1e-3  # aligned on everything: spread out
    with pytest.raises(ValueError, match="align_first_n must be"):
        evaluate(truth, est, align_first_n=0)


def test_interpolate_poses_on_a_screw_motion():
    # constant velocity along x and constant rate about z: linear + slerp interpolation is exact
    t = np.array([0.0, 1.0, 2.0, 2.0, 4.0])
    pos = np.outer(t, [1.0, 0.0, 0.0])
    q = Rotation.from_rotvec(np.outer(t, [0.0, 0.0, 0.3])).as_quat()
    at = np.array([-1.0, 0.25, 1.5, 2.0, 3.0, 3.9, 9.0])
    p_i, q_i = interpolate_poses(t, pos, q * 2.0, at)  # scale-free in the quaternions
    clamped = np.clip(at, 0.0, 4.0)
    np.testing.assert_allclose(p_i[:, 0], clamped, atol=1e-15)
    np.testing.assert_allclose(Rotation.from_quat(q_i).as_rotvec()[:, 2], 0.3 * clamped, atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(q_i, axis=1), 1.0, atol=1e-15)
    with pytest.raises(ValueError, match="sorted"):
        interpolate_poses(t[::-1], pos, q, at)
    with pytest.raises(ValueError, match="N >= 2"):
        interpolate_poses(t[:1], pos[:1], q[:1], at)


def test_interpolated_sync_removes_the_time_quantisation_error(rng):
    truth = _smooth_trajectory(rng, 800)  # 50 Hz truth; the estimate is the truth itself, sampled between its stamps
    at = truth.stamps[10:-10:7] + 0.009  # 9 ms after a truth stamp: nearest-neighbour pairs it 9 ms off
    p, q = interpolate_poses(truth.stamps, truth.positions, truth.quats, at)
    est = Trajectory(at, p, q)
    near = evaluate(truth, est, align="none", max_diff=0.012)
    interp = evaluate(truth, est, align="none", max_diff=0.012, sync="interpolate")
    assert near.ate.max() > 1e-3 and interp.ate.max() < 1e-12 and interp.orientation_deg.max() < 1e-9
    np.testing.assert_array_equal(interp.stamps, at)
    with pytest.raises(ValueError, match="sync must be"):
        evaluate(truth, est, sync="linear")  # type: ignore[arg-type]
