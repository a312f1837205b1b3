"""PnP (DLT + Gauss–Newton) against the truth and OpenCV; static alignment; body prior from the first frame."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose import sim
from dualpose.estimation import initialization
from dualpose.registration import pnp

cv2 = pytest.importorskip("cv2")


@pytest.fixture(scope="module")
def run() -> sim.SimulatedRun:
    return sim.simulate_eight(21, pixel_sigma=1.0)


def _truth_camera(run: sim.SimulatedRun, k: int) -> tuple[np.ndarray, np.ndarray]:
    kin = run.motion.kinematics(run.frames.t_true[k : k + 1])
    q_wc = dp.quat_mul(kin["quat"][0], run.q_bc)
    return q_wc, kin["position"][0] + dp.quat_rotate(kin["quat"][0], run.p_bc)


def test_exact_correspondences_recover_pose() -> None:
    clean = sim.simulate_eight(2, pixel_sigma=0.0)
    for k in (0, 30, 60):
        pix, pts = clean.frames.frame(k)
        q_wc, c_w = _truth_camera(clean, k)
        R, t = pnp.pnp_dlt(pix, pts, clean.camera.matrix)  # linear stage alone is exact without noise
        np.testing.assert_allclose(R.T, dp.matrix_from_quat(q_wc), atol=1e-9)
        np.testing.assert_allclose(-R.T @ t, c_w, atol=1e-9)
        res = pnp.solve_pnp(pix, pts, clean.camera.matrix)
        assert dp.quat_angle(res.q_wc, q_wc) < 1e-10 and np.linalg.norm(res.c_w - c_w) < 1e-10


def test_noisy_pnp_matches_opencv_and_truth(run: sim.SimulatedRun) -> None:
    K = run.camera.matrix
    errs, covs = [], []
    for k in range(0, len(run.frames), 4):
        pix, pts = run.frames.frame(k)
        res = pnp.solve_pnp(pix, pts, K, pixel_sigma=1.0)
        ok, rvec, tvec = cv2.solvePnP(pts, pix, K, None, flags=cv2.SOLVEPNP_ITERATIVE)
        assert ok
        R_cv = cv2.Rodrigues(rvec)[0]
        # both minimise the same reprojection error: same minimum (OpenCV's LM stops a little earlier)
        # (agreement 1e-4 m / 1e-4 rad is 50x below the noise-driven error of ~5 mm / 0.2 deg)
        assert dp.quat_angle(res.q_wc, dp.quat_from_matrix(R_cv.T)) < 1e-4
        np.testing.assert_allclose(res.c_w, -R_cv.T @ tvec.ravel(), atol=1e-4)
        proj_cv = cv2.projectPoints(pts, rvec, tvec, K, None)[0].reshape(-1, 2)
        assert res.rms_px <= np.sqrt(np.mean((pix - proj_cv) ** 2)) + 1e-9
        q_wc, c_w = _truth_camera(run, k)
        d_theta = dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(res.q_wc), q_wc))
        errs.append(np.concatenate([d_theta, c_w - res.c_w]))
        covs.append(res.covariance)
    errs, covs = np.array(errs), np.array(covs)
    # normalized error squared (6 dof) averages near 6: the reported covariance is honest
    nees = np.einsum("ni,nij,nj->n", errs, np.linalg.inv(covs), errs)
    assert 3.0 < nees.mean() < 10.0
    assert np.sqrt(np.mean(np.sum(errs[:, 3:] ** 2, axis=1))) < 0.02


def test_static_alignment_and_body_prior(run: sim.SimulatedRun) -> None:
    rest = run.t < 0.9
    al = initialization.static_alignment(run.accel[rest], run.gyro[rest])
    q_true = run.truth["quat"][0]
    # tilt (angle between the true and estimated "up" in the body frame) within the accel-bias level
    up_est = dp.quat_rotate(dp.quat_conj(al.q_wb), [0, 0, 1.0])
    up_true = dp.quat_rotate(dp.quat_conj(q_true), [0, 0, 1.0])
    tilt = np.degrees(np.arccos(np.clip(up_est @ up_true, -1, 1)))
    assert tilt < 1.0
    np.testing.assert_allclose(al.gyro_bias, run.truth["gyro_bias"][0], atol=3e-3)
    # with a magnetometer the full attitude is found
    mrun = sim.simulate_eight(21, magnetometer_sigma=0.01)
    al2 = initialization.static_alignment(
        mrun.accel[rest], mrun.gyro[rest], mag=mrun.mag[rest], field_w=mrun.magnetic_field
    )
    assert np.degrees(dp.quat_angle(al2.q_wb, q_true)) < 1.5
    # body prior from PnP of the first frame
    pix, pts = run.frames.frame(0)
    p_wb, q_wb, cov = initialization.body_pose_from_camera(
        pnp.solve_pnp(pix, pts, run.camera.matrix), run.q_bc, run.p_bc
    )
    kin = run.motion.kinematics(run.frames.t_true[:1])
    e = np.concatenate(
        [kin["position"][0] - p_wb, dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(q_wb), kin["quat"][0]))]
    )
    assert e @ np.linalg.solve(cov, e) < 22.5  # χ²(6) 99.9 %


def test_pnp_bad_input() -> None:
    with pytest.raises(ValueError, match="at least 6"):
        pnp.solve_pnp(np.zeros((5, 2)), np.zeros((5, 3)), np.eye(3))
    with pytest.raises(ValueError, match="points must"):
        pnp.solve_pnp(np.zeros((8, 2)), np.zeros((7, 3)), np.eye(3))


def test_ransac_pnp_with_gross_outliers() -> None:
    run = sim.simulate_eight(8, outlier_fraction=0.25, pixel_sigma=1.0)
    f = run.frames
    for k in (0, 20, 50):
        pix, pts = f.frame(k)
        out = f.outlier[f.offsets[k] : f.offsets[k + 1]]
        res, inl = pnp.solve_pnp_ransac(pix, pts, run.camera.matrix)
        assert not np.any(inl & out)  # no gross outlier kept
        assert np.mean(inl[~out]) > 0.9
        q_wc, c_w = _truth_camera(run, k)
        e = np.concatenate([dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(res.q_wc), q_wc)), c_w - res.c_w])
        assert e @ np.linalg.solve(res.covariance, e) < 22.5  # χ²(6) 99.9 %: within its own covariance
        assert np.linalg.norm(res.c_w - c_w) < 0.08


def test_coplanar_points_use_the_homography_path() -> None:
    clean = sim.simulate_eight(2, pixel_sigma=0.0)
    for k in range(0, len(clean.frames), 3):
        pix, pts = clean.frames.frame(k)
        wall = np.abs(pts[:, 1]) < 1e-12  # landmarks on the wall plane y = 0
        if wall.sum() < 6:
            continue
        q_wc, c_w = _truth_camera(clean, k)
        R, t = pnp.pnp_dlt(pix[wall], pts[wall], clean.camera.matrix)
        np.testing.assert_allclose(R.T, dp.matrix_from_quat(q_wc), atol=1e-8)
        np.testing.assert_allclose(-R.T @ t, c_w, atol=1e-8)


def _padded(problems: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stack ``(pixels, points)`` problems into (B, M, ·) arrays padded with copies of the first row."""
    m = max(len(p) for p, _ in problems)
    pix, pts = np.zeros((len(problems), m, 2)), np.zeros((len(problems), m, 3))
    valid = np.zeros((len(problems), m), dtype=bool)
    for k, (p, x) in enumerate(problems):
        pix[k], pts[k] = p[0], x[0]
        pix[k, : len(p)], pts[k, : len(p)], valid[k, : len(p)] = p, x, True
    return pix, pts, valid


