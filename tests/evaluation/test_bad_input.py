"""Degenerate alignments, unsorted / duplicated stamps, time windows and overflow in ``evaluate`` (docs/metrics.md)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from evo.core import geometry

import dualpose as dp
from dualpose.evaluation.align import align_positions, check_alignment_rank, umeyama_alignment
from dualpose.evaluation.metrics import evaluate, prepare_trajectory
from dualpose.types.trajectory import Trajectory


def _walk(n: int, seed: int) -> Trajectory:
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 6.0, n)
    p = np.column_stack([np.cos(s), np.sin(1.3 * s), 0.3 * s]) + rng.normal(0, 1e-3, (n, 3))
    q = dp.quat_from_rotvec(np.column_stack([0.1 * s, -0.2 * s, s]))
    return Trajectory(0.1 * np.arange(n), p, q, name="walk")


def _still(n: int, seed: int, at=(1.3, -0.7, 2.1)) -> Trajectory:
    rng = np.random.default_rng(seed)
    return Trajectory(0.1 * np.arange(n), np.tile(at, (n, 1)), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)) + 0 * rng.random())


@pytest.mark.parametrize("with_scale", [False, True])
def test_still_reference_is_refused_like_evo(with_scale):
    rng = np.random.default_rng(1)
    ref = np.tile([1.3, -0.7, 2.1], (300, 1))
    est = ref + rng.normal(0, 0.02, ref.shape)
    with pytest.raises(geometry.GeometryException, match="Degenerate covariance rank"):
        geometry.umeyama_alignment(est.T, ref.T, with_scale)
    with pytest.raises(ValueError, match="the target positions do not move"):
        umeyama_alignment(est, ref, with_scale)
    with pytest.raises(ValueError, match="the reference positions do not move"):
        align_positions(ref, est, "sim3" if with_scale else "se3")


def test_still_estimate_and_collinear_points_are_refused():
    rng = np.random.default_rng(2)
    line = np.outer(np.linspace(0, 5, 200), [1.0, 2.0, -0.5]) + [1e3, 0, 0]
    with pytest.raises(ValueError, match="the estimate positions do not move"):
        align_positions(line, np.tile([4.0, 5.0, 6.0], (200, 1)), "sim3")
    with pytest.raises(ValueError, match="lie on a line"):
        align_positions(line, line + rng.normal(0, 0.01, line.shape), "se3")
    # evo's absolute test (singular values > eps) takes the rounding noise of the collinear reference as a
    # second direction and returns an arbitrary rotation about the line
    geometry.umeyama_alignment((line + rng.normal(0, 0.01, line.shape)).T, line.T, False)


def test_scale_aware_far_from_the_origin_and_tiny_but_real_motion_is_kept():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(100, 3))
    r = dp.matrix_from_quat(dp.quat_normalize([0.2, -0.1, 0.4, 0.9]))
    for scale, offset in ((1e-6, 0.0), (1.0, 1e6), (1e3, 0.0)):
        src = scale * x + offset
        dst = src @ r.T + [1.0, 2.0, 3.0]
        check_alignment_rank(src, dst)
        a = umeyama_alignment(src, dst)
        np.testing.assert_allclose(a.rotation, r, atol=1e-6)
        ev_r, _, _ = geometry.umeyama_alignment(src.T, dst.T, False)
        np.testing.assert_allclose(a.rotation, ev_r, atol=1e-6)
    # rounding-level spread at 1 km: refused, whatever the relative cross-covariance says
    still = np.full((50, 3), 1000.0) + rng.normal(0, 1e-13, (50, 3))
    with pytest.raises(ValueError, match="do not move"):
        check_alignment_rank(still, x[:50])


def test_evaluate_refuses_a_still_reference_instead_of_a_perfect_score():
    ref = _still(300, 4)
    est = Trajectory(ref.stamps, ref.positions + np.random.default_rng(4).normal(0, 0.05, (300, 3)), ref.quats)
    for align in ("se3", "sim3", "scale"):
        with pytest.raises(ValueError, match="reference positions do not move"):
            evaluate(ref, est, align=align)
    ev = evaluate(ref, est, align="none")  # nothing to align: a meaningful number
    assert 0.05 < ev.ate_stats.rmse < 0.12


def test_unsorted_estimate_is_sorted_with_a_warning_and_gives_the_sorted_result():
    ref, est = _walk(400, 5), _walk(400, 6)
    order = np.random.default_rng(7).permutation(400)
    shuffled = est.take(order)
    with pytest.warns(UserWarning, match="not in increasing order; sorted"):
        ev = evaluate(ref, shuffled)
    sorted_ev = evaluate(ref, est)
    assert ev.rpe_translation_stats.rmse == pytest.approx(sorted_ev.rpe_translation_stats.rmse, rel=1e-12)
    assert ev.ate_stats.rmse == pytest.approx(sorted_ev.ate_stats.rmse, rel=1e-12)


def test_duplicate_rows_dropped_and_shared_stamps_warned_or_refused():
    ref, est = _walk(200, 8), _walk(200, 9)
    dup = est.take(np.sort(np.concatenate([np.arange(200), np.arange(0, 200, 4)])))
    with pytest.warns(UserWarning, match="dropped 50 exact duplicate pose"):
        ev = evaluate(ref, dup)
    clean = evaluate(ref, est)
    assert ev.rpe_pairs.shape == clean.rpe_pairs.shape
    assert ev.rpe_translation_stats.min == clean.rpe_translation_stats.min > 0.0
    one = Trajectory(np.where(np.arange(200) == 11, est.stamps[10], est.stamps), est.positions, est.quats, name="e")
    with pytest.warns(UserWarning, match=r"stamp 1\.0 s has different poses"):
        prepare_trajectory(one, "estimate")
    same = Trajectory(np.zeros(200), est.positions, est.quats, name="e.txt")
    with pytest.raises(ValueError, match=r"estimate \(e\.txt\): stamp 0\.0 s has different poses.*do not identify"):
        evaluate(ref, same)
    many = Trajectory(np.repeat(est.stamps[::2], 2), est.positions, est.quats)
    with pytest.raises(ValueError, match="100 of 200 poses share a stamp"):
        evaluate(ref, many)


def test_time_window():
    ref, est = _walk(300, 10), _walk(300, 11)
    ev = evaluate(ref, est, t_start=5.0, t_end=20.0)
    assert ev.stamps.min() >= 5.0 and ev.stamps.max() <= 20.0 and len(ev.ate) == 151
    with pytest.raises(ValueError, match="t_start must be < t_end"):
        evaluate(ref, est, t_start=3.0, t_end=3.0)
    with pytest.raises(ValueError, match=r"reference \(walk\) has no pose in \[t_start, t_end\]"):
        evaluate(ref, est, t_start=100.0)


def test_huge_coordinates_and_empty_trajectories_give_clear_errors():
    ref, est = _walk(50, 12), _walk(50, 13)
    big = Trajectory(ref.stamps, ref.positions * 1e300, ref.quats, name="big.txt")
    with pytest.raises(ValueError, match=r"reference \(big\.txt\): position coordinates up to .*overflow"):
        evaluate(big, est)
    empty = Trajectory(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 4)))
    assert len(empty) == 0
    with pytest.raises(ValueError, match="estimate has no poses"):
        evaluate(ref, empty)


def test_quat_mean_with_nan_is_a_value_error():
    q = np.tile([0.0, 0.0, 0.0, 1.0], (4, 1))
    q[2, 1] = np.nan
    with pytest.raises(ValueError, match="quats contains NaN"):
        dp.quat_mean(q)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="weights contains NaN"):
            dp.quat_mean(np.tile([0.0, 0.0, 0.0, 1.0], (2, 1)), [1.0, np.nan])
