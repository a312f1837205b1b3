"""Camera–IMU calibration against a known target: extrinsic, time offset, biases and gravity in one batch.

The unknowns are the IMU state at every usable camera frame ``k`` (orientation ``R_wb,k``, position ``p_k`` and
velocity ``v_k`` in the target frame ``w``), the IMU biases (a random walk with one knot per frame, or one
constant pair), the camera pose in the body frame (``R_bc``, ``p_bc``: ``x_b = R_bc x_c + p_bc``), the time offset
``τ`` (a frame stamped ``t`` by the camera was taken at IMU time ``t + τ``), the direction of gravity in the
target frame (2 dof; its magnitude is given) and, with the default IMU model, the axis models of the gyro
(symmetric 3 × 3: scale factors and non-orthogonality) and of the accelerometer (full 3 × 3), applied to the
measurements as ``(I − Δ) y`` and carried through the preintegration like the biases (optionally also the positions
of the y and z accelerometer axes, Kalibr's size effect, Rehder et al. 2016).  The cost (a maximum
a-posteriori batch, as in Kalibr, Furgale et al. 2013, but in discrete time):

* every target corner's reprojection residual through the distorted camera model (intrinsics fixed), the body
  pose taken at ``t_k + τ`` by a first-order shift of the frame's state, ``R(t_k + τ) = R_k Exp(ω_k δ)``,
  ``p(t_k + τ) = p_k + v_k δ`` with ``δ = τ − τ_ref`` (Li & Mourikis 2014, IJRR 33(7); Qin & Shen 2018, IROS),
  with a Huber loss (IRLS weights) and the pixel σ re-estimated robustly (MAD) between passes;
* IMU preintegration factors between consecutive frames (Forster et al. 2017, ``calibration._preintegration``), bias
  corrected to first order, with the white-noise densities of the IMU;
* bias random-walk factors ``b_k+1 − b_k ~ N(0, σ_rw² Δt)`` (or one constant bias), and weak priors on the first
  bias (0 ± 0.1 rad/s, 0 ± 1 m/s²) and the axis models (0 ± 0.1) that only fix the scale of the problem.

It is solved by Levenberg–Marquardt on the normal equations (the reprojection blocks of every frame summed corner
by corner in a compiled kernel, ``_native.camera_imu_reprojection``, with a NumPy path for other camera models and
refined intrinsics; the IMU blocks in NumPy; the block-tridiagonal frame part factored by the compiled block
Cholesky recursion and the globals by their Schur complement).  Between
passes the frame states are re-anchored at ``t_k + τ`` and the IMU re-preintegrated at the current biases.

Start from no prior: per-frame PnP on the undistorted corners (:func:`dualpose.registration.pnp.solve_pnp_batch`),
rotation and coarse ``τ`` from gyro vs camera rotation rates (:func:`~dualpose.calibration.estimate_time_offset`
without an extrinsic), translation zero, velocities by finite differences, gravity from the velocity change
telescoped over the recording.  Covariance: the inverse of the Gauss–Newton information at the solution (the
per-corner noise is the estimated pixel σ; temporally correlated corner errors make it optimistic).
Results and the IMU-model discussion: docs/euroc.md.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Any, Literal, TypedDict, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp
from dualpose import _native
from dualpose.calibration._preintegration import (
    N_ACCEL_AXES,
    N_GYRO_AXES,
    N_SIZE_EFFECT,
    Preintegrated,
    accel_axes_matrix,
    gyro_axes_matrix,
    imu_factors,
    preintegrate,
)
from dualpose.calibration.time_offset import estimate_time_offset, gyro_mean_rates
from dualpose.registration.pnp import solve_pnp, solve_pnp_batch
from dualpose.types.camera import FrameCorrespondences
from dualpose.types.camera_models import DistortedCamera, RadTanCamera
from dualpose.types.imu import STANDARD_GRAVITY, ImuNoise

__all__ = [
    "CameraImuCalibration", "CameraImuExcitation", "CameraImuOutliers", "CameraImuStd", "calibrate_camera_imu"
]

#: a float64 array (the shapes are in the docstrings)
_Arr = NDArray[np.float64]
#: global unknowns after the frame states and bias knots: δε (3, body frame), δp_bc (3), δτ, δg (2)
_NG = 9
_BIAS_PRIOR = np.array([0.1, 0.1, 0.1, 1.0, 1.0, 1.0])  # rad/s, m/s²: only fixes the scale
_AXES_PRIOR = 0.1  # the axis-model parameters (dimensionless), likewise
#: relative cost decrease that ends the LM of a re-weighting pass (the final pass runs to 1e-7)
_PASS_TOLERANCE = 1e-5
#: the accepted ``imu_model`` values of :func:`calibrate_camera_imu`
_IMU_MODELS = ("calibrated", "scale_misalignment", "scale_misalignment_size_effect")


class CameraImuStd(TypedDict):
    """The ``std`` of :class:`CameraImuCalibration`: first-order standard deviations (see there)."""

    rotation_deg: NDArray[np.float64]
    translation_m: NDArray[np.float64]
    time_offset_s: float
    gyro_bias: NDArray[np.float64]
    accel_bias: NDArray[np.float64]
    gravity_target_deg: float


class CameraImuOutliers(TypedDict):
    """The ``outliers`` of :class:`CameraImuCalibration`: the frames not used (camera stamps, s) and the corners
    rejected."""

    frames_total: int
    no_detections: list[float]
    too_few_corners: list[float]
    outside_imu: list[float]
    pnp_failed: list[float]
    corners_total: int
    corners_rejected: int
    corners_rejected_fraction: float
    reject_threshold_px: float


class CameraImuExcitation(TypedDict):
    """The ``excitation`` of :class:`CameraImuCalibration`: how well the motion determined the lever arm and the
    time offset."""

    translation_std_m: NDArray[np.float64]
    translation_directions: NDArray[np.float64]
    time_offset_std_s: float
    warnings: list[str]


@dataclass
class CameraImuCalibration:
    """Result of :func:`calibrate_camera_imu`.

    Attributes
    ----------
    q_bc : ndarray (4,)
        Camera→body rotation xyzw (the camera axes in the IMU frame).
    p_bc : ndarray (3,)
        Camera centre in the IMU frame, m (``x_imu = R_bc x_cam + p_bc``).
    time_offset : float
        ``τ`` s: a frame stamped ``t`` by the camera was taken at IMU time ``t + τ``.
    gyro_bias, accel_bias : ndarray (3,)
        Mean of the bias track over the frames (rad/s, m/s²; equal to the constant bias with
        ``bias_model="constant"``).
    bias_t : ndarray (K,)
        Times of the bias knots (IMU clock, the input's time origin), s.  ``bias_track`` (K, 6): gyro, accel biases.
    gravity_target : ndarray (3,)
        Gravity in the target frame, m/s².
    std : dict
        First-order standard deviations: ``rotation_deg`` (3,) about the body x, y, z axes (``R̂_bc = Exp(ε)
        R_bc``), ``translation_m`` (3,), ``time_offset_s``, ``gyro_bias`` (3,), ``accel_bias`` (3,) (of the track
        mean), ``gravity_target_deg`` (RMS angle of the direction).
    covariance : ndarray (9, 9)
        Covariance of ``[ε (3), p_bc (3), τ, δg (2)]`` (rad, m, s, rad; ``gravity_basis`` spans δg).
    reprojection_rms_px : float
        RMS of the corner residuals (both axes) of the inlier corners, px.  ``pixel_sigma`` the robust (MAD) σ, px
        (``σ₀`` with ``noise_model="motion"``, whose ``κ`` is ``blur_time_s``, s; 0 otherwise).
    imu_chi2_per_dof : float
        Mean ``rᵀ Σ⁻¹ r / 9`` of the preintegration factors (≈ 1 when the IMU noise densities fit).
    outliers : dict
        Frames not used (``no_detections``, ``too_few_corners``, ``pnp_failed``: camera stamps) and corners
        rejected (count and fraction; residual above ``reject_sigmas`` σ).
    excitation : dict
        Eigen-directions of the marginal covariance of ``[p_bc, τ]``: ``translation_std_m`` (3,) along the
        ``translation_directions`` (3, 3 rows, worst first), ``time_offset_std_s``, and ``warnings``.
    gyro_misalignment : ndarray (3, 3)
        Post-hoc fit ``ω_meas ≈ M ω + b`` over the frame intervals (``M − I``: scale factors on the diagonal,
        axis misalignment off it); ``accel_misalignment`` likewise from the velocity increments.
    frames_used : int.  iterations : int (LM steps accepted).  runtime_s : float.
    camera_parameters : ndarray (8,)
        The camera's ``parameters`` used (refined with ``estimate_intrinsics``; ``camera_parameters_std`` then their
        σ, else empty).
    imu_axes : tuple
        With ``imu_model="scale_misalignment"``: ``(M_g, M_a)`` (3, 3) each, ``ω̃ = M_g (ω + b_g)``,
        ``f̃ = M_a (f + b_a)``; ``imu_axes_std`` (15,) the σ of the 6 gyro and 9 accelerometer parameters.
    accel_axis_positions : ndarray (3, 3)
        With ``imu_model="scale_misalignment_size_effect"``: the positions (rows ``r_x = 0``, ``r_y``, ``r_z``, m,
        body frame) of the accelerometer axes; ``accel_axis_positions_std`` (6,) the σ of ``r_y``, ``r_z``.  Empty
        otherwise.
    frame_pose_correction : ndarray (N, 6)
        Per used frame (times ``bias_t`` with the random-walk bias): the correction one Gauss–Newton step on the
        frame's corners alone would apply to the batch's pose of it, ``[rotation vector in the camera axes (rad),
        position in the target frame (m)]``; ``frame_pose_chi2`` (N,) its χ² under the pixel σ (≈ 6 when the
        corners and the IMU-tied trajectory agree; docs/euroc.md).
    initial : dict
        The starting values (gyro/camera rate registration): ``q_bc``, ``time_offset``, ``gyro_bias``.
    """

    q_bc: np.ndarray
    p_bc: np.ndarray
    time_offset: float
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    gravity_target: np.ndarray
    std: CameraImuStd
    covariance: np.ndarray
    reprojection_rms_px: float
    pixel_sigma: float
    imu_chi2_per_dof: float
    outliers: CameraImuOutliers
    excitation: CameraImuExcitation
    gyro_misalignment: np.ndarray
    accel_misalignment: np.ndarray
    frames_used: int
    iterations: int
    runtime_s: float
    bias_t: np.ndarray
    bias_track: np.ndarray
    initial: dict[str, Any] = field(default_factory=dict)
    camera_parameters: np.ndarray = field(default_factory=lambda: np.zeros(0))
    imu_axes: tuple[NDArray[np.float64], ...] = ()
    imu_axes_std: np.ndarray = field(default_factory=lambda: np.zeros(0))
    camera_parameters_std: np.ndarray = field(default_factory=lambda: np.zeros(0))
    blur_time_s: float = 0.0
    frame_pose_correction: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    frame_pose_chi2: np.ndarray = field(default_factory=lambda: np.zeros(0))
    accel_axis_positions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    accel_axis_positions_std: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def rotation_matrix(self) -> np.ndarray:
        """``R_bc`` (3, 3)."""
        R: _Arr = dp.matrix_from_quat(self.q_bc)
        return R

    @property
    def matrix(self) -> np.ndarray:
        """The camera pose in the IMU frame, ``T_bc`` (4, 4) (Kalibr/EuRoC ``T_BS``)."""
        T = np.eye(4)
        T[:3, :3] = self.rotation_matrix
        T[:3, 3] = self.p_bc
        return T


def _tangent_basis(g: np.ndarray) -> np.ndarray:
    """Two unit vectors (3, 2) orthogonal to ``g`` and to each other."""
    u = g / np.linalg.norm(g)
    a = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(u, a)
    e1 /= np.linalg.norm(e1)
    basis: _Arr = np.column_stack([e1, np.cross(u, e1)])
    return basis


def _cross_into(out: np.ndarray, a: np.ndarray, b: np.ndarray) -> None:
    """``out[...] = a × b`` on the last axis (broadcast), without :func:`numpy.cross`'s axis handling."""
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _interp3(t: np.ndarray, x: np.ndarray, tq: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(tq, t, x[:, c]) for c in range(3)])


