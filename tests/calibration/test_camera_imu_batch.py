"""Camera–IMU batch calibration (:mod:`dualpose.calibration.camera_imu`): recovery of a simulated rig with a
distorted camera within the predicted σ, input refusals, and the EuRoC imu_april recording against EuRoC's
published Kalibr extrinsics (Burri et al. 2016) on a cut of the recording (the full run:
benchmarks/calibrate_euroc.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dualpose as dp
from dualpose import sim
from dualpose.calibration._preintegration import imu_factors, preintegrate, size_effect_jacobian
from dualpose.calibration.camera_imu import calibrate_camera_imu
from dualpose.types.camera import FrameCorrespondences
from dualpose.types.camera_models import RadTanCamera
from dualpose.types.imu import ImuNoise
from realdata import data_dir

EUROC = data_dir("euroc/imu_april", full=True)

def _simulated(seed: int, pixel_sigma: float = 0.3, time_offset: float = 0.004):
    """The eight-shaped run at 200 Hz with its pinhole pixels re-projected through a radial–tangential camera."""
    cam = RadTanCamera(213.3, 213.3, 160.0, 120.0, -0.2, 0.05, 1e-3, -1e-3, 320, 240)
    noise = ImuNoise(update_rate=200.0)
    run = sim.simulate(sim.eight_motion(), seed=seed, imu_noise=noise, camera_rate=20, pixel_sigma=0.0,
                       landmarks_per_frame=40, time_offset=time_offset)  # fmt: skip
    f = run.frames
    K = run.camera.matrix
    xyz = np.column_stack([(f.pixels - K[:2, 2]) / np.diag(K)[:2], np.ones(len(f.pixels))])
    rng = np.random.default_rng(seed + 100)
    pixels = cam.project(xyz) + rng.normal(0.0, pixel_sigma, (len(xyz), 2))
    return run, cam, noise, FrameCorrespondences(f.t, f.offsets, pixels, f.points)


@pytest.fixture(scope="module")
def simulated():
    run, cam, noise, frames = _simulated(1)
    return run, calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, min_frames=20,
                                     imu_model="calibrated")  # fmt: skip


def test_simulated_rig_recovered_within_predicted_sigma(simulated):
    run, res = simulated
    cov = res.covariance
    # rotation error in the body frame: R̂ = Exp(ε) R_true
    eps = dp.so3_log(res.rotation_matrix @ dp.matrix_from_quat(run.q_bc).T)
    assert float(eps @ np.linalg.solve(cov[:3, :3], eps)) < 16.3  # χ²(3) 99.9 %
    dt = res.p_bc - run.p_bc
    assert float(dt @ np.linalg.solve(cov[3:6, 3:6], dt)) < 16.3
    assert abs(res.time_offset - run.time_offset) < 4 * res.std["time_offset_s"]
    g_err = np.degrees(np.arctan2(np.linalg.norm(np.cross(res.gravity_target, run.gravity)),
                                  res.gravity_target @ run.gravity))  # fmt: skip
    assert g_err < 4 * res.std["gravity_target_deg"]
    assert np.all(np.abs(res.gyro_bias - run.truth["gyro_bias"].mean(axis=0)) < 4 * res.std["gyro_bias"])
    assert abs(np.linalg.norm(res.gravity_target) - 9.81) < 1e-9
    assert res.reprojection_rms_px == pytest.approx(0.3, rel=0.1)
    # the batch improves on the rate-correlation start
    assert np.degrees(dp.quat_angle(res.q_bc, run.q_bc)) < np.degrees(dp.quat_angle(res.initial["q_bc"], run.q_bc))


def test_constant_bias_model_agrees(simulated):
    run, rw = simulated
    _, cam, noise, frames = _simulated(1)
    const = calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, min_frames=20, bias_model="constant",
                                 imu_model="calibrated")  # fmt: skip
    assert const.bias_track.shape == (1, 6)
    assert np.degrees(dp.quat_angle(const.q_bc, rw.q_bc)) < 3 * np.max(rw.std["rotation_deg"])
    assert np.all(np.abs(const.p_bc - rw.p_bc) < 3 * rw.std["translation_m"] + 1e-4)


def test_imu_axis_model_recovers_misaligned_imu():
    """A few ‰ of gyro scale/non-orthogonality and accelerometer misalignment bias the lever arm of the calibrated
    model by centimetres; the scale–misalignment model recovers the matrices within 4 σ and the extrinsic."""
    cam = RadTanCamera(213.3, 213.3, 160.0, 120.0, -0.2, 0.05, 1e-3, -1e-3, 320, 240)
    noise = ImuNoise(1e-4, 1e-5, 1e-3, 1e-4, 0.0, 0.0, 200.0)
    run = sim.simulate(sim.eight_motion(), seed=3, imu_noise=noise, camera_rate=20, pixel_sigma=0.0,
                       landmarks_per_frame=40)  # fmt: skip
    Mg = np.eye(3) + np.array([[2e-3, 1e-3, -5e-4], [1e-3, -1e-3, 2e-3], [-5e-4, 2e-3, 3e-3]])
    Ma = np.eye(3) + np.array([[3e-3, 2e-3, -1e-3], [-1e-3, -2e-3, 1e-3], [4e-3, 1e-3, 5e-3]])
    f = run.frames
    K = run.camera.matrix
    xyz = np.column_stack([(f.pixels - K[:2, 2]) / np.diag(K)[:2], np.ones(len(f.pixels))])
    pixels = cam.project(xyz) + np.random.default_rng(7).normal(0.0, 0.05, (len(xyz), 2))
    frames = FrameCorrespondences(f.t, f.offsets, pixels, f.points)
    args = (run.t, run.gyro @ Mg.T, run.accel @ Ma.T, frames, cam, noise)
    plain = calibrate_camera_imu(*args, min_frames=20, imu_model="calibrated")
    res = calibrate_camera_imu(*args, min_frames=20)
    sym = res.imu_axes[0] - Mg
    err = np.concatenate([np.diag(sym), sym[0, 1:], sym[1, 2:], (res.imu_axes[1] - Ma).ravel()])
    assert np.all(np.abs(err) < 4 * res.imu_axes_std)
    assert np.linalg.norm(res.p_bc - run.p_bc) < 0.3 * np.linalg.norm(plain.p_bc - run.p_bc)
    dt = res.p_bc - run.p_bc
    assert float(dt @ np.linalg.solve(res.covariance[3:6, 3:6], dt)) < 16.3


def test_motion_noise_model_on_a_sharp_run(simulated):
    """Without motion blur the fitted blur duration is negligible and the extrinsic is that of the uniform σ."""
    run, uniform = simulated
    _, cam, noise, frames = _simulated(1)
    res = calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, min_frames=20, imu_model="calibrated",
                               noise_model="motion")  # fmt: skip
    # white noise only: the fit finds 0.25 ms, i.e. κ |u̇| of a few hundredths of a pixel at this run's image
    # speeds, against σ₀ = 0.3 px
    assert res.blur_time_s < 5e-4
    assert res.pixel_sigma == pytest.approx(0.3, rel=0.1)
    assert np.degrees(dp.quat_angle(res.q_bc, uniform.q_bc)) < np.max(uniform.std["rotation_deg"])
    assert np.all(np.abs(res.p_bc - uniform.p_bc) < uniform.std["translation_m"])


def test_frame_noise_model_on_frames_of_unequal_noise():
    """Frames of very unequal noise (σ 0.1–1.2 px, log-uniform per frame, as blur and focus vary): the per-frame
    variance components weight them accordingly, so the extrinsic is within its (smaller) predicted σ, while one σ
    for every corner gives larger formal σ; on a run of equal noise the per-frame model changes nothing."""
    run, cam, noise, frames = _simulated(4, pixel_sigma=0.0)
    rng = np.random.default_rng(44)
    sig = np.exp(rng.uniform(np.log(0.1), np.log(1.2), len(frames.t)))
    per_corner = np.repeat(sig, np.diff(frames.offsets))
    pixels = frames.pixels + rng.normal(size=frames.pixels.shape) * per_corner[:, None]
    frames = FrameCorrespondences(frames.t, frames.offsets, pixels, frames.points)
    out = {m: calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, min_frames=20,
                                   imu_model="calibrated", noise_model=m) for m in ("uniform", "frame")}  # fmt: skip
    res = out["frame"]
    eps = dp.so3_log(res.rotation_matrix @ dp.matrix_from_quat(run.q_bc).T)
    dt = res.p_bc - run.p_bc
    assert float(eps @ np.linalg.solve(res.covariance[:3, :3], eps)) < 16.3  # χ²(3) 99.9 %
    assert float(dt @ np.linalg.solve(res.covariance[3:6, 3:6], dt)) < 16.3
    # weighted by their own σ, the frames carry more information than under one pooled σ
    assert np.all(res.std["translation_m"] < out["uniform"].std["translation_m"])
    assert np.all(res.std["rotation_deg"] < out["uniform"].std["rotation_deg"])


def test_frame_sigmas_recover_the_per_frame_noise():
    """The per-frame variance components of residuals with known σ per frame (a fitted pose absorbs 6 of the 2 n
    coordinates: residuals of a least-squares fit are drawn with that redundancy) on 60-corner frames, and a frame of
    8 corners pulled towards the recording's σ."""
    from dualpose.calibration.camera_imu import _frame_sigmas

    rng = np.random.default_rng(9)
    n_frames, m = 400, 60
    sig = np.exp(rng.uniform(np.log(0.1), np.log(1.2), n_frames))
    r = np.empty((n_frames, m, 2))
    for k in range(n_frames):  # residuals of a 6-parameter linear fit: (I − P) e
        A = rng.normal(size=(2 * m, 6))
        e = rng.normal(0.0, sig[k], 2 * m)
        r[k] = (e - A @ np.linalg.lstsq(A, e, rcond=None)[0]).reshape(m, 2)
    use = np.ones((n_frames, m), dtype=bool)
    est = _frame_sigmas(r, use, 0.4)
    # the estimate is the frame's σ pooled with the recording's (0.4 px, 6 coordinates' worth): within 25 % of that
    # for 90 % of the frames (the MAD of 120 coordinates scatters by 11 %: 2.3 of its σ), and ranked as the true σ
    expected = np.sqrt((114 * sig**2 + 6 * 0.4**2) / 120)
    assert np.mean(np.abs(est / expected - 1.0) < 0.25) > 0.9
    assert np.corrcoef(np.argsort(np.argsort(est)), np.argsort(np.argsort(sig)))[0, 1] > 0.95
    few = use.copy()
    few[:, 8:] = False
    est8 = _frame_sigmas(r, few, 0.4)
    own = 1.4826 * np.median(np.abs(r[:, :8]), axis=(1, 2)) * np.sqrt(16 / 10)  # the frame's own, 16 − 6 dof
    assert np.all((est8 >= np.minimum(own, 0.4) - 1e-12) & (est8 <= np.maximum(own, 0.4) + 1e-12))
    assert np.all(np.abs(est8 - 0.4) < np.abs(own - 0.4))
    none = use.copy()
    none[3] = False  # a frame whose corners were all rejected keeps the recording's σ
    assert _frame_sigmas(r, none, 0.4)[3] == pytest.approx(0.4, rel=1e-12)