def _planar_and_general_problems(run: sim.SimulatedRun) -> list[tuple[np.ndarray, np.ndarray]]:
    """Frames of a noisy run: the wall plane alone (coplanar: the homography), the whole two-plane scene (the
    12-unknown DLT) and the wall with a few off-plane points (both candidates are tried)."""
    out = []
    for k in range(0, len(run.frames), 5):
        pix, pts = run.frames.frame(k)
        wall = np.abs(pts[:, 1]) < 1e-12
        if wall.sum() >= 8:
            out.append((pix[wall], pts[wall]))
            out.append((pix[wall | (np.cumsum(~wall) <= 2)], pts[wall | (np.cumsum(~wall) <= 2)]))
        out.append((pix, pts))
    return out


def test_batched_dlt_equals_one_problem_at_a_time(run: sim.SimulatedRun) -> None:
    problems = _planar_and_general_problems(run)
    pix, pts, valid = _padded(problems)
    K = run.camera.matrix
    R, t = pnp.pnp_dlt_batch(pix, pts, valid, K)
    for k, (p, x) in enumerate(problems):
        R1, t1 = pnp.pnp_dlt(p, x, K)  # the problem alone, no padding rows
        np.testing.assert_allclose(R[k], R1, atol=1e-11)
        np.testing.assert_allclose(t[k], t1, atol=1e-11)


