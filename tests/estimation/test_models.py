"""Measurement models: analytic Jacobians against central finite differences, and residuals at the truth."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose import sim
from dualpose.estimation import models

EPS = 1e-6


@pytest.fixture(scope="module")
def setup() -> tuple[sim.SimulatedRun, np.ndarray]:
    run = sim.simulate_eight(11, pixel_sigma=0.0)
    k = 40  # a frame in the middle of the motion
    tr = run.motion.kinematics(run.frames.t_true[k : k + 1])
    x = np.concatenate([tr["position"][0], tr["velocity"][0], tr["quat"][0], [1e-3, -2e-3, 3e-3, 0.02, -0.01, 0.03]])
    return run, x


def _fd_error_state(fun, x: np.ndarray) -> np.ndarray:
    """Central differences of ``fun(x ⊞ δx)`` (flattened) over the 15 error-state directions."""
    cols = []
    for i in range(15):
        d = np.zeros(15)
        d[i] = EPS
        cols.append((np.ravel(fun(models.boxplus(x, d))) - np.ravel(fun(models.boxplus(x, -d)))) / (2 * EPS))
    return np.stack(cols, axis=-1)


def test_camera_reprojection_jacobian_and_truth(setup) -> None:
    run, x = setup
    pix, pts = run.frames.frame(40)
    cam = run.camera
    intr = (cam.fx, cam.fy, cam.cx, cam.cy)
    r, H, depth = models.camera_reprojection(x, pix, pts, intr, run.q_bc, run.p_bc)
    np.testing.assert_allclose(r, 0.0, atol=1e-9)  # noise-free pixels of the true pose
    assert np.all(depth > 0.3)
    num = -_fd_error_state(lambda xx: models.camera_reprojection(xx, pix, pts, intr, run.q_bc, run.p_bc)[0], x)
    np.testing.assert_allclose(H.reshape(-1, 15), num, atol=1e-6 * np.abs(num).max())


def test_position_pose_magnetometer_jacobians(setup, rng) -> None:
    _, x = setup
    p_m = x[0:3] + rng.normal(0, 0.1, 3)
    q_m = dp.quat_mul(x[6:10], dp.quat_from_rotvec([0.3, -0.2, 0.4]))  # large residual: H is J_l^-1, not I
    field = np.array([0.4, 0.0, -0.9])
    m_m = rng.normal(size=3)
    for fun in (
        lambda xx: models.position_model(xx, p_m),
        lambda xx: models.pose_model(xx, p_m, q_m),
        lambda xx: models.magnetometer_model(xx, m_m, field),
    ):
        r, H = fun(x)
        num = -_fd_error_state(lambda xx, f=fun: f(xx)[0], x)
        np.testing.assert_allclose(H, num, atol=1e-8)
    np.testing.assert_allclose(
        models.magnetometer_model(x, m_m, field)[0], m_m - dp.quat_rotate(dp.quat_conj(x[6:10]), field)
    )


def _hol_state(x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A 22-state (eq. 8) near the error-state ``x``: q^{be} = conj(q_wb)."""
    return np.concatenate(
        [x[0:3], x[3:6], rng.normal(0, 2, 3), dp.quat_conj(x[6:10]), rng.normal(0, 0.5, 3), x[10:13], x[13:16]]
    )


def _fd_full(fun, x: np.ndarray) -> np.ndarray:
    cols = []
    for i in range(len(x)):
        d = np.zeros(len(x))
        d[i] = EPS
        cols.append((np.ravel(fun(x + d)) - np.ravel(fun(x - d))) / (2 * EPS))
    return np.stack(cols, axis=-1)


def test_hol_models_jacobians_and_values(setup, rng) -> None:
    run, x = setup
    xh = _hol_state(x, rng)
    g = np.array([0.0, 0.0, -9.81])
    ya, Ha = models.hol_accelerometer(xh, g)
    np.testing.assert_allclose(Ha, _fd_full(lambda v: models.hol_accelerometer(v, g)[0], xh), atol=1e-7)
    # eq. 11a value: specific force rotated into the body frame plus bias
    np.testing.assert_allclose(ya, dp.quat_rotate(xh[9:13], xh[6:9] - g) + xh[19:22], atol=1e-12)
    yw, Hw = models.hol_gyroscope(xh)
    np.testing.assert_allclose(Hw, _fd_full(lambda v: models.hol_gyroscope(v)[0], xh), atol=1e-9)
    pix, pts = run.frames.frame(40)
    cam = run.camera
    intr = (cam.fx, cam.fy, cam.cx, cam.cy)
    h, Hc, depth = models.hol_camera_implicit(xh, pix, pts, intr, run.q_bc, run.p_bc)
    np.testing.assert_allclose(h, 0.0, atol=1e-9)  # exact correspondences satisfy eq. 11c
    num = _fd_full(lambda v: models.hol_camera_implicit(v, pix, pts, intr, run.q_bc, run.p_bc)[0], xh)
    np.testing.assert_allclose(Hc.reshape(-1, 22), num, atol=1e-6 * np.abs(num).max())
    # eq. 11c is the reprojection residual scaled by the depth: h = Z (pixel − π(z^c))
    shifted = pix + 1.0
    h2 = models.hol_camera_implicit(xh, shifted, pts, intr, run.q_bc, run.p_bc)[0]
    np.testing.assert_allclose(h2, np.repeat(depth[:, None], 2, axis=1), rtol=1e-9)


def test_bad_shapes(setup) -> None:
    _, x = setup
    with pytest.raises(ValueError, match="x must"):
        models.position_model(x[:10], np.zeros(3))
    with pytest.raises(ValueError, match="same M"):
        models.camera_reprojection(x, np.zeros((3, 2)), np.zeros((4, 3)), (1, 1, 0, 0), [0, 0, 0, 1], [0, 0, 0])
