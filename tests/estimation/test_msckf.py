"""The MSCKF visual–inertial odometer: its native per-feature kernel on exact geometry, accuracy and NEES on the
simulator's feature-track mode (unknown landmarks), the unobservable position and yaw (first-estimates Jacobians),
and the real EuRoC V1_01 segment (no ground truth used in the run)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

import dualpose as dp
from dualpose import _native, sim
from dualpose.estimation.consistency import nees_band
from dualpose.estimation.eskf import initial_covariance
from dualpose.estimation.msckf import MsckfOptions, MsckfVio, TrackUpdate
from dualpose.estimation.state import ESKF_ERROR, ESKF_STATE
from dualpose.types import ImuNoise
from dualpose.types.features import TrackFrame


def _clone_poses(rng: np.random.Generator, n: int) -> np.ndarray:
    """n IMU poses [p, q] on a 1 m arc looking along +x (body = camera axes rotated by the identity)."""
    p = np.column_stack([np.zeros(n), np.linspace(-0.5, 0.5, n), rng.normal(0, 0.05, n)])
    q = dp.quat_from_rotvec(rng.normal(0, 0.05, (n, 3)))
    return np.hstack([p, q])


def test_features_kernel_on_exact_geometry(rng: np.random.Generator) -> None:
    """Exact observations of a point: zero residual after the nullspace projection, 2m − 3 rows, and the projected
    rows blind to a common translation of all clones (the point moves with them, so nothing is observed)."""
    C = 6
    clones = _clone_poses(rng, C)
    q_bc, p_bc = np.array([0.0, 0.0, 0.0, 1.0]), np.array([0.05, -0.02, 0.01])
    pw = np.array([0.2, 0.1, 3.0]) + np.array([0.0, 0.0, 0.0])
    pc = sim.camera_points(clones[:, 3:], clones[:, :3], q_bc, p_bc, pw[None, :].repeat(C, 0))
    uv = pc[:, :2] / pc[:, 2:3]
    n = 15 + 6 * C
    P = np.eye(n) * 1e-4
    H, r, rvar = np.empty((2 * C - 3, n)), np.empty(2 * C - 3), np.empty(2 * C - 3)
    status, nis, points, top = np.empty(1, np.int64), np.empty(1), np.empty((1, 3)), np.empty((1, 3, n + 4))
    gates = np.r_[np.inf, chi2.ppf(0.95, np.arange(1, 40))]
    rows = _native.msckf_features(clones, clones.copy(), q_bc, p_bc, np.array([0, C]), np.arange(C), uv, P, 1e-3,
                                  gates, np.array([0.1, 60.0, 0.01, 0.0]), H, r, rvar, status, nis, points,
                                  top)  # fmt: skip
    assert rows == 2 * C - 3 and status[0] == 1
    np.testing.assert_allclose(points[0], pw, atol=1e-9)
    np.testing.assert_allclose(r, 0.0, atol=1e-9)
    np.testing.assert_allclose(rvar, np.einsum("ij,jk,ik->i", H, P, H), rtol=1e-10)
    assert nis[0] < 1e-9
    # a common translation δp of every clone (the feature moves with it) is invisible: H [δp; 0]* = 0
    dx = np.zeros(n)
    for c in range(C):
        dx[15 + 6 * c : 18 + 6 * c] = [0.3, -0.2, 0.1]
    np.testing.assert_allclose(H @ dx, 0.0, atol=1e-10)
    # no baseline: the same pose for every clone fails triangulation
    same = np.repeat(clones[:1], C, 0)
    rows = _native.msckf_features(same, same, q_bc, p_bc, np.array([0, C]), np.arange(C), np.repeat(uv[:1], C, 0),
                                  P, 1e-3, gates, np.array([0.1, 60.0, 0.01, 0.0]), H, r, rvar, status, nis,
                                  points, top)  # fmt: skip
    assert rows == 0 and status[0] == -1 and np.isnan(points[0]).all()


def _inverse_depth_sigma(clones: np.ndarray, q_bc: np.ndarray, p_bc: np.ndarray, pw: np.ndarray) -> float:
    """The relative inverse-depth σ_ρ/ρ per unit σ of a normalised coordinate of the point ``pw`` seen from every clone,
    from an independent normal matrix: central differences of the projections with respect to the anchor camera's
    inverse-depth parameters (α, β, ρ), ``p_A = [α, β, 1] / ρ``."""
    R_bc = dp.matrix_from_quat(q_bc)
    R_wb = dp.matrix_from_quat(clones[0, 3:])
    R_wa, c_a = R_wb @ R_bc, clones[0, :3] + R_wb @ p_bc
    pa = R_wa.T @ (pw - c_a)
    theta = np.array([pa[0] / pa[2], pa[1] / pa[2], 1.0 / pa[2]])

    def uv(th: np.ndarray) -> np.ndarray:
        p = c_a + R_wa @ (np.array([th[0], th[1], 1.0]) / th[2])
        pc = sim.camera_points(clones[:, 3:], clones[:, :3], q_bc, p_bc, p[None, :].repeat(len(clones), 0))
        return (pc[:, :2] / pc[:, 2:3]).ravel()

    J = np.column_stack([(uv(theta + h) - uv(theta - h)) / (2e-7 * theta[2]) for h in np.eye(3) * 1e-7 * theta[2]])
    return float(np.sqrt(np.linalg.inv(J.T @ J)[2, 2]) / theta[2])


def test_features_kernel_refuses_a_depth_not_determined_at_the_pixel_noise(rng: np.random.Generator) -> None:
    """A feature is used only when its inverse depth is told apart from 0 at the noise σ: ρ/σ_ρ above the given
    z (here √χ²₁(0.95) = 1.96, the MSCKF's default).  At σ 10 % below the σ that puts ρ/σ_ρ at z (from an
    independent normal matrix) the point is used; 10 % above it is undetermined (status −3, no point), with the
    parallax test alone (z = 0) still accepted; a nearer point at the larger σ is used again."""
    C = 4
    clones = _clone_poses(rng, C)
    q_bc, p_bc = np.array([0.0, 0.0, 0.0, 1.0]), np.array([0.05, -0.02, 0.01])
    n = 15 + 6 * C
    P = np.eye(n) * 1e-4
    gates = np.r_[np.inf, chi2.ppf(0.95, np.arange(1, 40))]
    z = float(np.sqrt(chi2.ppf(0.95, 1)))

    def status_of(pw: np.ndarray, sigma: float, depth_z: float) -> tuple[int, np.ndarray]:
        pc = sim.camera_points(clones[:, 3:], clones[:, :3], q_bc, p_bc, pw[None, :].repeat(C, 0))
        H, r, rvar = np.empty((2 * C - 3, n)), np.empty(2 * C - 3), np.empty(2 * C - 3)
        status, nis, points = np.empty(1, np.int64), np.empty(1), np.empty((1, 3))
        _native.msckf_features(clones, clones.copy(), q_bc, p_bc, np.array([0, C]), np.arange(C),
                               pc[:, :2] / pc[:, 2:3], P, sigma, gates, np.array([0.1, 60.0, 0.01, depth_z]), H, r,
                               rvar, status, nis, points, np.empty((1, 3, n + 4)))  # fmt: skip
        return int(status[0]), points[0]

    far = np.array([0.2, 0.1, 40.0])  # 1 m of baseline at 40 m: parallax 0.025, above the 0.01 of the geometric test
    s_star = 1.0 / (z * _inverse_depth_sigma(clones, q_bc, p_bc, far))
    assert 1e-3 < s_star < 0.1  # a plausible noise of normalised coordinates (0.5-50 px at f = 500 px)
    st, pt = status_of(far, 0.9 * s_star, z)
    assert st == 1
    np.testing.assert_allclose(pt, far, rtol=1e-8)
    st, pt = status_of(far, 1.1 * s_star, z)
    assert st == -3 and np.isnan(pt).all()
    assert status_of(far, 1.1 * s_star, 0.0)[0] == 1  # the fixed parallax ratio alone lets it through
    assert status_of(np.array([0.2, 0.1, 4.0]), 1.1 * s_star, z)[0] == 1


def test_features_kernel_checks_the_gate_table(rng: np.random.Generator) -> None:
    """An empty χ² table is refused (the gate of a feature with d dof reads chi2[min(d, D − 1)])."""
    C = 4
    clones = _clone_poses(rng, C)
    q_bc, p_bc = np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3)
    pc = sim.camera_points(clones[:, 3:], clones[:, :3], q_bc, p_bc, np.repeat([[0.2, 0.1, 3.0]], C, 0))
    uv = pc[:, :2] / pc[:, 2:3]
    n = 15 + 6 * C
    H, r, rvar = np.empty((2 * C - 3, n)), np.empty(2 * C - 3), np.empty(2 * C - 3)
    with pytest.raises(ValueError, match="chi2"):
        _native.msckf_features(clones, clones.copy(), q_bc, p_bc, np.array([0, C]), np.arange(C), uv,
                               np.eye(n) * 1e-4, 1e-3, np.empty(0), np.array([0.1, 60.0, 0.01, 0.0]), H, r, rvar,
                               np.empty(1, np.int64), np.empty(1), np.empty((1, 3)),
                               np.empty((1, 3, n + 4)))  # fmt: skip


def _start(run: sim.SimulatedRun, rec, rng: np.random.Generator, options: MsckfOptions | None = None) -> MsckfVio:
    """The filter at t[0] from a draw of its prior around the truth (the estimator never sees the landmarks)."""
    tr = run.truth
    P0 = initial_covariance(imu_noise=run.imu_noise)
    e = rng.multivariate_normal(np.zeros(15), P0)
    x = ESKF_STATE.assemble(position=tr["position"][0] + e[:3], velocity=tr["velocity"][0] + e[3:6],
                            quat=dp.quat_mul(tr["quat"][0], dp.quat_from_rotvec(e[6:9])),
                            gyro_bias=tr["gyro_bias"][0] + e[9:12],
                            accel_bias=tr["accel_bias"][0] + e[12:15])  # fmt: skip
    f = MsckfVio(x, P0, run.imu_noise, run.q_bc, run.p_bc, rec.feature_sigma, options=options)
    f.time, f._u = float(run.t[0]), np.r_[run.gyro[0], run.accel[0]]
    return f


def _pose_error(run: sim.SimulatedRun, f: MsckfVio) -> np.ndarray:
    """[δp (3), δθ (3)] of the filter's final IMU pose in its error convention (local attitude)."""
    dpos = run.truth["position"][-1] - f.position
    dth = dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(f.quat), run.truth["quat"][-1]))
    return np.r_[dpos, dth]