def _check_inputs(imu_t: ArrayLike, gyro: ArrayLike, accel: ArrayLike, frames: object,
                  camera: object) -> tuple[_Arr, _Arr, _Arr]:  # fmt: skip
    imu_t = np.asarray(imu_t, dtype=np.float64)
    if imu_t.ndim != 1 or len(imu_t) < 10 or not np.all(np.isfinite(imu_t)) or np.any(np.diff(imu_t) <= 0):
        raise ValueError(f"imu_t must be a finite strictly increasing array of shape (N,), N >= 10; got {imu_t.shape}")
    out = []
    for name, x in (("gyro", gyro), ("accel", accel)):
        a = np.asarray(x, dtype=np.float64)
        if a.shape != (len(imu_t), 3) or not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be finite with shape ({len(imu_t)}, 3); got {a.shape}")
        out.append(a)
    if not isinstance(frames, FrameCorrespondences):
        raise TypeError(f"frames must be a FrameCorrespondences; got {type(frames).__name__}")
    for attr in ("project_jacobian", "ideal_pixels", "fx", "fy", "cx", "cy"):
        if not hasattr(camera, attr):
            raise TypeError(f"camera must provide {attr!r} (a camera model of dualpose.types); got {type(camera)}")
    return imu_t, out[0], out[1]


def _initial_poses(frames: FrameCorrespondences, keep: NDArray[np.intp], camera: DistortedCamera,
                   min_corners: int) -> tuple[_Arr, _Arr, _Arr, NDArray[np.bool_]]:  # fmt: skip
    """PnP on the undistorted corners of the frames ``keep`` (indices); returns ``R_wc`` (F, 3, 3), ``c_w`` (F, 3),
    the PnP RMS (F,) (NaN where it failed)."""
    K = np.array([[camera.fx, 0.0, camera.cx], [0.0, camera.fy, camera.cy], [0.0, 0.0, 1.0]])
    counts = frames.counts[keep]
    m = int(counts.max())
    b = len(keep)
    pix = np.zeros((b, m, 2))
    pts = np.zeros((b, m, 3))
    valid = np.arange(m)[None, :] < counts[:, None]
    rows = frames.offsets[keep][:, None] + np.arange(m)[None, :]
    rows = np.where(valid, rows, frames.offsets[keep][:, None])
    pix[:] = camera.ideal_pixels(frames.pixels[rows])
    pts[:] = frames.points[rows]
    R = np.full((b, 3, 3), np.nan)
    c = np.full((b, 3), np.nan)
    rms = np.full(b, np.nan)
    try:
        res = solve_pnp_batch(pix, pts, valid, K, threshold_px=10.0, failed="nan")  # a lost frame: NaN
        solved = np.isfinite(res.rms_px)
        R[solved] = dp.matrix_from_quat(res.q_wc[solved])
        c[solved] = res.c_w[solved]
        rms[solved] = res.rms_px[solved]
    except (ValueError, np.linalg.LinAlgError):
        for i in range(b):  # the batch refused a frame (degenerate points): one frame at a time
            try:
                r1 = solve_pnp(pix[i, valid[i]], pts[i, valid[i]], K)
            except (ValueError, np.linalg.LinAlgError):
                continue
            R[i], c[i], rms[i] = dp.matrix_from_quat(r1.q_wc), r1.c_w, r1.rms_px
    ok = np.isfinite(rms) & (counts >= min_corners)
    return R, c, rms, ok


#: a copy of the state of :class:`_Problem`: R, p, v, bias, R_bc, p_bc, τ, g, camera, axis-model deviation
_State = tuple[_Arr, _Arr, _Arr, _Arr, _Arr, _Arr, float, _Arr, DistortedCamera, _Arr]
#: what the reprojection Jacobian is built from: D (N, M, 2, 3), E (N, 3, 3), Rᵀ (N, 3, 3), y, x_b, x_c (N, M, 3)
_ReprojectionJacobian = tuple[_Arr, _Arr, _Arr, _Arr, _Arr, _Arr]