def test_batched_pnp_on_planar_frames_equals_solve_pnp_and_opencv(run: sim.SimulatedRun) -> None:
    # a planar target (every problem takes the homography start): the batch against solve_pnp frame by frame and
    # against OpenCV's planar solver refined by its Levenberg–Marquardt
    problems = [(p, x) for p, x in _planar_and_general_problems(run) if np.all(np.abs(x[:, 1]) < 1e-12)]
    assert len(problems) >= 10
    pix, pts, valid = _padded(problems)
    K = run.camera.matrix
    batch = pnp.solve_pnp_batch(pix, pts, valid, K, threshold_px=50.0)
    for k, (p, x) in enumerate(problems):
        one = pnp.solve_pnp(p, x, K)
        assert dp.quat_angle(batch.q_wc[k], one.q_wc) < 1e-9
        np.testing.assert_allclose(batch.c_w[k], one.c_w, atol=1e-9)
        ok, rvec, tvec = cv2.solvePnP(x, p, K, None, flags=cv2.SOLVEPNP_IPPE)
        assert ok
        rvec, tvec = cv2.solvePnPRefineLM(x, p, K, None, rvec, tvec)
        R_cv = cv2.Rodrigues(rvec)[0]
        assert dp.quat_angle(batch.q_wc[k], dp.quat_from_matrix(R_cv.T)) < 1e-5
        np.testing.assert_allclose(batch.c_w[k], -R_cv.T @ tvec.ravel(), atol=1e-5)


def test_batched_dlt_names_the_degenerate_problem(run: sim.SimulatedRun) -> None:
    problems = _planar_and_general_problems(run)[:3]
    p, x = problems[0]
    line = np.column_stack([np.linspace(0, 1, len(x)), np.zeros(len(x)), np.zeros(len(x))])
    pix, pts, valid = _padded([*problems, (p, line)])
    with pytest.raises(ValueError, match=r"one line.*\(problem 3\)"):
        pnp.pnp_dlt_batch(pix, pts, valid, run.camera.matrix)
    pix[1, valid[1]] = pix[1, 0]
    pts[1, valid[1]] = pts[1, 0]
    with pytest.raises(ValueError, match=r"same world point.*\(problem 1\)"):
        pnp.pnp_dlt_batch(pix, pts, valid, run.camera.matrix)


def test_batched_pnp_loses_a_problem_to_nan_or_raises(run: sim.SimulatedRun) -> None:
    problems = [(p, x) for p, x in _planar_and_general_problems(run) if len(p) >= 12][:6]
    pix, pts, valid = _padded(problems)
    K = run.camera.matrix
    whole = pnp.solve_pnp_batch(pix, pts, valid, K, threshold_px=20.0)
    bad = pix.copy()
    keep = np.flatnonzero(valid[2])[:5]  # problem 2: all but 5 corners thrown 100 px off
    off = np.setdiff1d(np.flatnonzero(valid[2]), keep)
    bad[2, off] += np.random.default_rng(4).normal(0.0, 100.0, (len(off), 2))
    with pytest.raises(ValueError, match="fewer than 6"):
        pnp.solve_pnp_batch(bad, pts, valid, K, threshold_px=20.0)
    lost = pnp.solve_pnp_batch(bad, pts, valid, K, threshold_px=20.0, failed="nan")
    assert np.all(np.isnan(lost.q_wc[2])) and np.all(np.isnan(lost.c_w[2])) and np.isnan(lost.rms_px[2])
    assert np.all(np.isnan(lost.covariance[2])) and not lost.inliers[2].any()
    others = np.arange(len(problems)) != 2
    np.testing.assert_allclose(lost.q_wc[others], whole.q_wc[others], atol=1e-12)
    np.testing.assert_allclose(lost.c_w[others], whole.c_w[others], atol=1e-12)
    with pytest.raises(ValueError, match="failed must be"):
        pnp.solve_pnp_batch(pix, pts, valid, K, failed="skip")