def test_accuracy_and_nees_with_unknown_landmarks() -> None:
    """Monte Carlo over simulated feature-track runs: the final pose NEES (6 dof) lies in its two-sided 95 % band,
    the per-feature NIS averages its degrees of freedom, and the pose errors are at the cm / sub-degree level."""
    runs = 12
    nees, nis, dof, perr, aerr = [], [], [], [], []
    for i in range(runs):
        run, rec = sim.simulate_tracks(sim.random_motion(200 + i, duration=4.0), seed=200 + i,
                                       imu_noise=ImuNoise(update_rate=100.0), n_landmarks=120)  # fmt: skip
        f = _start(run, rec, np.random.default_rng(300 + i))
        res = f.run(rec, 0)
        e = _pose_error(run, f)
        idx = np.r_[ESKF_ERROR.slice("position"), ESKF_ERROR.slice("attitude")]
        nees.append(e @ np.linalg.solve(f.covariance[np.ix_(idx, idx)], e))
        nis.append(res.nis)
        dof.append(res.nis_dof)
        perr.append(np.linalg.norm(e[:3]))
        aerr.append(np.degrees(np.linalg.norm(e[3:])))
    lo, hi = nees_band(6, runs)
    assert lo <= np.mean(nees) <= hi, (np.mean(nees), lo, hi)
    ratio = np.sum(np.concatenate(nis)) / np.sum(np.concatenate(dof))
    assert 0.85 < ratio < 1.1, ratio  # the 95 % gate trims the upper tail a little
    assert np.median(perr) < 0.03 and np.median(aerr) < 0.5, (perr, aerr)