class _Problem:
    """The batch: fixed data, current state, residuals/normal equations (module docstring)."""

    def __init__(self, imu_t: _Arr, gyro: _Arr, accel: _Arr, t_frames: _Arr, offsets: NDArray[np.intp], pixels: _Arr,
                 points: _Arr, camera: DistortedCamera, noise: ImuNoise, gmag: float, bias_model: str,
                 intrinsics: bool = False, axes: bool = False, size_effect: bool = False,
                 size_effect_prior: float = 0.05) -> None:  # fmt: skip
        self.imu_t, self.gyro, self.accel = imu_t, gyro, accel
        self.t = t_frames  # (N,) camera stamps of the nodes, s
        n = len(t_frames)
        self.N = n
        counts = np.diff(offsets)
        m = int(counts.max())
        self.valid0 = np.arange(m)[None, :] < counts[:, None]
        rows = np.where(self.valid0, offsets[:-1, None] + np.arange(m)[None, :], offsets[:-1, None])
        self.rows = rows
        self.pix = pixels[rows]
        self.pts = points[rows]
        self.inlier = self.valid0.copy()
        self.camera = camera
        self.noise = noise
        self.gmag = gmag
        rw = bias_model == "random_walk"
        self.knot = np.arange(n) if rw else np.zeros(n, dtype=np.int64)
        self.K = int(self.knot.max()) + 1
        self.knot_t = t_frames.copy() if rw else np.array([t_frames.mean()])
        # variable layout: a band of per-frame blocks [φ, p, v (, bias knot)] in time order, then the border
        # (the constant bias if any, and the globals [ε, p_bc, τ, δg]), so the normal matrix is banded + border
        stride = 15 if rw else 9
        self.stride = stride
        self.nb = stride * n
        self.node_off = stride * np.arange(n)
        self.knot_off = self.node_off + 9 if rw else np.array([self.nb])
        self.gbase = self.nb + (0 if rw else 6)
        # after δg: the IMU model (the axis models, gyro symmetric 6 and accelerometer 9, then the size effect's 6
        # accelerometer axis positions), then the camera parameters (8); n_axes counts the whole IMU model
        self.n_matrices = N_GYRO_AXES + N_ACCEL_AXES if axes or size_effect else 0
        self.n_size = N_SIZE_EFFECT if size_effect else 0
        self.n_axes = self.n_matrices + self.n_size
        self.size_r = np.zeros(self.n_size)  # accelerometer y, z axis positions at the linearisation point, m
        self.size_prior = size_effect_prior
        self.n_intr = 8 if intrinsics else 0
        self.nvar = self.gbase + _NG + self.n_axes + self.n_intr
        self.correct_g = np.eye(3)  # measurement corrections (I − Δ) at the linearisation point
        self.correct_a = np.eye(3)
        self.theta = np.zeros(self.n_axes)  # axis-model deviation from it
        self.node_idx = self.node_off[:, None] + np.arange(9)
        self.knot_idx = self.knot_off[:, None] + np.arange(6)
        self.sigma_px = 1.0
        self.corner_scale = np.ones(self.valid0.shape)  # per-corner σ / sigma_px (the motion-blur noise model)
        self.huber = 1.5  # in σ
        self.blur_time = 0.0
        #: the compiled reprojection blocks (radial-tangential camera, intrinsics fixed); the NumPy path otherwise
        self.native = isinstance(camera, RadTanCamera) and not intrinsics
        self.intr0 = np.asarray(camera.parameters, dtype=np.float64).copy()
        self.intr_info = np.zeros(self.n_intr)  # 1/σ of a prior on the camera parameters at their given values

    # ----- state ---------------------------------------------------------------------------------------------
    def set_state(self, R: _Arr, p: _Arr, v: _Arr, bias: _Arr, R_bc: _Arr, p_bc: _Arr, tau: float, g: _Arr,
                  tau_ref: float) -> None:  # fmt: skip
        self.R, self.p, self.v, self.bias = R, p, v, bias
        self.R_bc, self.p_bc, self.tau, self.g = R_bc, p_bc, tau, g
        self.tau_ref = tau_ref
        self.relinearize()

    def state(self) -> _State:
        return (self.R.copy(), self.p.copy(), self.v.copy(), self.bias.copy(), self.R_bc.copy(), self.p_bc.copy(),
                self.tau, self.g.copy(), self.camera, self.theta.copy())  # fmt: skip

    def restore(self, s: _State) -> None:
        self.R, self.p, self.v, self.bias, self.R_bc, self.p_bc, self.tau, self.g, self.camera, self.theta = s

    def axes_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """The current measurement corrections ``(I − Δ)`` of the gyro and the accelerometer (3, 3) each."""
        if not self.n_matrices:
            return self.correct_g, self.correct_a
        nm = self.n_matrices
        return ((np.eye(3) - gyro_axes_matrix(self.theta[:N_GYRO_AXES])) @ self.correct_g,
                (np.eye(3) - accel_axes_matrix(self.theta[N_GYRO_AXES:nm])) @ self.correct_a)  # fmt: skip

    def relinearize(self) -> None:
        """Node times ``t + τ_ref``, body rates there and the preintegration at the current biases."""
        self.s = self.t + self.tau_ref
        self.correct_g, self.correct_a = self.axes_matrices()
        self.size_r = self.size_r + self.theta[self.n_matrices :]
        self.theta = np.zeros(self.n_axes)
        self.gyro_c = self.gyro @ self.correct_g.T
        self.accel_c = self.accel @ self.correct_a.T
        bn = self.bias[self.knot]
        self.omega = _interp3(self.imu_t, self.gyro_c, self.s) - bn[:, :3]
        n = self.noise
        self.pre: Preintegrated = preintegrate(
            self.imu_t, self.gyro_c, self.accel_c, self.s, bn[:-1, :3], bn[:-1, 3:],
            n.gyroscope_noise_density, n.accelerometer_noise_density, axes=self.n_matrices > 0,
            size_effect=self.size_r if self.n_size else None,
        )  # fmt: skip
        L = np.linalg.cholesky(np.linalg.inv(self.pre.covariance))  # Σ⁻¹ = L Lᵀ
        self.imu_whiten = np.swapaxes(L, 1, 2)
        dt_knot = np.diff(self.knot_t)
        rw = np.array([n.gyroscope_random_walk] * 3 + [n.accelerometer_random_walk] * 3)
        self.rw_scale = 1.0 / (rw[None, :] * np.sqrt(np.maximum(dt_knot, 1e-9))[:, None])

    def reanchor(self) -> None:
        """Move the node times to ``t + τ`` (first-order shift of each state) and re-preintegrate."""
        d = self.tau - self.tau_ref
        bn = self.bias[self.knot]
        f = _interp3(self.imu_t, self.accel_c, self.s) - bn[:, 3:]
        acc_w = np.einsum("kij,kj->ki", self.R, f) + self.g
        self.p = self.p + self.v * d + 0.5 * acc_w * d * d
        self.v = self.v + acc_w * d
        self.R = self.R @ dp.so3_exp(self.omega * d)
        self.tau_ref = self.tau
        self.relinearize()

    def retract(self, delta: _Arr) -> None:
        dn = delta[self.node_idx]
        self.R = self.R @ dp.so3_exp(dn[:, 0:3])
        self.p = self.p + dn[:, 3:6]
        self.v = self.v + dn[:, 6:9]
        self.bias = self.bias + delta[self.knot_idx]
        dg = delta[self.gbase :]
        self.R_bc = dp.so3_exp(dg[0:3]) @ self.R_bc
        self.p_bc = self.p_bc + dg[3:6]
        self.tau = self.tau + dg[6]
        self.g = dp.so3_exp(_tangent_basis(self.g) @ dg[7:9]) @ self.g
        self.theta = self.theta + dg[_NG : _NG + self.n_axes]
        if self.n_intr:
            self.camera = _with_parameters(self.camera, self.camera.parameters + dg[_NG + self.n_axes :])

    # ----- residuals -----------------------------------------------------------------------------------------
    @overload
    def reprojection(self, jac: Literal[True]) -> tuple[_Arr, NDArray[np.bool_], _ReprojectionJacobian]: ...

    @overload
    def reprojection(self, jac: Literal[False]) -> tuple[_Arr, NDArray[np.bool_], None]: ...

    def reprojection(self, jac: bool) -> tuple[_Arr, NDArray[np.bool_], _ReprojectionJacobian | None]:
        d = self.tau - self.tau_ref
        E = dp.so3_exp(self.omega * d)
        Rt = np.swapaxes(self.R, 1, 2)
        y = (self.pts - (self.p + self.v * d)[:, None, :]) @ self.R  # R_nᵀ (X − p(t)), batched (N, M, 3)
        xb = y @ E  # Eᵀ y
        xc = (xb - self.p_bc) @ self.R_bc  # R_bcᵀ (x_b − p_bc)
        front = xc[..., 2] > 1e-3
        xc_safe = np.where(front[..., None], xc, np.array([0.0, 0.0, 1.0]))
        parts: _ReprojectionJacobian | None = None
        if jac:
            pred, D = self.camera.project_jacobian(xc_safe)
            parts = (D, E, Rt, y, xb, xc_safe)
        else:
            pred = self.camera.project(xc_safe)
        r = pred - self.pix
        use = self.inlier & front
        return r, use, parts

    def robust(self, r: np.ndarray, use: np.ndarray) -> tuple[float, np.ndarray]:
        s = np.linalg.norm(r, axis=-1) / (self.sigma_px * self.corner_scale)
        c = self.huber
        rho = np.where(s <= c, s * s, 2 * c * s - c * c)
        w = np.where(s <= c, 1.0, c / np.maximum(s, 1e-300)) * use
        return float(np.sum(rho * use)), w

    def image_speed(self) -> np.ndarray:
        """Speed of every corner's image (N, M), px/s, from the frame's body rate and velocity: ``ẋ_b = −ω × x_b
        − R_wbᵀ v``, ``ẋ_c = R_bcᵀ ẋ_b``, ``u̇ = (∂π/∂x_c) ẋ_c``."""
        r, use, (D, E, Rt, y, xb, xc_safe) = self.reprojection(True)
        vb = np.einsum("nij,nj->ni", Rt, self.v)
        xdot_b = -np.cross(self.omega[:, None, :], xb) - vb[:, None, :]
        xdot_c = xdot_b @ self.R_bc
        return np.asarray(np.linalg.norm(np.einsum("nmij,nmj->nmi", D, xdot_c), axis=-1), dtype=np.float64)

    def fit_noise(self, r: np.ndarray, use: np.ndarray, model: str) -> None:
        """Re-estimate the pixel noise from the residuals ``r`` (N, M, 2) of the corners ``use``: ``sigma_px`` the
        robust (MAD) σ; with ``model="motion"`` the per-corner model ``σ² = σ₀² + (κ |u̇|)²`` (``κ`` s: the blur's
        effective duration; least squares of the squared residuals on the squared image speed); with
        ``model="frame"`` one σ per frame (:func:`_frame_sigmas`)."""
        if model == "frame":
            self.corner_scale = np.ones(self.valid0.shape)
            self.sigma_px = max(1.4826 * float(np.median(np.abs(r[use]))), 1e-3)
            self.corner_scale[:] = (_frame_sigmas(r, use, self.sigma_px) / self.sigma_px)[:, None]
            return
        if model != "motion":
            self.sigma_px = max(1.4826 * float(np.median(np.abs(r[use]))), 1e-3)
            return
        speed = self.image_speed()[use]
        e2 = 0.5 * np.sum(r[use] ** 2, axis=-1)
        A = np.column_stack([np.ones_like(speed), speed**2])
        a, b = np.linalg.lstsq(A, e2, rcond=None)[0]
        s0 = max(1.4826 * float(np.median(np.abs(r[use]))), 1e-3)
        a = a if a > 0 else s0**2
        b = max(float(b), 0.0)
        self.blur_time = math.sqrt(b)
        full = self.image_speed()
        self.corner_scale = np.sqrt(1.0 + (b / a) * full**2)
        # the MAD of the normalised residuals: σ₀ robustly, given the shape of the model
        self.sigma_px = max(1.4826 * float(np.median(np.abs(r[use] / self.corner_scale[use][:, None]))), 1e-3)

    def _native_reprojection(self, jacobians: bool) -> tuple[np.ndarray, np.ndarray, float]:
        """The per-frame reprojection blocks ``JᵀWJ`` (N, 16, 16), ``JᵀWr`` (N, 16) and the robust cost, compiled
        (``_native.camera_imu_reprojection``: the equations of :meth:`reprojection` and :meth:`normal_equations`)."""
        n, m = self.valid0.shape
        d = self.tau - self.tau_ref
        E = np.ascontiguousarray(dp.so3_exp(self.omega * d), dtype=np.float64)
        H = np.empty((n, 16, 16) if jacobians else (0, 16, 16))
        g = np.empty((n, 16) if jacobians else (0, 16))
        cost = np.empty(n)
        _native.camera_imu_reprojection(
            np.ascontiguousarray(self.camera.parameters, dtype=np.float64), np.ascontiguousarray(self.R),
            np.ascontiguousarray(self.p), np.ascontiguousarray(self.v), np.ascontiguousarray(self.omega), E,
            np.ascontiguousarray(self.R_bc).ravel(), np.ascontiguousarray(self.p_bc, dtype=np.float64),
            self.pts, self.pix, self.inlier.astype(np.float64), self.sigma_px * self.corner_scale, float(d),
            float(self.huber), int(jacobians), H, g, cost,
        )  # fmt: skip
        return H, g, float(np.sum(cost))

    def cost(self) -> float:
        if self.native:
            return self._native_reprojection(False)[2] + self._imu_cost()
        r, use, _ = self.reprojection(False)
        c_cam = self.robust(r, use)[0]
        return c_cam + self._imu_cost()

    def _imu_args(self) -> tuple[Preintegrated, _Arr, _Arr, _Arr, _Arr, _Arr, _Arr, _Arr, _Arr, _Arr, _Arr]:
        bk = self.bias[self.knot]
        return (self.pre, self.R[:-1], self.p[:-1], self.v[:-1], self.R[1:], self.p[1:], self.v[1:], bk[:-1, :3],
                bk[:-1, 3:], self.g, _tangent_basis(self.g))  # fmt: skip

    def imu_whitened(self, jac: bool) -> tuple[_Arr, _Arr | None]:
        nm = self.n_matrices
        ag, aa = (self.theta[:N_GYRO_AXES], self.theta[N_GYRO_AXES:nm]) if nm else (None, None)
        r, J = imu_factors(*self._imu_args(), jacobians=jac, axes_gyro=ag, axes_accel=aa,
                           size_effect=self.theta[nm:] if self.n_size else None)  # fmt: skip
        rw = np.einsum("kij,kj->ki", self.imu_whiten, r)
        Jw = self.imu_whiten @ J if J is not None else None
        return rw, Jw

    def _imu_cost(self) -> float:
        rw = self.imu_whitened(False)[0]
        rb = np.diff(self.bias, axis=0) * self.rw_scale
        rp = self.bias[0] / _BIAS_PRIOR
        return float(np.sum(rw**2) + np.sum(rb**2) + np.sum(rp**2) + np.sum(self._imu_model_prior() ** 2)
                     + np.sum(self._intr_prior() ** 2))

    def _imu_model_prior(self) -> _Arr:
        """Whitened prior residuals of the IMU model: the axis-model deviations (0 ± 0.1) and the size effect's
        accelerometer axis positions (0 ± ``size_prior`` m)."""
        nm = self.n_matrices
        r: _Arr = np.concatenate([self.theta[:nm] / _AXES_PRIOR, (self.size_r + self.theta[nm:]) / self.size_prior])
        return r

    def _intr_prior(self) -> _Arr:
        if not self.n_intr:
            return np.zeros(0)
        r: _Arr = (np.asarray(self.camera.parameters, dtype=np.float64) - self.intr0) * self.intr_info
        return r

    def camera_blocks(self) -> tuple[_Arr, _Arr, float]:
        """The per-frame reprojection blocks ``JᵀWJ`` (N, c, c) and ``JᵀWr`` (N, c) over [φ, p, v of the frame's
        node, ε, p_bc, τ (, the camera parameters)] (c = 16, + 8 with refined intrinsics), and the robust cost."""
        if self.native:
            return self._native_reprojection(True)
        n = self.N
        r, use, (D, E, Rt, y, xb, xc_safe) = self.reprojection(True)
        c_cam, w = self.robust(r, use)
        d = self.tau - self.tau_ref
        Rbc_t = self.R_bc.T
        A = Rbc_t @ np.swapaxes(E, 1, 2)  # (N, 3, 3): d x_c / d x_b ∘ Eᵀ
        m = D.shape[1]
        D2 = D.reshape(n, 2 * m, 3)
        DA = D2 @ A  # row-vector products as batched (2M × 3)(3 × 3) matrices
        DART = (DA @ Rt).reshape(n, m, 2, 3)
        DA = DA.reshape(n, m, 2, 3)
        DB = (D2 @ Rbc_t).reshape(n, m, 2, 3)
        nc = 16 + self.n_intr
        J = np.empty((n, m, 2, nc))
        _cross_into(J[..., 0:3], DA, y[:, :, None, :])  # aᵀ [y]× = (a × y)ᵀ
        J[..., 3:6] = -DART
        J[..., 6:9] = -DART * d
        _cross_into(J[..., 9:12], DB, (xb - self.p_bc)[:, :, None, :])
        J[..., 12:15] = -DB
        vb = np.einsum("nij,nj->ni", Rt, self.v)
        dxb_dtau = np.cross(xb, self.omega[:, None, :]) - np.einsum("nji,nj->ni", E, vb)[:, None, :]
        J[..., 15] = np.sum(DB * dxb_dtau[:, :, None, :], axis=-1)
        if self.n_intr:
            J[..., 16:] = self.camera.intrinsics_jacobian(xc_safe)
        sw = np.sqrt(w) / (self.sigma_px * self.corner_scale)
        Jw = (J * sw[..., None, None]).reshape(n, -1, nc)
        rw = (r * sw[..., None]).reshape(n, -1)
        return np.swapaxes(Jw, 1, 2) @ Jw, np.einsum("bri,br->bi", Jw, rw), c_cam

    def normal_equations(self) -> tuple[_Normal, np.ndarray, float]:
        """``H = JᵀWJ`` as :class:`_Normal` (band + border), the gradient ``JᵀWr`` and the cost."""
        n, K, gb = self.N, self.K, self.gbase
        acc = _Normal.empty(self.nvar, self.nb, self.stride)
        add = acc.add
        # reprojection: per corner 2 × 16 over [φ, p, v of its node, ε, p_bc, τ]
        glob = np.concatenate([gb + np.arange(7), gb + _NG + self.n_axes + np.arange(self.n_intr)])
        idx = np.concatenate([self.node_idx, np.broadcast_to(glob, (n, len(glob)))], axis=1)
        Hc, gc, c_cam = self.camera_blocks()
        acc.add_blocks(idx, Hc, gc)
        # IMU factors: 9 × 26 over [node i, node j, bias knot of i, δg]
        rI, JI = self.imu_whitened(True)
        assert JI is not None  # with jac=True
        gidx = np.broadcast_to(gb + np.arange(7, _NG + self.n_axes), (n - 1, 2 + self.n_axes))
        kidx = self.knot_idx[self.knot[:-1]]
        idx = np.concatenate([self.node_idx[:-1], self.node_idx[1:], kidx, gidx], axis=1)
        add(idx, JI, rI)
        # bias random walk and prior
        if K > 1:
            k = np.arange(K - 1)
            rb = np.diff(self.bias, axis=0) * self.rw_scale
            diag = self.rw_scale[:, :, None] * np.eye(6)
            pair = np.concatenate([self.knot_idx[k], self.knot_idx[k + 1]], axis=1)
            add(pair, np.concatenate([-diag, diag], axis=2), rb)
        else:
            rb = np.zeros((0, 6))
        rp = self.bias[0] / _BIAS_PRIOR
        add(self.knot_idx[:1], np.diag(1.0 / _BIAS_PRIOR)[None], rp[None])
        ra = self._imu_model_prior()
        if self.n_axes:
            w_prior = np.concatenate([np.full(self.n_matrices, 1.0 / _AXES_PRIOR),
                                      np.full(self.n_size, 1.0 / self.size_prior)])  # fmt: skip
            add((gb + _NG + np.arange(self.n_axes))[None], np.diag(w_prior)[None], ra[None])
        ri = self._intr_prior()
        if self.n_intr:
            add((gb + _NG + self.n_axes + np.arange(self.n_intr))[None], np.diag(self.intr_info)[None], ri[None])
        H, grad = acc, acc.gradient()
        cost = c_cam + float(np.sum(rI**2) + np.sum(rb**2) + np.sum(rp**2) + np.sum(ra**2) + np.sum(ri**2))
        return H, grad, cost