def test_frame_noise_model_on_frames_of_equal_noise(simulated):
    """White noise of one σ: the per-frame model's extrinsic is that of the uniform σ to within half its σ."""
    run, uniform = simulated
    _, cam, noise, frames = _simulated(1)
    res = calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, min_frames=20, imu_model="calibrated",
                               noise_model="frame")  # fmt: skip
    assert res.pixel_sigma == pytest.approx(0.3, rel=0.1)
    assert np.degrees(dp.quat_angle(res.q_bc, uniform.q_bc)) < 0.5 * np.max(uniform.std["rotation_deg"])
    assert np.all(np.abs(res.p_bc - uniform.p_bc) < 0.5 * uniform.std["translation_m"])


def test_frame_pose_chi2_detects_a_camera_model_error():
    """The per-frame pose corrections' χ² (6 dof) stay below 6 when the camera model is right (each frame's own
    corners are in the batch's pose; a near noise-free IMU pins the trajectory) and grow by more than a third with
    a radial distortion off by 0.03 although the pixel σ, re-estimated, absorbs part of it."""
    cam = RadTanCamera(213.3, 213.3, 160.0, 120.0, -0.2, 0.05, 1e-3, -1e-3, 320, 240)
    noise = ImuNoise(1e-5, 1e-6, 1e-4, 1e-5, 0.0, 0.0, 200.0)
    run = sim.simulate(sim.eight_motion(), seed=5, imu_noise=noise, camera_rate=20, pixel_sigma=0.0,
                       landmarks_per_frame=40)  # fmt: skip
    f = run.frames
    K = run.camera.matrix
    xyz = np.column_stack([(f.pixels - K[:2, 2]) / np.diag(K)[:2], np.ones(len(f.pixels))])
    pixels = cam.project(xyz) + np.random.default_rng(8).normal(0.0, 0.3, (len(xyz), 2))
    frames = FrameCorrespondences(f.t, f.offsets, pixels, f.points)
    chi2 = []
    for c in (cam, dataclasses.replace(cam, k1=cam.k1 + 0.03)):
        res = calibrate_camera_imu(run.t, run.gyro, run.accel, frames, c, noise, min_frames=20,
                                   imu_model="calibrated")  # fmt: skip
        assert res.frame_pose_correction.shape == (res.frames_used, 6)
        assert res.frame_pose_chi2.shape == (res.frames_used,)
        chi2.append(float(np.mean(res.frame_pose_chi2)))
    assert 2.0 < chi2[0] < 6.0
    assert chi2[1] > 1.3 * chi2[0]