def _unobservable_directions(f: MsckfVio) -> np.ndarray:
    """(15 + 6C + 3L + 1, 4) the error-state directions of a global translation (3) and a rotation about the vertical
    through the origin (1) (Hesch et al. 2014), at the first estimates (the IMU state before a pending update, the
    clones as taken, the SLAM features as initialised; the time offset, observable, has none); gravity along −z.
    Local attitude error: a world rotation δψ ẑ is ``δθ = Rᵀ ẑ δψ``."""
    z = np.array([0.0, 0.0, 1.0])
    x = f.x if f._x_fej is None else f._x_fej
    N = np.zeros((f.P.shape[0], 4))
    N[0:3, :3] = np.eye(3)
    N[0:3, 3], N[3:6, 3] = np.cross(z, x[0:3]), np.cross(z, x[3:6])
    N[6:9, 3] = dp.matrix_from_quat(x[6:10]).T @ z
    for c, clone in enumerate(f.clones_fej):
        o = 15 + 6 * c
        N[o : o + 3, :3] = np.eye(3)
        N[o : o + 3, 3] = np.cross(z, clone[:3])
        N[o + 3 : o + 6, 3] = dp.matrix_from_quat(clone[3:]).T @ z
    o = 15 + 6 * len(f.clones)
    for i, p in enumerate(f.slam_fej):  # SLAM features: world points
        N[o + 3 * i : o + 3 * i + 3, :3] = np.eye(3)
        N[o + 3 * i : o + 3 * i + 3, 3] = np.cross(z, p)
    return N