def _frame_sigmas(r: _Arr, use: NDArray[np.bool_], sigma: float) -> _Arr:
    """One pixel σ per frame (N,) from the residuals ``r`` (N, M, 2) of the corners ``use`` (N, M): a
    variance-component estimate (Förstner 1979; Koch, "Parameter estimation and hypothesis testing in linear
    models", 1999, § 3.6), made robust by taking the frame's MAD instead of its mean square, and corrected for the 6
    pose degrees of freedom the frame's own corners absorb (redundancy ``2 n − 6`` of ``2 n`` coordinates).  It is
    pooled with the recording's σ (``sigma``) in proportion to the redundancies, with the recording's σ counted as
    one frame's worth of 6 coordinates, so that a frame of few corners cannot set its own weight."""
    a = np.where(use[..., None], np.abs(r), np.nan).reshape(len(r), -1)
    n2 = 2.0 * use.sum(axis=1)
    red = np.maximum(n2 - 6.0, 1.0)
    some = n2 > 0
    mad = np.zeros(len(r))
    mad[some] = np.nanmedian(a[some], axis=1)
    s2 = np.where(some, (1.4826 * mad) ** 2 * n2 / red, sigma**2)
    pooled = (red * s2 + 6.0 * sigma**2) / (red + 6.0)
    out: _Arr = np.sqrt(np.maximum(pooled, 1e-6))
    return out