class _Captured(Exception):
    pass


def test_compiled_reprojection_blocks_equal_the_numpy_path(monkeypatch):
    """The compiled per-frame reprojection blocks (``_native.camera_imu_reprojection``) against the NumPy
    Jacobians of the same problem, with a time shift, per-corner σ and rejected corners."""
    import dualpose.calibration.camera_imu as ci

    run, cam, noise, frames = _simulated(2)
    box = {}

    def capture(prob, *args, **kwargs):
        box["prob"] = prob
        raise _Captured

    monkeypatch.setattr(ci, "_levenberg_marquardt", capture)
    with pytest.raises(_Captured):
        calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, min_frames=20)
    prob = box["prob"]
    assert prob.native
    rng = np.random.default_rng(5)
    prob.corner_scale = 1.0 + rng.random(prob.corner_scale.shape)
    prob.inlier[:, ::5] = False
    prob.tau = prob.tau_ref + 0.003
    out = {}
    for native in (True, False):
        prob.native = native
        H, g, cost = prob.normal_equations()
        out[native] = (H.D, H.U, H.B, H.C, g, cost, prob.cost())
    for a, b in zip(out[True], out[False], strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10 * np.max(np.abs(b)))


def test_block_tridiagonal_factor_solves_the_damped_system():
    from dualpose.calibration.camera_imu import _Normal

    rng = np.random.default_rng(1)
    n, s = 30, 15
    A = np.zeros((n * s, n * s))
    for i in range(n):
        X = rng.normal(size=(s, 2 * s))
        A[i * s : (i + 1) * s, i * s : (i + 1) * s] = X @ X.T
        if i + 1 < n:
            Y = 0.3 * rng.normal(size=(s, s))
            A[i * s : (i + 1) * s, (i + 1) * s : (i + 2) * s] = Y
            A[(i + 1) * s : (i + 2) * s, i * s : (i + 1) * s] = Y.T
    D = np.stack([A[i * s : (i + 1) * s, i * s : (i + 1) * s] for i in range(n)])
    U = np.stack([A[i * s : (i + 1) * s, (i + 1) * s : (i + 2) * s] for i in range(n - 1)])
    N = _Normal(D, U, np.zeros((n * s, 2)), np.eye(2), np.zeros(n * s + 2))
    b = rng.normal(size=(n * s, 3))
    F = N._factor_band(0.1)
    expected = np.linalg.solve(A + 0.1 * np.diag(np.diag(A)), b)
    np.testing.assert_allclose(N._solve_band(F, b), expected, atol=1e-12)
    np.testing.assert_allclose(N._solve_band(F, b[:, 0]), expected[:, 0], atol=1e-12)
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        _Normal(-D, U, np.zeros((n * s, 2)), np.eye(2), np.zeros(n * s + 2))._factor_band(0.0)