def test_position_and_yaw_stay_unobservable() -> None:
    """First-estimates Jacobians in the propagation and the feature updates keep the global position and the yaw
    unobservable (Hesch et al. 2014): the information Nᵀ P⁻¹ N along those four directions never grows from frame
    to frame (clone, update, marginalisation, propagation; Loewner order), while roll and pitch become well known.
    (A transition at the current estimate after an update, instead of the first estimate, gains yaw information:
    threefold over this run.)"""
    run, rec = sim.simulate_tracks(sim.random_motion(7, duration=4.0), seed=7, imu_noise=ImuNoise(update_rate=100.0),
                                   n_landmarks=120)  # fmt: skip
    f = _start(run, rec, np.random.default_rng(8))
    P0 = f.covariance
    k, info = 0, []
    for j in range(len(rec.tracks)):
        frame = rec.tracks.frame(j)
        while k < len(run.t) and run.t[k] <= frame.t:
            f.propagate(run.t[k], run.gyro[k], run.accel[k])
            k += 1
        N = _unobservable_directions(f)  # P is regular here (the last clone has been propagated away from)
        info.append(N.T @ np.linalg.solve(f.P, N))
        f.update(frame)
    growth = [np.linalg.eigvalsh(info[i + 1] - info[i]).max() / np.linalg.eigvalsh(info[i]).max()
              for i in range(len(info) - 1)]  # fmt: skip
    assert max(growth) < 1e-9, max(growth)
    assert f.n_slam_init > 5  # SLAM features were initialised, updated and marginalised along the way
    assert info[-1][3, 3] < info[0][3, 3]  # process noise only loses yaw information
    P = f.covariance
    pos = ESKF_ERROR.slice("position")
    assert np.all(np.diag(P[pos, pos]) >= np.diag(P0[pos, pos]) * 0.999)
    R = dp.matrix_from_quat(f.quat)  # world-frame attitude covariance: roll and pitch shrink
    R0 = dp.matrix_from_quat(run.truth["quat"][0])
    att = ESKF_ERROR.slice("attitude")
    world, world0 = R @ P[att, att] @ R.T, R0 @ P0[att, att] @ R0.T
    assert world[0, 0] < 0.5 * world0[0, 0] and world[1, 1] < 0.5 * world0[1, 1]


def test_feature_sigma_adapts_to_the_tracks() -> None:
    """The covariance-matching σ (MsckfOptions.adaptive_sigma) reaches the simulator's true feature σ from a start
    three times too large or three times too small, and stays there from the true value."""
    run, rec = sim.simulate_tracks(sim.random_motion(5, duration=3.0), seed=5, imu_noise=ImuNoise(update_rate=100.0),
                                   n_landmarks=120)  # fmt: skip
    for start in (3.0, 1.0, 0.3):
        f = _start(run, rec, np.random.default_rng(6), MsckfOptions(adaptive_sigma=True))
        f.feature_sigma = f.nominal_sigma = start * rec.feature_sigma
        f.run(rec, 0)
        assert f.feature_sigma == pytest.approx(rec.feature_sigma, rel=0.1), (start, f.feature_sigma)


