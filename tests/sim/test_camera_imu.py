"""Simulator: ground truth self-consistency, IMU signals vs truth, projections, camera-stream options."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dualpose as dp
from dualpose import sim
from dualpose.types import CameraIntrinsics, FrameCorrespondences, ImuNoise, PinholeCamera


@pytest.fixture(scope="module")
def eight() -> sim.SmoothMotion:
    return sim.eight_motion()


def test_eight_matches_hol_description(eight: sim.SmoothMotion) -> None:
    t = np.linspace(0.0, eight.duration, 40001)
    k = eight.kinematics(t)
    speed = np.linalg.norm(k["velocity"], axis=1)
    assert np.trapezoid(speed, t) == pytest.approx(2.6, rel=1e-6)
    moving = speed > 1e-9
    assert t[moving][-1] - t[moving][0] == pytest.approx(5.4, abs=1e-3)
    assert 3.5 < np.linalg.norm(k["acceleration"], axis=1).max() <= 4.0
    assert 0.9 < np.linalg.norm(k["omega"], axis=1).max() <= 1.0
    # all six DoF excited: every position axis and every body rate axis moves
    assert np.all(np.ptp(k["position"], axis=0) > 0.05)
    assert np.all(np.abs(k["omega"]).max(axis=0) > 0.3)


@pytest.mark.parametrize("make", [sim.eight_motion, lambda: sim.random_motion(3, duration=6.0)])
def test_truth_derivatives_match_finite_differences(make) -> None:
    traj = make()
    t = np.linspace(0.3, traj.duration - 0.3, 57)
    h = 1e-5
    k0, kp, km = traj.kinematics(t), traj.kinematics(t + h), traj.kinematics(t - h)
    np.testing.assert_allclose((kp["position"] - km["position"]) / (2 * h), k0["velocity"], atol=1e-7)
    np.testing.assert_allclose((kp["velocity"] - km["velocity"]) / (2 * h), k0["acceleration"], atol=1e-6)
    # body rate from the quaternion derivative: ω_b = 2 vec(q* q̇)
    qdot = (kp["quat"] - km["quat"]) / (2 * h)
    omega_fd = 2.0 * dp.quat_mul(dp.quat_conj(k0["quat"]), qdot)[:, :3]
    np.testing.assert_allclose(omega_fd, k0["omega"], atol=1e-7)


def _dead_reckon(run: sim.SimulatedRun) -> tuple[np.ndarray, np.ndarray]:
    """Trapezoidal strapdown integration of the IMU from the true initial state (independent of the filters)."""
    tr = run.truth
    n = len(run.t)
    dt = run.t[1] - run.t[0]
    q = np.empty((n, 4))
    p = np.empty((n, 3))
    q[0], p[0], v = tr["quat"][0], tr["position"][0], tr["velocity"][0].copy()
    a_prev = Rotation.from_quat(q[0]).apply(run.accel[0]) + run.gravity
    for i in range(n - 1):
        w = 0.5 * (run.gyro[i] + run.gyro[i + 1])
        q[i + 1] = (Rotation.from_quat(q[i]) * Rotation.from_rotvec(w * dt)).as_quat()
        a_next = Rotation.from_quat(q[i + 1]).apply(run.accel[i + 1]) + run.gravity
        p[i + 1] = p[i] + v * dt + dt * dt * (a_prev / 3.0 + a_next / 6.0)
        v = v + 0.5 * dt * (a_prev + a_next)
        a_prev = a_next
    return p, q


def test_noise_free_imu_integrates_to_truth(eight: sim.SmoothMotion) -> None:
    """Second-order strapdown of the noise-free IMU converges to the truth (×10 rate ⇒ ≈ ×100 smaller error)."""
    errs = []
    for rate in (100.0, 1000.0):
        run = sim.simulate(
            eight, seed=1, imu_noise=ImuNoise(update_rate=rate).scaled(0.0), gravity_misalignment_deg=0.7
        )
        p, q = _dead_reckon(run)
        errs.append((np.abs(p - run.truth["position"]).max(), dp.quat_angle(q, run.truth["quat"]).max()))
    assert errs[1][0] < 2e-4 and errs[1][1] < 2e-6
    assert errs[0][0] / errs[1][0] > 30 and errs[0][1] / errs[1][1] > 30


def test_imu_noise_and_bias_statistics() -> None:
    noise = ImuNoise()
    run = sim.simulate(sim.random_motion(5, duration=60.0), seed=2, imu_noise=noise)
    dt = run.t[1] - run.t[0]
    spec = dp.quat_rotate(dp.quat_conj(run.truth["quat"]), run.truth["acceleration"] - run.gravity)
    eg = run.gyro - run.truth["omega"] - run.truth["gyro_bias"]
    ea = run.accel - spec - run.truth["accel_bias"]
    np.testing.assert_allclose(eg.std(axis=0), noise.gyroscope_noise_density / math.sqrt(dt), rtol=0.05)
    np.testing.assert_allclose(ea.std(axis=0), noise.accelerometer_noise_density / math.sqrt(dt), rtol=0.05)
    inc = np.diff(run.truth["gyro_bias"], axis=0)
    np.testing.assert_allclose(inc.std(axis=0), noise.gyroscope_random_walk * math.sqrt(dt), rtol=0.05)


def test_projections_match_independent_pinhole(eight: sim.SmoothMotion) -> None:
    run = sim.simulate(eight, seed=4, pixel_sigma=0.0, time_offset=0.02)
    cam = run.camera
    assert cam.fx == pytest.approx(3.2e-3 / 15e-6)
    f = run.frames
    assert len(f) > 60 and np.all(np.diff(f.offsets) == 20)
    np.testing.assert_allclose(f.t, f.t_true - 0.02)
    kin = eight.kinematics(f.t_true)
    r_bc = Rotation.from_quat(run.q_bc).as_matrix()
    for k in range(0, len(f), 7):
        r_wb = Rotation.from_quat(kin["quat"][k]).as_matrix()
        r_wc = r_wb @ r_bc
        c_w = kin["position"][k] + r_wb @ run.p_bc
        pix, pts = f.frame(k)
        x = (cam.matrix @ (r_wc.T @ (pts - c_w).T)).T
        np.testing.assert_allclose(pix, x[:, :2] / x[:, 2:], atol=1e-9)
        assert np.all((pix >= 0) & (pix < [cam.width, cam.height]))


def test_outliers_dropouts_and_pixel_noise(eight: sim.SmoothMotion) -> None:
    clean = sim.simulate(eight, seed=7, pixel_sigma=0.0)
    noisy = sim.simulate(eight, seed=7, pixel_sigma=1.0, outlier_fraction=0.1, dropouts=((2.0, 4.0),))
    f = noisy.frames
    assert not np.any((f.t_true >= 2.0) & (f.t_true < 4.0))
    assert 0.06 < f.outlier.mean() < 0.14
    # pixel noise: compare inlier pixels with the exact projection of the same landmark at the same time
    kin = eight.kinematics(f.t_true)
    res = []
    for k in range(len(f)):
        pix, pts = f.frame(k)
        pc = sim.camera_points(kin["quat"][k], kin["position"][k], noisy.q_bc, noisy.p_bc, pts)
        ok = ~f.outlier[f.offsets[k] : f.offsets[k + 1]]
        res.append(pix[ok] - noisy.camera.project(pc[ok]))
    res = np.concatenate(res)
    assert abs(res.std() - 1.0) < 0.05 and abs(res.mean()) < 0.05
    assert len(clean.frames) == math.floor((eight.duration - 0.0137) * 12.5) + 1


def test_gravity_misalignment_rotates_gravity() -> None:
    run = sim.simulate(sim.eight_motion(), seed=0, gravity_misalignment_deg=1.0, imu_noise=ImuNoise().scaled(0))
    ang = math.degrees(math.atan2(np.linalg.norm(np.cross(run.gravity, [0, 0, -1.0])), -run.gravity[2]))
    assert ang == pytest.approx(1.0)
    # at rest the accelerometer reads -g in the body frame
    np.testing.assert_allclose(
        run.accel[0], dp.quat_rotate(dp.quat_conj(run.truth["quat"][0]), -run.gravity), atol=1e-12
    )


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="outlier_fraction"):
        sim.simulate(sim.eight_motion(), outlier_fraction=1.5)
    with pytest.raises(ValueError, match="points_c"):
        PinholeCamera().project(np.zeros((3, 2)))


def test_camera_intrinsics_match_the_pinhole_camera_and_validate():
    cam = PinholeCamera()
    same = CameraIntrinsics(cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height)
    pts = np.array([[0.1, -0.2, 1.5], [0.0, 0.0, 2.0]])
    np.testing.assert_array_equal(same.project(pts), cam.project(pts))
    np.testing.assert_array_equal(same.matrix, cam.matrix)
    # an anisotropic camera with an off-centre principal point: u = fx X/Z + cx
    k = CameraIntrinsics(400.0, 380.0, 311.5, 242.25, 640, 480)
    np.testing.assert_allclose(k.project(pts[0]), [400 * 0.1 / 1.5 + 311.5, 380 * -0.2 / 1.5 + 242.25], rtol=1e-15)
    for bad in ({"fx": 0.0}, {"cy": float("nan")}, {"width": 0}, {"height": 2.5}):
        args = {"fx": 400.0, "fy": 380.0, "cx": 311.5, "cy": 242.25, "width": 640, "height": 480} | bad
        with pytest.raises(ValueError, match=next(iter(bad))):
            CameraIntrinsics(**args)


def test_frame_counts_and_observations_of_simulated_frames():
    run = sim.simulate_eight(1)
    f = run.frames
    assert isinstance(f, FrameCorrespondences)
    np.testing.assert_array_equal(f.counts, np.diff(f.offsets))
    # observe_landmarks with no noise reproduces the projections of the reported landmarks
    kin = run.motion.kinematics(f.t_true[:3])
    obs = sim.observe_landmarks(kin["quat"], kin["position"], run.landmarks, run.camera, run.q_bc, run.p_bc,
                                np.random.default_rng(0), pixel_sigma=0.0)  # fmt: skip
    for k in range(3):
        a, b = obs["offsets"][k], obs["offsets"][k + 1]
        pc = sim.camera_points(kin["quat"][k], kin["position"][k], run.q_bc, run.p_bc, obs["points"][a:b])
        np.testing.assert_allclose(obs["pixels"][a:b], run.camera.project(pc), rtol=0, atol=1e-9)
        assert b - a == 20 and not obs["outlier"][a:b].any()
