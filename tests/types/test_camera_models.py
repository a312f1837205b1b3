"""Distorted cameras (dualpose.types.camera_models) against OpenCV's projection and undistortion, finite-difference
Jacobians, the guarded series on the optical axis, and the failure modes."""

from __future__ import annotations

import camera_reference as ref
import cv2
import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dualpose.types import CameraIntrinsics, EquidistantCamera, PinholeModel, RadTanCamera, camera_from_parameters

#: EuRoC MAV cam0 (sensors.yaml of the dataset)
EUROC = RadTanCamera(458.654, 457.296, 367.215, 248.375, -0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 752, 480)
#: a TUM-VI-like fisheye (512 x 512, Kannala-Brandt coefficients of TUM VI cam0)
TUMVI = EquidistantCamera(
    190.97847715128717, 190.9733070521226, 254.93170605935475, 256.8974428996504,
    0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202, 0.00020293673591811182, 512, 512,
)  # fmt: skip
CAMERAS = [EUROC, TUMVI]


def _pixel_grid(cam, n: int = 41) -> np.ndarray:
    """A grid over the whole image, corners included, (n*n, 2)."""
    u, v = np.meshgrid(np.linspace(0, cam.width - 1, n), np.linspace(0, cam.height - 1, n))
    return np.stack([u.ravel(), v.ravel()], axis=-1)


def _grid_points(cam) -> np.ndarray:
    """Camera-frame points whose images cover the image (corners included) at depths 0.5 to 4 m, (N, 3); for the
    fisheye only the rays in front of the camera (Z > 0, what OpenCV's fisheye model handles)."""
    rays = cam.bearing(_pixel_grid(cam))
    rays = rays[rays[:, 2] > 0.05]
    depth = np.linspace(0.5, 4.0, len(rays))
    return rays / rays[:, 2:3] * depth[:, None]


def _cv_project(cam, points: np.ndarray) -> np.ndarray:
    if cam.model == "radtan":
        out, _ = cv2.projectPoints(points, np.zeros(3), np.zeros(3), cam.matrix, np.array(cam.distortion))
    else:
        k = np.array(cam.distortion)
        out, _ = cv2.fisheye.projectPoints(points[:, None], np.zeros(3), np.zeros(3), cam.matrix, k)
    return out[:, 0]


@pytest.mark.parametrize("cam", CAMERAS, ids=["radtan", "equi"])
def test_project_equals_opencv_over_the_whole_image(cam):
    points = _grid_points(cam)
    assert len(points) > 1000
    px = cam.project(points)
    np.testing.assert_allclose(px, _cv_project(cam, points), rtol=0, atol=1e-9)
    if cam.model == "radtan":  # the grid reaches the image corners
        assert px[:, 0].min() < 1 and px[:, 0].max() > cam.width - 2
        assert px[:, 1].min() < 1 and px[:, 1].max() > cam.height - 2


def test_undistort_equals_opencv_radtan():
    px = _pixel_grid(EUROC)
    xy = EUROC.unproject(px)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-300)
    ref = cv2.undistortPointsIter(px[:, None], EUROC.matrix, np.array(EUROC.distortion), None, None, criteria)[:, 0]
    np.testing.assert_allclose(xy, ref, rtol=0, atol=1e-10)
    assert _ray_angles(xy, ref).max() <= 1e-10
    # analytic round trip: projecting the undistorted rays gives the pixels back
    np.testing.assert_allclose(EUROC.project(np.c_[xy, np.ones(len(xy))]), px, rtol=0, atol=1e-9)


def test_undistort_equals_opencv_fisheye():
    px = _pixel_grid(TUMVI)
    xy, valid = TUMVI.unproject(px, return_valid=True)
    theta = np.arctan(np.hypot(xy[valid, 0], xy[valid, 1]))
    assert valid.mean() > 0.5 and theta.max() > 1.5  # up to ~86 degrees off axis
    # OpenCV's default criteria (Newton on θ until |Δθ| < 1e-8, then one more evaluation) reach full precision here;
    # a count-only criterion makes it flag points beyond ~78° as failed (-1e6)
    ref = cv2.fisheye.undistortPoints(px[:, None], TUMVI.matrix, np.array(TUMVI.distortion))[:, 0]
    assert _ray_angles(xy[valid], ref[valid]).max() <= 1e-10
    # ours: the analytic round trip to 1e-9 px over every invertible pixel, also beyond 90 degrees (bearing)
    rays = TUMVI.bearing(px)
    np.testing.assert_allclose(TUMVI.project(rays), px, rtol=0, atol=1e-9)
    np.testing.assert_allclose(TUMVI.project(np.c_[xy[valid], np.ones(valid.sum())]), px[valid], rtol=0, atol=1e-9)