def test_track_frames_go_through_the_interface() -> None:
    run, rec = sim.simulate_tracks(sim.random_motion(11, duration=1.5), seed=11, imu_noise=ImuNoise(update_rate=100.0),
                                   n_landmarks=80)  # fmt: skip
    f = _start(run, rec, np.random.default_rng(12))
    k = 0
    used = 0
    for j in range(len(rec.tracks)):
        frame = rec.tracks.frame(j)
        while k < len(run.t) and run.t[k] <= frame.t:
            f.propagate(run.t[k], run.gyro[k], run.accel[k])
            k += 1
        t_before, td = f.time, f.camera_time_offset  # the time offset is estimated online (default)
        res = f.update(frame)
        assert isinstance(res, TrackUpdate) and f.time == pytest.approx(max(frame.t + td, t_before))
        assert len(f.clones) <= f.options.max_clones
        used += int(np.sum(res.accepted))
    assert used > 50
    assert f.full_covariance.shape == (15 + 6 * len(f.clones) + 3 * len(f.slam_id) + 1,) * 2  # + time offset
    with pytest.raises(TypeError, match="no model for a CameraFrame"):
        f.update(run.frames.camera_frame(0))
    with pytest.raises(ValueError, match="older than the filter time"):
        f.update(TrackFrame(0.0, [1], [[0.0, 0.0]]))


def test_euroc_v101_from_rest(euroc_v101) -> None:
    """The real flight, started from its rest period with no ground truth: a regression guard on the accuracy of
    docs/vio.md (4-DoF ATE and final drift), the rest found, features mostly accepted."""
    from dualpose.pipelines.vio import run_vio

    csv, gt = euroc_v101
    out = run_vio(csv, truth=gt)
    m = out.metrics
    assert 4.0 < m["rest_s"] < 5.2
    assert m["ate_rmse_4dof_m"] < 0.025 and m["orientation_rmse_4dof_deg"] < 1.1 and m["final_drift_percent"] < 0.4
    assert m["features_used"] > 5 * m["features_gated"] and m["slam_features"] > 50
    assert m["adapted_sigma_px"] == m["feature_sigma_px"] == pytest.approx(1.0)  # OpenVINS' 1 px, not adapted


def test_options_are_checked() -> None:
    with pytest.raises(ValueError, match="max_clones"):
        MsckfOptions(max_clones=1)
    with pytest.raises(ValueError, match="gate_probability"):
        MsckfOptions(gate_probability=1.0)
    with pytest.raises(ValueError, match="sigma_floor"):
        MsckfOptions(sigma_floor=0.0)
    with pytest.raises(ValueError, match="max_slam"):
        MsckfOptions(max_slam=-1)
    with pytest.raises(ValueError, match="time_offset_sigma"):
        MsckfOptions(time_offset_sigma=0.0)


def test_saved_state_continues_bit_for_bit(tmp_path) -> None:
    """Stop one sample / frame at a time mid-run, save with np.savez, load, continue: the same states as without the
    interruption."""
    run, rec = sim.simulate_tracks(sim.random_motion(21, duration=1.5), seed=21, imu_noise=ImuNoise(update_rate=100.0),
                                   n_landmarks=80)  # fmt: skip

    def events():
        k = 0
        for j in range(len(rec.tracks)):
            frame = rec.tracks.frame(j)
            while k < len(run.t) and run.t[k] <= frame.t:
                yield ("imu", k)
                k += 1
            yield ("frame", frame)

    def feed(f: MsckfVio, ev) -> None:
        if ev[0] == "imu":
            f.propagate(run.t[ev[1]], run.gyro[ev[1]], run.accel[ev[1]])
        else:
            f.update(ev[1])

    evs = list(events())
    a = _start(run, rec, np.random.default_rng(22))
    b = MsckfVio.from_state_dict(a.state_dict())
    for ev in evs:
        feed(a, ev)
    half = len(evs) // 2
    for ev in evs[:half]:
        feed(b, ev)
    np.savez(tmp_path / "s.npz", **b.state_dict())
    c = MsckfVio.from_state_dict(np.load(tmp_path / "s.npz"))
    for ev in evs[half:]:
        feed(c, ev)
    np.testing.assert_array_equal(c.state, a.state)
    np.testing.assert_array_equal(c.full_covariance, a.full_covariance)
    np.testing.assert_array_equal(c.clones, a.clones)
    with pytest.raises(ValueError, match="layout version 99"):
        MsckfVio.from_state_dict({**a.state_dict(), "version": np.array(99)})