def test_refusals():
    run, cam, noise, frames = _simulated(2)
    with pytest.raises(ValueError, match="noise_model"):
        calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, noise_model="blur")
    with pytest.raises(ValueError, match="huber"):
        calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, huber=0.0)
    with pytest.raises(ValueError, match="imu_model must be one of .*'scale_misalignment_size_effect'"):
        calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, imu_model="full")
    for bad in (0.0, -1e-2, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="size_effect_prior_sigma must be a finite"):
            calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise,
                                 imu_model="scale_misalignment_size_effect", size_effect_prior_sigma=bad)  # fmt: skip
    with pytest.raises(ValueError, match="bias_model"):
        calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, bias_model="spline")
    late = FrameCorrespondences(frames.t + 1000.0, frames.offsets, frames.pixels, frames.points)
    with pytest.raises(ValueError, match="no time overlap"):
        calibrate_camera_imu(run.t, run.gyro, run.accel, late, cam, noise)
    with pytest.raises(ValueError, match="frames with >= 8 corners"):
        calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, min_frames=10_000)
    with pytest.raises(ValueError, match="gyro must be finite"):
        calibrate_camera_imu(run.t, run.gyro[:-1], run.accel, frames, cam, noise)
    with pytest.raises(TypeError, match="frames must be a FrameCorrespondences"):
        calibrate_camera_imu(run.t, run.gyro, run.accel, (frames.t, frames.pixels), cam, noise)
    with pytest.raises(ValueError, match="needs estimate_intrinsics"):
        calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, intrinsics_prior_sigma=np.ones(8))
    for bad in (np.ones(7), np.zeros(8), np.full(8, np.nan)):
        with pytest.raises(ValueError, match="intrinsics_prior_sigma must have shape"):
            calibrate_camera_imu(run.t, run.gyro, run.accel, frames, cam, noise, estimate_intrinsics=True,
                                 intrinsics_prior_sigma=bad)  # fmt: skip