@pytest.mark.parametrize("cam", CAMERAS, ids=["radtan", "equi"])
def test_ideal_pixels_and_pinhole(cam):
    px = _pixel_grid(cam, 11)[44:77]  # rows 4 to 6: within 90 degrees of the axis for the fisheye too
    ideal = cam.ideal_pixels(px)
    assert isinstance(cam.pinhole(), CameraIntrinsics)
    rays = cam.bearing(px)
    np.testing.assert_allclose(ideal, cam.pinhole().project(rays), rtol=0, atol=1e-9)
    assert isinstance(cam, PinholeModel)
    np.testing.assert_array_equal(cam.matrix, cam.pinhole().matrix)


def _ray_angles(xy_a: np.ndarray, xy_b: np.ndarray) -> np.ndarray:
    """Angles (radians, atan2 of |cross| and dot) between the rays (x, y, 1) of two sets of normalised points."""
    a = np.c_[xy_a, np.ones(len(xy_a))]
    b = np.c_[xy_b, np.ones(len(xy_b))]
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


def _central(f, x: np.ndarray, h: float) -> np.ndarray:
    """Central-difference Jacobian of f at x (1-D), columns per component of x."""
    cols = []
    for i in range(len(x)):
        e = np.zeros_like(x)
        e[i] = h
        cols.append((f(x + e) - f(x - e)) / (2 * h))
    return np.stack(cols, axis=-1)


_fov = st.tuples(
    st.floats(-0.9, 0.9), st.floats(-0.6, 0.6), st.floats(0.3, 5.0)
)  # normalised x, y and depth within the EuRoC field of view


@pytest.mark.parametrize("cam", CAMERAS, ids=["radtan", "equi"])
@given(_fov)
def test_jacobians_match_central_differences(cam, sample):
    x, y, z = sample
    p = np.array([x * z, y * z, z])
    px, j = cam.project_jacobian(p)
    np.testing.assert_allclose(px, cam.project(p), rtol=0, atol=1e-12)
    np.testing.assert_allclose(j, _central(cam.project, p, 1e-6 * z), rtol=1e-6, atol=1e-4)
    params = cam.parameters

    def with_params(q):
        return type(cam)(*q, cam.width, cam.height).project(p)

    np.testing.assert_allclose(cam.intrinsics_jacobian(p), _central(with_params, params, 1e-7), rtol=1e-6, atol=1e-5)
    xy = np.array([x, y])
    np.testing.assert_allclose(cam.distort_jacobian(xy), _central(cam.distort, xy, 1e-7), rtol=1e-6, atol=1e-7)


def test_broadcasting_and_shapes():
    p = np.tile(np.array([0.1, -0.2, 1.5]), (4, 3, 1))
    for cam in CAMERAS:
        px, j = cam.project_jacobian(p)
        assert px.shape == (4, 3, 2) and j.shape == (4, 3, 2, 3)
        assert cam.intrinsics_jacobian(p).shape == (4, 3, 2, 8)
        assert cam.distort(p[..., :2]).shape == (4, 3, 2)
        assert cam.distort_jacobian(p[..., :2]).shape == (4, 3, 2, 2)
        assert cam.bearing(px).shape == (4, 3, 3)
        assert cam.project(p[0, 0]).shape == (2,)


def test_equidistant_on_the_optical_axis_is_exact_and_continuous():
    """θ_d/ρ through the guarded series: at ρ = 0 the pixel is the principal point and the Jacobian fx/Z; near it the
    projection equals the mpmath evaluation of the model to a few ulps."""
    z = 2.0
    px, j = TUMVI.project_jacobian(np.array([0.0, 0.0, z]))
    np.testing.assert_array_equal(px, [TUMVI.cx, TUMVI.cy])
    np.testing.assert_allclose(j, [[TUMVI.fx / z, 0, 0], [0, TUMVI.fy / z, 0]], rtol=1e-15, atol=0)
    mpmath.mp.dps = 40
    k = [mpmath.mpf(c) for c in TUMVI.distortion]
    for rho in (1e-300, 1e-20, 1e-9, 1e-5, 1e-3, 0.3):
        xy = np.array([rho * 0.6, rho * 0.8])  # normalised, Z = 1
        theta = mpmath.atan(mpmath.mpf(rho))
        td = theta * (1 + k[0] * theta**2 + k[1] * theta**4 + k[2] * theta**6 + k[3] * theta**8)
        ref = float(td / mpmath.mpf(rho))  # θ_d / ρ
        got = TUMVI.distort(xy) / xy
        np.testing.assert_allclose(got, ref, rtol=4e-16, atol=0)
        if rho < 1e-5:
            jr = TUMVI.project_jacobian(np.array([*(xy * z), z]))[1]
            f = np.array([[TUMVI.fx], [TUMVI.fy]]) / z
            pinhole = f * np.array([[1.0, 0.0, -xy[0]], [0.0, 1.0, -xy[1]]])  # distortion is O(ρ²) from here
            np.testing.assert_allclose(jr, pinhole, rtol=1e-9, atol=0)