def test_time_offset_is_estimated_online() -> None:
    """The camera–IMU time offset in the state (MsckfOptions.estimate_time_offset): started at 0 with its 10 ms prior
    σ on a run whose camera stamps are 8 ms early (sim: ``t_imu = t_cam + 0.008``), the estimate comes within 1.5 ms of
    the truth with a σ below 1 ms, and the final position is better than with the offset fixed at 0; started at the
    truth it stays there."""
    run = sim.simulate(sim.random_motion(1, duration=6.0), seed=1, imu_noise=ImuNoise(update_rate=100.0),
                       camera_rate=20.0, n_landmarks=120, time_offset=0.008)  # fmt: skip
    rec = sim.track_recording(run, 1e-3, 1)
    tr = run.truth
    x = ESKF_STATE.assemble(position=tr["position"][0], velocity=tr["velocity"][0], quat=tr["quat"][0],
                            gyro_bias=tr["gyro_bias"][0], accel_bias=tr["accel_bias"][0])  # fmt: skip
    P0 = initial_covariance(imu_noise=run.imu_noise)
    out = {}
    for start, online in ((0.0, True), (0.0, False), (0.008, True)):
        f = MsckfVio(x, P0, run.imu_noise, run.q_bc, run.p_bc, rec.feature_sigma, camera_time_offset=start,
                     options=MsckfOptions(estimate_time_offset=online))  # fmt: skip
        f.time, f._u = float(run.t[0]), np.r_[run.gyro[0], run.accel[0]]
        f.run(rec, 0)
        out[start, online] = (f.camera_time_offset, np.linalg.norm(tr["position"][-1] - f.position), f)
    td, err, f = out[0.0, True]
    assert abs(td - 0.008) < 0.0015 and np.sqrt(f.P[-1, -1]) < 0.001, (td, f.P[-1, -1])
    assert err < out[0.0, False][1], (err, out[0.0, False][1])
    assert out[0.0, False][0] == 0.0 and abs(out[0.008, True][0] - 0.008) < 0.0005


def test_slam_rows_kernel_is_the_linearised_projection(rng: np.random.Generator) -> None:
    """``msckf_slam_rows``: the residual of an observation made at a slightly different clone pose and point is the
    kernel's two rows times the difference, ``r = H δx`` to first order (δx = truth − estimate, local attitude error
    ``q = q̂ ⊗ Exp(δθ)``), the rows sit in the newest clone's and the point's columns, and a gate of 0 rejects."""
    C, L = 4, 2
    clones = _clone_poses(rng, C)
    q_bc, p_bc = np.array([0.0, 0.0, 0.0, 1.0]), np.array([0.05, -0.02, 0.01])
    c = C - 1
    R = dp.matrix_from_quat(clones[c, 3:])
    points = clones[c, :3] + np.array([[0.2, -0.1, 3.0], [-0.3, 0.2, 2.0]]) @ R.T  # in front of the clone
    d = 1e-6 * rng.standard_normal(9)  # [δp, δθ] of the clone, δp_f of point 1
    q_true = dp.quat_mul(clones[c, 3:], dp.quat_from_rotvec(d[3:6]))
    pc = sim.camera_points(q_true, clones[c, :3] + d[:3], q_bc, p_bc, (points[1] + d[6:])[None, :])
    uv = pc[:, :2] / pc[:, 2:3]
    n = 15 + 6 * C + 3 * L + 1  # the time offset last
    P = np.eye(n) * 1e-4
    H, r, r_all, rvar = np.empty((2, n)), np.empty(2), np.empty(2), np.empty(2)
    status = np.empty(1, np.int64)
    rows, front = _native.msckf_slam_rows(clones, clones.copy(), q_bc, p_bc, points, points.copy(), np.array([1]), c,
                                          uv, P, 1e-3, np.inf, H, r, status, r_all, rvar)  # fmt: skip
    assert rows == 2 and front == 1 and status[0] == 1
    cols = np.r_[15 + 6 * c : 21 + 6 * c, 15 + 6 * C + 3 : 15 + 6 * C + 6]
    np.testing.assert_allclose(r, H[:, cols] @ d, rtol=1e-4, atol=1e-12)
    assert np.count_nonzero(H[:, np.setdiff1d(np.arange(n), cols)]) == 0
    np.testing.assert_allclose(rvar, np.einsum("ij,jk,ik->i", H, P, H), rtol=1e-12)
    rows, _ = _native.msckf_slam_rows(clones, clones.copy(), q_bc, p_bc, points, points.copy(), np.array([1]), c,
                                      uv + 0.01, P, 1e-3, 0.0, H, r, status, r_all, rvar)  # fmt: skip
    assert rows == 0 and status[0] == 0