def test_intrinsics_prior_holds_the_principal_point_and_recovers_the_distortion(simulated):
    """A camera handed over with k1 off by 0.03: with the fixed model the extrinsic is biased; refining the
    distortion with the focal lengths and the principal point held by the prior recovers k1 within 4 σ, keeps the
    held parameters at their values and the extrinsic within its χ² bound."""
    run, _ = simulated
    _, cam, noise, frames = _simulated(1)
    wrong = dataclasses.replace(cam, k1=cam.k1 + 0.03)
    args = (run.t, run.gyro, run.accel, frames, wrong, noise)
    fixed = calibrate_camera_imu(*args, min_frames=20, imu_model="calibrated")
    sigma = np.array([1e-3, 1e-3, 1e-3, 1e-3, np.inf, np.inf, np.inf, np.inf])
    res = calibrate_camera_imu(*args, min_frames=20, imu_model="calibrated", estimate_intrinsics=True,
                               intrinsics_prior_sigma=sigma)  # fmt: skip
    d = res.camera_parameters - cam.parameters
    assert np.all(np.abs(d[:4]) < 1e-2)  # held (σ 1e-3 px against the data's pull)
    assert np.all(np.abs(d[4:]) < 4 * res.camera_parameters_std[4:])  # k1..p2 back at the truth
    dt = res.p_bc - run.p_bc
    assert float(dt @ np.linalg.solve(res.covariance[3:6, 3:6], dt)) < 16.3
    eps = dp.so3_log(res.rotation_matrix @ dp.matrix_from_quat(run.q_bc).T)
    assert float(eps @ np.linalg.solve(res.covariance[:3, :3], eps)) < 16.3
    assert np.linalg.norm(fixed.p_bc - run.p_bc) > 3 * np.linalg.norm(dt)
    assert res.reprojection_rms_px < fixed.reprojection_rms_px