def test_equidistant_projects_beyond_90_degrees():
    p = np.array([1.0, 0.5, -0.2])  # behind the image plane: a fisheye ray beyond 90 degrees
    ray = p / np.linalg.norm(p)
    px = TUMVI.project(p)
    np.testing.assert_allclose(TUMVI.bearing(px), ray, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="points_c"):
        TUMVI.project([0.0, 0.0, -1.0])


def test_refuses_points_behind_radtan_and_bad_shapes():
    with pytest.raises(ValueError, match="points_c.*Z must be > 0"):
        EUROC.project([[0.1, 0.2, 1.0], [0.0, 0.0, -1.0]])
    with pytest.raises(ValueError, match=r"points_c must have shape \(\.\.\., 3\)"):
        EUROC.project(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="pixels must be finite"):
        EUROC.unproject([np.nan, 1.0])


def test_undistort_flags_points_outside_the_invertible_region():
    # r(1 + k1 r² + k2 r⁴) with k1 = -0.3, k2 = 0 folds at r² = 1/0.9: distorted radii beyond its maximum have no
    # preimage on the first branch
    cam = RadTanCamera(400.0, 400.0, 320.0, 240.0, -0.3, 0.0, 0.0, 0.0, 640, 480)
    assert cam.max_radius2 == pytest.approx(1 / 0.9)
    rmax = np.sqrt(1 / 0.9) * (1 - 0.3 / 0.9)
    xy_d = np.array([[0.2, 0.1], [rmax * 1.01, 0.0], [0.0, rmax * 0.99]])
    xy, valid = cam.undistort(xy_d, return_valid=True)
    np.testing.assert_array_equal(valid, [True, False, True])
    assert np.isnan(xy[1]).all() and np.isfinite(xy[[0, 2]]).all()
    np.testing.assert_allclose(cam.distort(xy[[0, 2]]), xy_d[[0, 2]], rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match=r"xy_d: 1 of 3 \(first at index \(1,\)\).*invertible"):
        cam.undistort(xy_d)
    fish = EquidistantCamera(300.0, 300.0, 320.0, 240.0, -0.2, 0.0, 0.0, 0.0, 640, 480)
    assert fish.max_angle == pytest.approx(np.sqrt(1 / 0.6))
    with pytest.raises(ValueError, match="pixels: 1 of 1"):
        fish.bearing([320.0 + 300.0 * 1.0, 240.0])  # θ_d = 1 > max θ_d = 0.86


def test_construction_checks_and_factory():
    with pytest.raises(ValueError, match="fx must be > 0"):
        RadTanCamera(0.0, 1.0, 0, 0, 0, 0, 0, 0, 10, 10)
    with pytest.raises(ValueError, match="k2 must be a finite number"):
        EquidistantCamera(1.0, 1.0, 0, 0, 0, np.inf, 0, 0, 10, 10)
    with pytest.raises(ValueError, match="height must be a positive whole number"):
        RadTanCamera(1.0, 1.0, 0, 0, 0, 0, 0, 0, 10, 10.5)
    cam = camera_from_parameters("Radial-Tangential", [458.654, 457.296, 367.215, 248.375], EUROC.distortion, 752, 480)
    assert cam == EUROC and cam.model == "radtan"
    for name in ("equi", "equidistant", "fisheye", "kannala-brandt"):
        assert isinstance(camera_from_parameters(name, [1, 1, 0, 0], [0, 0, 0, 0], 4, 4), EquidistantCamera)
    with pytest.raises(ValueError, match="model must be one of.*radtan"):
        camera_from_parameters("double-sphere", [1, 1, 0, 0], [0, 0, 0, 0], 4, 4)
    with pytest.raises(ValueError, match="distortion must have 4 values"):
        camera_from_parameters("radtan", [1, 1, 0, 0], [0, 0, 0], 4, 4)
    assert TUMVI.distortion == (TUMVI.k1, TUMVI.k2, TUMVI.k3, TUMVI.k4) and TUMVI.model == "equi"