def test_clone_select_and_propagate_kernels_are_the_covariance_maps(rng: np.random.Generator) -> None:
    """``msckf_clone`` is ``T P Tᵀ`` with ``T`` stacking the identity and the clone's rows ``J + u e_lastᵀ`` (the
    pose rows of the IMU error, plus the time-offset term) inserted at row k; ``msckf_select`` is ``P[keep][:, keep]``;
    ``msckf_propagate`` maps the IMU rows of the cross-covariance linearly, ``P_IO <- Φ P_IO`` with the same ``Φ``
    for every ``P_IO``, and leaves the IMU block as a propagation of that block alone does."""
    n, k = 15 + 12 + 6 + 1, 27  # IMU, two clones, two points, the time offset
    A = rng.standard_normal((n, n))
    P = A @ A.T / n + np.eye(n)
    rows = np.r_[0:3, 6:9]
    u = rng.standard_normal(6)
    for uu in (u, np.zeros(0)):
        J = np.zeros((6, n))
        J[np.arange(6), rows] = 1.0
        if len(uu):
            J[:, n - 1] += uu
        T = np.insert(np.eye(n), k, np.zeros((6, n)), axis=0)
        T[k : k + 6] = J
        out = np.empty((n + 6, n + 6))
        _native.msckf_clone(P, rows, k, uu, out)
        np.testing.assert_allclose(out, T @ P @ T.T, rtol=1e-12, atol=1e-14)
        np.testing.assert_array_equal(out, out.T)
    keep = np.r_[0:15, 21:n]
    out = np.empty((len(keep), len(keep)))
    _native.msckf_select(P, keep, out)
    np.testing.assert_array_equal(out, P[np.ix_(keep, keep)])
    # propagation: Φ from P_IO = I (15 other states), then a random P_IO
    x = ESKF_STATE.assemble(position=np.zeros(3), velocity=np.array([0.3, -0.1, 0.2]),
                            quat=dp.quat_from_rotvec(np.array([0.1, -0.2, 0.3])), gyro_bias=np.full(3, 1e-3),
                            accel_bias=np.full(3, 0.01))  # fmt: skip
    gyro, accel = rng.normal(0, 0.3, (5, 3)), rng.normal(0, 0.5, (5, 3)) + [0.0, 0.0, 9.81]
    dt, g, noise = np.full(5, 0.005), np.array([0.0, 0.0, -9.81]), np.array([1e-6, 1e-4, 1e-10, 1e-8, 0.0, 0.0])

    def run(P0: np.ndarray) -> np.ndarray:
        P1, x1 = P0.copy(), x.copy()
        _native.msckf_propagate(x1, x.copy(), P1, gyro, accel, dt, g, noise, np.empty((5, 16)))
        return P1

    Pii = P[:15, :15]
    alone = run(Pii)
    eye = run(np.block([[Pii, np.eye(15)], [np.eye(15), np.eye(15)]]))
    B = rng.standard_normal((15, 4))
    full = run(np.block([[Pii, B], [B.T, np.eye(4)]]))
    np.testing.assert_array_equal(eye[:15, :15], alone)
    np.testing.assert_array_equal(full[:15, :15], alone)
    np.testing.assert_allclose(full[:15, 15:], eye[:15, 15:] @ B, rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(full[15:, :15], full[:15, 15:].T)
    np.testing.assert_array_equal(full[15:, 15:], np.eye(4))