@pytest.fixture(scope="module")
def euroc_cut():
    if not EUROC.is_dir():
        pytest.skip(f"EuRoC imu_april data missing ({EUROC})")
    from dualpose.pipelines.calibrate_camera_imu import calibrate_camera_imu_files

    return {c: calibrate_camera_imu_files(str(EUROC / "imu0.csv"), str(EUROC / f"{c}_aprilgrid.csv"),
                                          str(EUROC / "sensors.yaml"), c, frame_window=(10.0, 25.0))
            for c in ("cam0", "cam1")}  # fmt: skip


def _angle_deg(R: np.ndarray) -> float:
    return float(np.degrees(np.linalg.norm(dp.so3_log(R))))


def test_euroc_cut_against_kalibr_and_stereo(euroc_cut):
    from dualpose.io import read_rig_sensors
    from dualpose.pipelines.calibrate_camera_imu import EUROC_KALIBR_T_BS, pose_matrix

    for cam, m in euroc_cut.items():
        T = pose_matrix(m)
        Tk = EUROC_KALIBR_T_BS[cam]
        assert _angle_deg(Tk[:3, :3].T @ T[:3, :3]) < 0.35, cam  # measured 0.21°, 0.27°
        assert np.linalg.norm(T[:3, 3] - Tk[:3, 3]) < 0.01, cam  # measured 6.5 mm, 3.4 mm
        assert abs(m["time_offset_s"]) < 0.002, cam
        assert m["reprojection_rms_px"] < 0.6, cam
    stereo = read_rig_sensors(EUROC / "sensors.yaml").T_cam0_cam1
    est = np.linalg.inv(pose_matrix(euroc_cut["cam0"])) @ pose_matrix(euroc_cut["cam1"])
    # a 15 s cut: 0.15° and 4.6 mm measured (the whole recording: 0.066°, 1.8 mm; docs/euroc.md)
    assert _angle_deg(stereo[:3, :3].T @ est[:3, :3]) < 0.25
    assert np.linalg.norm(est[:3, 3] - stereo[:3, 3]) < 0.008