@pytest.mark.parametrize("cam", CAMERAS, ids=["radtan", "equi"])
def test_compiled_kernels_equal_the_numpy_statement(cam, rng):
    """The compiled per-point kernels against the whole-array NumPy statement of the same equations
    (tests/types/camera_reference.py) to 1e-12 relative, over the image, on the axis and near the invertible edge."""
    px = np.concatenate([_pixel_grid(cam, 31), rng.uniform(0, [cam.width, cam.height], (500, 2)), [[cam.cx, cam.cy]]])
    xy_d = np.stack([(px[:, 0] - cam.cx) / cam.fx, (px[:, 1] - cam.cy) / cam.fy], -1)
    p8 = cam.parameters
    limit = cam.max_radius2 if cam.model == "radtan" else cam.max_angle
    if cam.model == "radtan":
        xy_ref, valid_ref = ref.radtan_undistort(p8[4:], limit, xy_d)
        rays_ref = np.c_[xy_ref, np.ones(len(xy_ref))]
        rays_ref /= np.linalg.norm(rays_ref, axis=1, keepdims=True)
    else:
        xy_ref, valid_ref = ref.equi_undistort(p8[4:], limit, xy_d)
        rays_ref, bearing_valid = ref.equi_bearing(p8[4:], limit, xy_d)
        assert bearing_valid.all()
    rays = cam.bearing(px)
    np.testing.assert_allclose(rays, rays_ref, rtol=1e-12, atol=1e-15)
    xy, valid = cam.undistort(xy_d, return_valid=True)
    np.testing.assert_array_equal(valid, valid_ref)
    np.testing.assert_allclose(xy[valid], xy_ref[valid], rtol=1e-12, atol=1e-15)
    points = rays * rng.uniform(0.2, 5.0, (len(rays), 1))
    points = np.concatenate([points, [[0.0, 0.0, 1.0], [1e-200, -1e-200, 2.0]]])
    px_ref, j_ref, jp_ref = ref.project(cam.model, p8, points)
    got, j = cam.project_jacobian(points)
    np.testing.assert_allclose(got, px_ref, rtol=1e-12, atol=0)
    np.testing.assert_allclose(cam.project(points), px_ref, rtol=1e-12, atol=0)
    scale = np.abs(j_ref).max(axis=(-1, -2), keepdims=True)
    np.testing.assert_allclose(j / scale, j_ref / scale, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cam.intrinsics_jacobian(points), jp_ref, rtol=1e-12, atol=1e-12)
    front = points[:, 2] > 0.05
    xy_u = points[front, :2] / points[front, 2:]
    if cam.model == "radtan":
        d_ref, dj_ref, _ = ref.radtan_distort(p8[4:], xy_u[:, 0], xy_u[:, 1])
    else:
        d_ref, dj3, _ = ref.equi_point(p8[4:], np.c_[xy_u, np.ones(len(xy_u))])
        dj_ref = dj3[..., :2]
    np.testing.assert_allclose(cam.distort(xy_u), d_ref, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(cam.distort_jacobian(xy_u), dj_ref, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("cam", CAMERAS, ids=["radtan", "equi"])
@given(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0))
def test_undistort_inverts_distort(cam, a, b):
    """undistort(distort(xy)) = xy inside the invertible region (a disc reaching 0.95 of its bound)."""
    bound = np.sqrt(cam.max_radius2) if cam.model == "radtan" else np.tan(min(cam.max_angle, 1.45))
    xy = np.array([a, b]) * min(bound * 0.95, 1.5) / np.sqrt(2)
    np.testing.assert_allclose(cam.undistort(cam.distort(xy)), xy, rtol=1e-11, atol=1e-13)


@given(st.floats(0.05, 1.0), st.floats(-np.pi, np.pi), st.floats(1.6, 2.6))
def test_equidistant_jacobian_beyond_90_degrees(rho_scale, phi, theta):
    """The fisheye Jacobian also for rays behind the image plane (θ > 90°, Z < 0)."""
    p = 2.0 * np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)]) * rho_scale
    _, j = TUMVI.project_jacobian(p)
    np.testing.assert_allclose(j, _central(TUMVI.project, p, 1e-6), rtol=1e-6, atol=1e-4)