def _as_slice(index: np.ndarray) -> slice | np.ndarray:
    """``index`` (k,) as a slice when it is a run of consecutive integers, else unchanged."""
    if len(index) and np.all(np.diff(index) == 1):
        return slice(int(index[0]), int(index[-1]) + 1)
    return index


def _take2(H: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``H[:, rows][:, :, cols]`` (F, len(rows), len(cols)), by slices where the indices are consecutive."""
    r, c = _as_slice(rows), _as_slice(cols)
    out = H[:, r] if isinstance(r, slice) else H[:, rows]
    return out[:, :, c] if isinstance(c, slice) else out[:, :, cols]


class _Normal:
    """Normal matrix ``[[A, B], [Bᵀ, C]]``: ``A`` (nb, nb) block tridiagonal (the per-frame blocks of size ``s`` in
    time order: diagonal blocks ``D`` (N, s, s), super-diagonal ``U`` (N − 1, s, s)) and a dense border ``B``
    (nb, m), ``C`` (m, m), with the gradient ``g`` (nb + m,).  ``A`` is factored by the block Cholesky recursion
    (one small dense step per frame, compiled; LAPACK's banded Cholesky is as fast single-threaded, but its threaded
    BLAS made it a hundred times slower on busy cores) and the border by its Schur complement."""

    def __init__(self, D: np.ndarray, U: np.ndarray, B: np.ndarray, C: np.ndarray, g: np.ndarray):
        self.D, self.U, self.B, self.C, self.g = D, U, B, C, g
        self.s = D.shape[1]

    @classmethod
    def empty(cls, nvar: int, nb: int, s: int) -> _Normal:
        n, m = nb // s, nvar - nb
        return cls(np.zeros((n, s, s)), np.zeros((max(n - 1, 0), s, s)), np.zeros((nb, m)), np.zeros((m, m)),
                   np.zeros(nvar))  # fmt: skip

    def gradient(self) -> np.ndarray:
        return self.g

    def add(self, idx: np.ndarray, Jw: np.ndarray, rw: np.ndarray) -> None:
        """Add the factors ``Jw`` (F, r, c) with whitened residuals ``rw`` (F, r) over the unknowns ``idx`` (F, c).

        Each column is either a band unknown in the same position of a frame block for every factor (the block of
        the first band column, or the next one), or a border unknown; ``JᵀJ`` and ``Jᵀr`` go straight into the
        blocks (the blocks of one call are distinct across factors)."""
        self.add_blocks(idx, np.swapaxes(Jw, 1, 2) @ Jw, np.einsum("bri,br->bi", Jw, rw))

    def add_blocks(self, idx: np.ndarray, H: np.ndarray, gv: np.ndarray) -> None:
        """Add the factors' information ``H`` (F, c, c) and gradients ``gv`` (F, c) over ``idx`` (F, c) (as
        :meth:`add`)."""
        s, nb = self.s, len(self.B)
        band = idx[0] < nb
        bc, oc = np.flatnonzero(band), np.flatnonzero(~band)
        border = idx[0, oc] - nb
        if len(oc):
            self.C[np.ix_(border, border)] += H[:, oc][:, :, oc].sum(axis=0)
            self.g[nb + border] += gv[:, oc].sum(axis=0)
        if not len(bc):
            return
        blk = idx[:, bc] // s
        base = blk[:, 0]
        rel = blk[0] - base[0]
        off = idx[0, bc] % s
        if np.any(blk - base[:, None] != rel) or np.any(idx[:, bc] % s != off) or np.any(rel > 1) or np.any(rel < 0):
            raise ValueError("factor columns do not follow the block layout")
        gband = self.g[:nb].reshape(-1, s)
        Bb = self.B.reshape(-1, s, self.B.shape[1])
        consecutive = bool(np.all(np.diff(base) == 1))
        for a in (0, 1):
            ca = bc[rel == a]
            if not len(ca):
                continue
            oa = _as_slice(off[rel == a])
            # the factors' frame blocks: a slice when they are consecutive frames (every factor kind here)
            ba = slice(int(base[0]) + a, int(base[-1]) + a + 1) if consecutive else (base + a)[:, None]
            bi = (base + a)[:, None]
            if isinstance(ba, slice) and isinstance(oa, slice):
                gband[ba, oa] += gv[:, ca]
            else:
                gband[bi, off[rel == a][None, :]] += gv[:, ca]
            if len(oc):
                bs = _as_slice(border)
                if isinstance(ba, slice) and isinstance(oa, slice) and isinstance(bs, slice):
                    Bb[ba, oa, bs] += _take2(H, ca, oc)
                else:
                    Bb[bi[:, :, None], off[rel == a][None, :, None], border[None, None, :]] += _take2(H, ca, oc)
            for b_ in (a, a + 1):
                cb = bc[rel == b_]
                if not len(cb):
                    continue
                T = self.D if b_ == a else self.U
                ob = _as_slice(off[rel == b_])
                if isinstance(ba, slice) and isinstance(oa, slice) and isinstance(ob, slice):
                    T[ba, oa, ob] += _take2(H, ca, cb)
                else:
                    bi = (base + a)[:, None, None]
                    T[bi, off[rel == a][None, :, None], off[rel == b_][None, None, :]] += _take2(H, ca, cb)

    def _factor_band(self, lam: float) -> tuple[np.ndarray, np.ndarray]:
        """Block Cholesky ``A = L Lᵀ`` of the band damped by ``1 + lam`` on the diagonal (compiled,
        ``_native.block_tridiagonal_factor``): the inverses of ``L``'s diagonal blocks and its sub-diagonal blocks."""
        n, s = self.D.shape[:2]
        Linv = np.empty((n, s, s))
        Lsub = np.empty((max(n - 1, 0), s, s))
        if not _native.block_tridiagonal_factor(np.ascontiguousarray(self.D), np.ascontiguousarray(self.U),
                                                float(lam), Linv, Lsub):  # fmt: skip
            raise np.linalg.LinAlgError("the frame band of the normal matrix is not positive definite")
        return Linv, Lsub

    def _solve_band(self, F: tuple[np.ndarray, np.ndarray], b: np.ndarray) -> np.ndarray:
        """``A⁻¹ b`` for ``b`` (nb,) or (nb, q) with the factor of :meth:`_factor_band`."""
        Linv, Lsub = F
        n, s = Linv.shape[:2]
        bb = np.ascontiguousarray(b.reshape(n, s, -1), dtype=np.float64)
        x = np.empty_like(bb)
        _native.block_tridiagonal_solve(Linv, Lsub, bb, x)
        return x.reshape(b.shape)

    def factor(self, lam: float = 0.0) -> tuple[tuple[_Arr, _Arr], _Arr, _Arr]:
        """Factor of the band (damped by ``1 + lam`` on the diagonal), ``A⁻¹B`` and the border's Schur complement."""
        F = self._factor_band(lam)
        XB = self._solve_band(F, self.B)
        S = self.C + lam * np.diag(np.diag(self.C)) - self.B.T @ XB
        return F, XB, S

    def solve(self, g: _Arr, lam: float) -> _Arr:
        """``−(H + λ diag H)⁻¹ g``."""
        nb = len(self.B)
        F, XB, S = self.factor(lam)
        x0 = self._solve_band(F, g[:nb])
        db = -np.linalg.solve(S, g[nb:] - self.B.T @ x0)
        return np.concatenate([-x0 - XB @ db, db])

    def covariance(self, band_combinations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``H⁻¹`` of the border (m, m) and of the linear combinations ``cᵀ x_band`` (columns of
        ``band_combinations`` (nb, q)), (q, q)."""
        F, XB, S = self.factor(0.0)
        Sinv = np.linalg.inv(S)
        if band_combinations.shape[1] == 0:
            return Sinv, np.zeros((0, 0))
        y = self._solve_band(F, band_combinations)
        w = self.B.T @ y
        return Sinv, band_combinations.T @ y + w.T @ Sinv @ w


def _with_parameters(camera: DistortedCamera, params: _Arr) -> DistortedCamera:
    """The same camera model with ``parameters`` (fx, fy, cx, cy, 4 distortion coefficients) replaced."""
    names = ("fx", "fy", "cx", "cy", *camera.DISTORTION_NAMES)
    return dataclasses.replace(camera, **{k: float(v) for k, v in zip(names, params, strict=True)})


def _levenberg_marquardt(prob: _Problem, max_iterations: int, tol: float = 1e-7) -> int:
    """LM (Marquardt's diagonal damping) on the current model, until a step lowers the cost by less than ``tol``
    (relative); returns the accepted steps."""
    lam = 1e-5
    accepted = 0
    H, g, cost = prob.normal_equations()
    for _ in range(max_iterations):
        step_ok = False
        for _try in range(8):
            try:
                delta = H.solve(g, lam)
            except np.linalg.LinAlgError:
                lam *= 10
                continue
            saved = prob.state()
            prob.retract(delta)
            new = prob.cost()
            if np.isfinite(new) and new < cost:
                step_ok = True
                lam = max(lam / 3.0, 1e-9)
                break
            prob.restore(saved)
            lam *= 8.0
        if not step_ok:
            break
        accepted += 1
        if (cost - new) / max(cost, 1e-300) < tol:
            break
        H, g, cost = prob.normal_equations()
    return accepted


def _fit_misalignment(x_true: np.ndarray, x_meas: np.ndarray) -> np.ndarray:
    """Least-squares ``x_meas ≈ M x_true + b`` (rows); returns ``M − I`` (3, 3)."""
    A = np.column_stack([x_true, np.ones(len(x_true))])
    coef = np.linalg.lstsq(A, x_meas, rcond=None)[0]
    M: _Arr = coef[:3].T - np.eye(3)
    return M


def calibrate_camera_imu(
    imu_t: np.ndarray,
    gyro: np.ndarray,
    accel: np.ndarray,
    frames: FrameCorrespondences,
    camera: DistortedCamera,
    imu_noise: ImuNoise,
    gravity_magnitude: float = STANDARD_GRAVITY,
    bias_model: str = "random_walk",
    min_corners: int = 8,
    min_frames: int = 40,
    max_offset: float = 0.1,
    reject_sigmas: float = 5.0,
    passes: int = 3,
    max_iterations: int = 30,
    estimate_intrinsics: bool = False,
    imu_model: str = "scale_misalignment",
    noise_model: str = "uniform",
    huber: float = 1.5,
    intrinsics_prior_sigma: ArrayLike | None = None,
    size_effect_prior_sigma: float = 0.05,
) -> CameraImuCalibration:
    """Calibrate the camera–IMU extrinsic, time offset, IMU biases and target gravity from one recording.

    Parameters
    ----------
    imu_t : (S,) IMU times, s.  gyro : (S, 3) rad/s.  accel : (S, 3) m/s² (specific force), body frame.
    frames : FrameCorrespondences
        Target corners per camera frame: stamps ``t`` (F,) in the IMU's time unit and origin (camera clock), raw
        distorted ``pixels`` (M, 2) and their target-frame ``points`` (M, 3), m.
    camera : a camera model of :mod:`dualpose.types` with ``project``, ``project_jacobian`` and ``ideal_pixels``
        (intrinsics and distortion are held fixed).
    imu_noise : ImuNoise
        White-noise densities and bias random walks (Kalibr ``imu.yaml`` units).
    gravity_magnitude : float
        m/s²; only the direction is estimated.
    bias_model : ``"random_walk"`` (one knot per frame) or ``"constant"``.
    min_corners : int
        Frames with fewer corners are not used (PnP start and the 6-dof frame state need them).
    min_frames : int
        Refuse with fewer usable frames.
    max_offset : float
        ``|τ|`` searched by the rate correlation, s.
    reject_sigmas : float
        Corners whose residual exceeds this many pixel σ after a pass are rejected in the next.
    passes, max_iterations : int
        Outer passes (σ re-estimate, rejection, re-anchoring) and LM steps per pass.
    estimate_intrinsics : bool
        Also refine the camera's 8 parameters (``camera.parameters``: fx, fy, cx, cy and the distortion) from the
        same corners (off by default: the intrinsics are taken as calibrated).
    imu_model : ``"scale_misalignment"`` (default): white noise, bias random walk and a symmetric 3 × 3 gyro and a
        full 3 × 3 accelerometer axis model, ``ω̃ = M_g (ω + b_g)``, ``f̃ = M_a (f + b_a)`` (scale factors,
        non-orthogonality, the accelerometer's rotation relative to the gyro); ``"calibrated"``: without the axis
        models (``M = I``); ``"scale_misalignment_size_effect"``: the axis models and Kalibr's accelerometer size
        effect (Rehder et al. 2016, ICRA; ``calibration._preintegration.size_effect_jacobian``): the
        y and z accelerometer axes sit at their own positions ``r_y``, ``r_z`` (m, body frame; the x axis is the
        origin of the body frame, so ``p_bc`` refers to it), each measuring the specific force of its point,
        ``e_iᵀ (f + α × r_i + ω × (ω × r_i))`` with ``α`` the central difference of the gyro samples.
    noise_model : ``"uniform"`` (default): one pixel σ for every corner (MAD of the residuals after each pass);
        ``"motion"``: per-corner ``σ² = σ₀² + (κ |u̇|)²`` with ``|u̇|`` the speed of the corner's image (px/s, from
        the frame's body rate and velocity) and ``σ₀``, ``κ`` (s, the blur's effective duration) fitted to the
        squared residuals after each pass — motion blur of a global-shutter camera (docs/euroc.md); ``"frame"``: one
        σ per frame, a robust variance-component estimate from that frame's residuals after each pass, pooled with
        the recording's σ (blur, exposure and focus differ from frame to frame; docs/euroc.md).
    huber : float
        Huber threshold of the reprojection loss, in σ (IRLS weights).
    intrinsics_prior_sigma : (8,) array, optional
        With ``estimate_intrinsics``: σ of a Gaussian prior on each camera parameter (``camera.parameters``: fx, fy,
        cx, cy in px, then the distortion coefficients) at its given value; ``inf`` leaves it free (the default
        when omitted: all free).  A small σ on the principal point keeps it where the intrinsic calibration put it:
        the pan and tilt of the extrinsic and the principal point are otherwise nearly interchangeable
        (docs/euroc.md).
    size_effect_prior_sigma : float
        With ``imu_model="scale_misalignment_size_effect"``: σ (m) of a zero-mean Gaussian prior on each coordinate
        of ``r_y`` and ``r_z`` (the default 5 cm is weak against an IMU package of about 1 cm).

    Raises
    ------
    ValueError
        Bad shapes, no time overlap between the IMU and the frames, fewer than ``min_frames`` usable frames.
    TypeError
        ``frames`` or ``camera`` of the wrong kind.
    """
    start = time.perf_counter()
    imu_t, gyro, accel = _check_inputs(imu_t, gyro, accel, frames, camera)
    if imu_model not in _IMU_MODELS:
        raise ValueError(f"imu_model must be one of {', '.join(map(repr, _IMU_MODELS))}; got {imu_model!r}")
    if not (math.isfinite(size_effect_prior_sigma) and size_effect_prior_sigma > 0):
        raise ValueError(f"size_effect_prior_sigma must be a finite σ > 0 (m); got {size_effect_prior_sigma!r}")
    if bias_model not in ("random_walk", "constant"):
        raise ValueError(f"bias_model must be 'random_walk' or 'constant'; got {bias_model!r}")
    if noise_model not in ("uniform", "motion", "frame"):
        raise ValueError(f"noise_model must be 'uniform', 'motion' or 'frame'; got {noise_model!r}")
    if not huber > 0:
        raise ValueError(f"huber must be > 0 (in pixel σ); got {huber!r}")
    prior_sigma = None
    if intrinsics_prior_sigma is not None:
        prior_sigma = np.asarray(intrinsics_prior_sigma, dtype=np.float64)
        n_par = len(np.asarray(camera.parameters))
        if not estimate_intrinsics:
            raise ValueError("intrinsics_prior_sigma needs estimate_intrinsics=True")
        if prior_sigma.shape != (n_par,) or not np.all(prior_sigma > 0):  # NaN fails the comparison
            raise ValueError(f"intrinsics_prior_sigma must have shape ({n_par},) (the camera's parameters) with "
                             f"every σ > 0 (inf: free); got {intrinsics_prior_sigma!r}")  # fmt: skip
    ft = np.asarray(frames.t, dtype=np.float64)
    inside = (ft - max_offset > imu_t[0]) & (ft + max_offset < imu_t[-1])
    if not inside.any():
        raise ValueError(f"no time overlap: frames span [{ft.min():.3f}, {ft.max():.3f}] s, the IMU "
                         f"[{imu_t[0]:.3f}, {imu_t[-1]:.3f}] s (same clock and origin expected)")  # fmt: skip
    counts = frames.counts
    no_det = counts == 0
    few = (counts > 0) & (counts < min_corners)
    cand = np.flatnonzero(inside & ~no_det & ~few)
    if len(cand) < min_frames:
        raise ValueError(f"only {len(cand)} frames with >= {min_corners} corners inside the IMU record; need "
                         f"{min_frames}")  # fmt: skip
    R_wc, c_w, pnp_rms, ok = _initial_poses(frames, cand, camera, min_corners)
    pnp_failed = cand[~ok]
    used = cand[ok]
    R_wc, c_w = R_wc[ok], c_w[ok]
    if len(used) < min_frames:
        raise ValueError(f"only {len(used)} frames with a PnP pose; need {min_frames}")
    t_used = ft[used]

    # rotation, coarse τ and gyro bias from the rates (no extrinsic given)
    coarse = estimate_time_offset(imu_t, gyro, t_used, dp.quat_from_matrix(R_wc), None, max_offset=max_offset)
    R_bc = dp.matrix_from_quat(coarse.q_bc)
    tau0 = float(coarse.offset)
    R_wb = R_wc @ R_bc.T
    p_wb = c_w.copy()  # translation starts at zero
    v_wb = np.column_stack([np.gradient(p_wb[:, c], t_used) for c in range(3)])

    sub = np.concatenate([[0], np.cumsum(counts[used])])
    rows = np.concatenate([np.arange(frames.offsets[k], frames.offsets[k + 1]) for k in used])
    prob = _Problem(imu_t, gyro, accel, t_used, sub, frames.pixels[rows], frames.points[rows], camera, imu_noise,
                    float(gravity_magnitude), bias_model, estimate_intrinsics,
                    imu_model == "scale_misalignment", imu_model == "scale_misalignment_size_effect",
                    float(size_effect_prior_sigma))  # fmt: skip
    if prior_sigma is not None:
        prob.intr_info = 1.0 / prior_sigma
    bias = np.zeros((prob.K, 6))
    bias[:, :3] = coarse.gyro_bias
    # gravity from the telescoped velocity change: Σ (v_j − v_i) = g T + Σ R_i Δv_ij
    pre0 = preintegrate(imu_t, gyro, accel, t_used + tau0, np.broadcast_to(coarse.gyro_bias, (len(used) - 1, 3)),
                        np.zeros((len(used) - 1, 3)), 0.0, 0.0)  # fmt: skip
    g_sum = v_wb[-1] - v_wb[0] - np.einsum("kij,kj->i", R_wb[:-1], pre0.dv)
    g0 = g_sum / np.linalg.norm(g_sum) * gravity_magnitude
    pix_sigma0 = float(np.nanmedian(pnp_rms[ok]))
    prob.sigma_px = max(pix_sigma0, 0.05)
    prob.huber = float(huber)
    prob.set_state(R_wb, p_wb, v_wb, bias, R_bc, np.zeros(3), tau0, g0, tau0)

    # first: a pass with the lever arm and velocities settling (everything free), then re-weighting passes (to a
    # looser tolerance: the weights and the anchoring change after each), then the final pass
    iterations = 0
    for _pass in range(passes):
        iterations += _levenberg_marquardt(prob, max_iterations, _PASS_TOLERANCE)
        r, use, _ = prob.reprojection(False)
        rn = np.linalg.norm(r, axis=-1)
        prob.fit_noise(r, prob.inlier & use, noise_model)
        prob.inlier = prob.valid0 & (rn < reject_sigmas * prob.sigma_px * prob.corner_scale)
        prob.reanchor()
    iterations += _levenberg_marquardt(prob, max_iterations)

    # covariance of the globals (and the bias means) from the information at the solution
    H, _, _ = prob.normal_equations()
    n, K = prob.N, prob.K
    comb = np.zeros((prob.nb, 6 if K > 1 else 0))
    for c in range(comb.shape[1]):
        comb[prob.knot_idx[:, c], c] = 1.0 / K
    try:
        c_border, c_mean = H.covariance(comb)
    except np.linalg.LinAlgError:
        c_border, c_mean = np.full((prob.nvar - prob.nb,) * 2, np.nan), np.full((comb.shape[1],) * 2, np.nan)
    og = prob.gbase - prob.nb
    cov_g = c_border[og : og + _NG, og : og + _NG]
    na = prob.n_axes
    cov_axes = c_border[og + _NG : og + _NG + na, og + _NG : og + _NG + na]
    cov_intr = c_border[og + _NG + na :, og + _NG + na :]
    cov_g = 0.5 * (cov_g + cov_g.T)
    c_bias = c_mean if K > 1 else c_border[:6, :6]
    std_all = np.sqrt(np.maximum(np.concatenate([np.diag(cov_g), np.diag(c_bias)]), 0.0))

    # per frame: the pose correction the frame's corners alone would apply to the batch's pose (one Gauss–Newton
    # step on its 6 pose unknowns) and its χ² (≈ 6 when corners and IMU-tied trajectory agree within the pixel σ)
    Hc, gc, _ = prob.camera_blocks()
    Hp, gp = Hc[:, :6, :6], gc[:, :6]
    try:
        corr = -np.linalg.solve(Hp, gp[..., None])[..., 0]
    except np.linalg.LinAlgError:
        corr = np.full((n, 6), np.nan)
    frame_chi2 = -np.einsum("ki,ki->k", corr, gp)
    corr[:, :3] = corr[:, :3] @ prob.R_bc  # body-frame rotation → camera axes (R_bcᵀ φ)

    r, use, _ = prob.reprojection(False)
    inl = prob.inlier & use
    rms = float(np.sqrt(np.mean(r[inl] ** 2)))
    rI = prob.imu_whitened(False)[0]
    chi2 = float(np.mean(np.sum(rI**2, axis=1)) / 9.0)
    n_rej = int(np.sum(prob.valid0 & ~prob.inlier))

    # excitation: eigen-directions of Cov([p_bc, τ])
    ct = cov_g[3:7, 3:7]
    lam, vec = np.linalg.eigh(cov_g[3:6, 3:6])
    order = np.argsort(lam)[::-1]
    tr_std = np.sqrt(np.maximum(lam[order], 0.0))
    warnings: list[str] = []
    if tr_std[0] > 0.005:
        worst = np.round(vec[:, order[0]], 3).tolist()
        warnings.append(f"translation poorly excited: std {1e3 * tr_std[0]:.1f} mm along {worst} (rotate the rig "
                        "more, about several axes)")  # fmt: skip
    if math.sqrt(ct[3, 3]) > 0.002:
        warnings.append(f"time offset poorly excited: std {1e3 * math.sqrt(ct[3, 3]):.2f} ms")
    if lam[order[-1]] <= 0 or not np.all(np.isfinite(cov_g)):
        warnings.append("information matrix not positive definite: some parameters are unobservable")

    # post-hoc IMU axis model: mean gyro over each interval vs the estimated mean body rate
    s = prob.s
    rel = np.swapaxes(prob.R[:-1], 1, 2) @ prob.R[1:]
    dt = np.diff(s)
    w_est = dp.so3_log(rel) / dt[:, None]
    w_meas = gyro_mean_rates(imu_t, gyro, s[:-1], s[1:])
    short = dt < 0.2
    gyro_M = _fit_misalignment(w_est[short], w_meas[short])
    bk = prob.bias[prob.knot]
    dv_true = np.einsum("kji,kj->ki", prob.R[:-1], prob.v[1:] - prob.v[:-1] - prob.g * dt[:, None])
    pre_nb = preintegrate(imu_t, gyro, accel, s, bk[:-1, :3], np.zeros((n - 1, 3)), 0.0, 0.0)
    acc_M = _fit_misalignment(dv_true[short] / dt[short, None], pre_nb.dv[short] / dt[short, None])

    q_bc = dp.quat_from_matrix(prob.R_bc)
    positions = np.zeros((0, 3))
    if prob.n_size:  # rows r_x = 0, r_y, r_z
        positions = np.vstack([np.zeros(3), (prob.size_r + prob.theta[prob.n_matrices :]).reshape(2, 3)])
    std = CameraImuStd(
        rotation_deg=np.degrees(std_all[0:3]),
        translation_m=std_all[3:6],
        time_offset_s=float(std_all[6]),
        gyro_bias=std_all[_NG : _NG + 3],
        accel_bias=std_all[_NG + 3 : _NG + 6],
        gravity_target_deg=float(np.degrees(math.sqrt(max(cov_g[7, 7] + cov_g[8, 8], 0.0)))),
    )
    outliers = CameraImuOutliers(
        frames_total=int(len(ft)),
        no_detections=ft[no_det].tolist(),
        too_few_corners=ft[few].tolist(),
        outside_imu=ft[~inside & ~no_det].tolist(),
        pnp_failed=ft[pnp_failed].tolist(),
        corners_total=int(prob.valid0.sum()),
        corners_rejected=n_rej,
        corners_rejected_fraction=n_rej / max(int(prob.valid0.sum()), 1),
        reject_threshold_px=reject_sigmas * prob.sigma_px,
    )
    excitation = CameraImuExcitation(
        translation_std_m=tr_std,
        translation_directions=vec[:, order].T,
        time_offset_std_s=float(math.sqrt(max(ct[3, 3], 0.0))),
        warnings=warnings,
    )
    return CameraImuCalibration(
        q_bc=q_bc, p_bc=prob.p_bc.copy(), time_offset=float(prob.tau), gyro_bias=prob.bias[:, :3].mean(axis=0),
        accel_bias=prob.bias[:, 3:].mean(axis=0), gravity_target=prob.g.copy(), std=std, covariance=cov_g,
        reprojection_rms_px=rms, pixel_sigma=prob.sigma_px, imu_chi2_per_dof=chi2, outliers=outliers,
        excitation=excitation, gyro_misalignment=gyro_M, accel_misalignment=acc_M, frames_used=n,
        iterations=iterations, runtime_s=time.perf_counter() - start, bias_t=prob.knot_t + prob.tau_ref,
        bias_track=prob.bias.copy(),
        initial={"q_bc": coarse.q_bc, "time_offset": tau0, "gyro_bias": coarse.gyro_bias},
        camera_parameters=np.asarray(prob.camera.parameters, dtype=np.float64),
        imu_axes=tuple(np.linalg.inv(m) for m in prob.axes_matrices()) if na else (),
        imu_axes_std=np.sqrt(np.maximum(np.diag(cov_axes)[: prob.n_matrices], 0.0)) if na else np.zeros(0),
        accel_axis_positions=positions,
        accel_axis_positions_std=np.sqrt(np.maximum(np.diag(cov_axes)[prob.n_matrices :], 0.0)),
        camera_parameters_std=np.sqrt(np.maximum(np.diag(cov_intr), 0.0)) if prob.n_intr else np.zeros(0),
        blur_time_s=float(prob.blur_time),
        frame_pose_correction=corr,
        frame_pose_chi2=frame_chi2,
    )  # fmt: skip