def test_imu_factors_with_axis_models_need_the_axis_jacobians_and_both_deviations():
    t = np.linspace(0.0, 1.0, 101)
    gyro, accel = np.zeros((101, 3)), np.tile([0.0, 0.0, 9.81], (101, 1))
    s, zeros = np.array([0.1, 0.5, 0.9]), np.zeros((2, 3))
    R = np.broadcast_to(np.eye(3), (2, 3, 3))
    states = (R, zeros, zeros, R, zeros, zeros, zeros, zeros, np.array([0.0, 0.0, -9.81]), np.eye(3)[:, :2])
    plain = preintegrate(t, gyro, accel, s, zeros, zeros, 1e-3, 1e-2)
    with pytest.raises(ValueError, match="no axis-model Jacobians"):
        imu_factors(plain, *states, axes_gyro=np.zeros(6), axes_accel=np.zeros(9))
    with_axes = preintegrate(t, gyro, accel, s, zeros, zeros, 1e-3, 1e-2, axes=True)
    with pytest.raises(ValueError, match="axes_accel must be given with axes_gyro"):
        imu_factors(with_axes, *states, axes_gyro=np.zeros(6))
    r, J = imu_factors(with_axes, *states, axes_gyro=np.zeros(6), axes_accel=np.zeros(9))
    assert r.shape == (2, 9) and J is not None and J.shape == (2, 9, 41)
    with pytest.raises(ValueError, match="no size-effect Jacobians"):
        imu_factors(with_axes, *states, axes_gyro=np.zeros(6), axes_accel=np.zeros(9), size_effect=np.zeros(6))
    sized = preintegrate(t, gyro, accel, s, zeros, zeros, 1e-3, 1e-2, axes=True, size_effect=np.zeros(6))
    r, J = imu_factors(sized, *states, axes_gyro=np.zeros(6), axes_accel=np.zeros(9), size_effect=np.zeros(6))
    assert J is not None and J.shape == (2, 9, 47)
    np.testing.assert_array_equal(J[:, 3:9, 41:], -np.concatenate([sized.v_r, sized.p_r], axis=1))


def test_size_effect_jacobian_is_the_acceleration_of_a_point_on_the_body():
    """``α × r + ω × (ω × r)``: the body-frame acceleration of a point fixed at ``r`` on a rotating body, checked
    against the second central difference of ``R(t) r`` (a rotation vector quadratic in time)."""
    r = np.array([[0.01, -0.02, 0.005], [-0.003, 0.004, 0.02]])  # r_y, r_z
    th0, th1, th2 = np.array([0.1, -0.2, 0.3]), np.array([1.0, 0.5, -2.0]), np.array([3.0, -1.0, 0.5])
    t, h = 0.4, 1e-4

    def R(x: float) -> np.ndarray:
        return dp.so3_exp(th0 + th1 * x + th2 * x * x)

    Rd = (R(t + h) - R(t - h)) / (2 * h)
    Rdd = (R(t + h) - 2 * R(t) + R(t - h)) / h**2
    w = dp.so3_vee(R(t).T @ Rd)
    alpha = dp.so3_vee((R(t + h).T @ (R(t + 2 * h) - R(t)) - R(t - h).T @ (R(t) - R(t - 2 * h))) / (4 * h * h))
    S = size_effect_jacobian(w, alpha)
    for i, ri in ((1, r[0]), (2, r[1])):
        expected = (R(t).T @ Rdd @ ri)[i]  # e_iᵀ Rᵀ d²(R r)/dt²
        assert S[i] @ r.ravel() == pytest.approx(expected, abs=1e-6)
    assert np.all(S[0] == 0.0)


def test_preintegration_size_effect_jacobians_are_exact():
    """The size effect is linear in ``r`` and does not touch the rotation: the Jacobians give the change of Δv, Δp
    exactly, and ``r = 0`` is the plain preintegration."""
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 1.0, 201)
    gyro = np.column_stack([np.sin(3 * t + k) * 2.0 for k in range(3)])
    accel = rng.normal(0.0, 1.0, (201, 3)) + [0.0, 0.0, 9.81]
    s, z = np.array([0.1, 0.43, 0.77, 0.9]), np.zeros((3, 3))
    args = (t, gyro, accel, s, z, z, 1e-3, 1e-2)
    plain = preintegrate(*args)
    r0 = preintegrate(*args, size_effect=np.zeros(6))
    np.testing.assert_allclose(r0.dv, plain.dv, atol=1e-15)
    r1 = np.array([0.01, -0.02, 0.005, -0.003, 0.004, 0.02])
    moved = preintegrate(*args, size_effect=r1)
    v_r, p_r = r0.size_effect_jacobians()
    np.testing.assert_allclose(moved.dv - r0.dv, v_r @ r1, atol=1e-13)
    np.testing.assert_allclose(moved.dp - r0.dp, p_r @ r1, atol=1e-13)
    np.testing.assert_allclose(moved.dR, r0.dR, atol=1e-15)
    assert np.max(np.abs(moved.dv - r0.dv)) > 1e-3  # the rates above make a visible effect
    with pytest.raises(ValueError, match="no size-effect Jacobians"):
        plain.size_effect_jacobians()


def _size_effect_run(r: np.ndarray):
    """A 20 s random motion turning at up to 1 rad/s, its accelerometer axes y and z displaced by ``r`` (2, 3) m."""
    cam = RadTanCamera(213.3, 213.3, 160.0, 120.0, -0.2, 0.05, 1e-3, -1e-3, 320, 240)
    noise = ImuNoise(1e-4, 1e-5, 1e-3, 1e-4, 0.0, 0.0, 200.0)
    run = sim.simulate(sim.random_motion(5, duration=20.0, rotation_amplitude=0.25, max_frequency_hz=1.2), seed=3,
                       imu_noise=noise, camera_rate=20, pixel_sigma=0.0, landmarks_per_frame=40)  # fmt: skip
    w = run.truth["omega"]
    alpha = np.gradient(w, run.t, axis=0)
    K = dp.so3_hat(alpha) + dp.so3_hat(w) @ dp.so3_hat(w)  # independent of size_effect_jacobian's layout
    accel = run.accel.copy()
    accel[:, 1] += K[:, 1, :] @ r[0]
    accel[:, 2] += K[:, 2, :] @ r[1]
    f = run.frames
    Kc = run.camera.matrix
    xyz = np.column_stack([(f.pixels - Kc[:2, 2]) / np.diag(Kc)[:2], np.ones(len(f.pixels))])
    pixels = cam.project(xyz) + np.random.default_rng(7).normal(0.0, 0.05, (len(xyz), 2))
    return run, (run.t, run.gyro, accel, FrameCorrespondences(f.t, f.offsets, pixels, f.points), cam, noise)


def test_size_effect_model_recovers_displaced_accelerometer_axes():
    """Accelerometer y and z axes 4–8 mm from the x axis bias the lever arm of the scale–misalignment model by
    several σ; the size-effect model recovers the positions within 4 σ and the lever arm within its σ; on an IMU
    without displacement it finds positions consistent with zero."""
    r = np.array([[0.004, -0.006, 0.003], [-0.005, 0.002, 0.008]])
    run, args = _size_effect_run(r)
    plain = calibrate_camera_imu(*args, min_frames=20)
    res = calibrate_camera_imu(*args, min_frames=20, imu_model="scale_misalignment_size_effect")
    assert res.accel_axis_positions.shape == (3, 3) and np.all(res.accel_axis_positions[0] == 0.0)
    err = res.accel_axis_positions[1:].ravel() - r.ravel()
    assert np.all(np.abs(err) < 4 * res.accel_axis_positions_std)
    assert np.all(res.accel_axis_positions_std < 0.002)
    d_plain, d = plain.p_bc - run.p_bc, res.p_bc - run.p_bc
    assert float(d_plain @ np.linalg.solve(plain.covariance[3:6, 3:6], d_plain)) > 16.3  # biased without the model
    assert float(d @ np.linalg.solve(res.covariance[3:6, 3:6], d)) < 16.3  # χ²(3) 99.9 %
    _, args0 = _size_effect_run(np.zeros((2, 3)))
    none = calibrate_camera_imu(*args0, min_frames=20, imu_model="scale_misalignment_size_effect")
    assert np.all(np.abs(none.accel_axis_positions[1:].ravel()) < 4 * none.accel_axis_positions_std)
