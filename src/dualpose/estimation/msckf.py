"""Visual–inertial odometry from feature tracks: the multi-state-constraint Kalman filter (MSCKF; Mourikis &
Roumeliotis, "A multi-state constraint Kalman filter for vision-aided inertial navigation", ICRA 2007), in the
design of OpenVINS (Geneva et al., "OpenVINS: a research platform for visual-inertial estimation", ICRA 2020).

State (docs/vio.md):

* the IMU nominal state :data:`~dualpose.estimation.state.ESKF_STATE` (16,) ``[p_wb, v_w, q_wb (xyzw), b_g, b_a]``
  with the error state :data:`~dualpose.estimation.state.ESKF_ERROR` (15,) of the error-state filter
  (:mod:`dualpose.estimation.eskf`, Solà 2017; local attitude error ``q = q̂ ⊗ Exp(δθ)``), propagated by the same
  native kernel (``msckf_propagate``, ``src/native/estimation/msckf.cpp``);
* a sliding window of ``C ≤ max_clones`` clones of the IMU pose ``[p_wb (3), q_wb (4)]`` taken at the camera
  times (stochastic cloning), each with a 6-dof error ``[δp, δθ]`` (:data:`MSCKF_CLONE_ERROR`);
* up to ``max_slam`` long-lived features as world points (OpenVINS' SLAM features, 3 each) and the camera–IMU time
  offset (1); the full covariance is ``(15 + 6C + 3L + 1)²`` in that order.

A feature that is not a SLAM feature is used once, when its track ends or when its oldest observation would leave
the window: it is triangulated from the window (linear midpoint, then Gauss–Newton on the inverse depth in its first
camera), its reprojection residuals are linearised at the clones' *first estimates* (FEJ, Huang et al. 2010: the
values the clones had when they were taken) and the propagation's transition at the IMU state's first estimate (the
propagated state before an update), so that the four unobservable directions -- position and yaw -- stay
unobservable; the feature Jacobian is removed by projecting onto its left nullspace (Givens rotations), and the
``2m − 3`` projected rows pass a per-feature χ² gate. The accepted rows of all features of a frame are stacked,
compressed by a QR decomposition when they outnumber the state, and fused in one EKF update. A track that spans the
whole window becomes a SLAM feature (delayed initialisation from the three rows the projection sets aside), updated
at every frame it is seen in and marginalised when it ends.  All per-feature work is native (``msckf_features``,
``msckf_slam_rows``, ``msckf_update``).

The filter initialises itself from the rest period at the start (:meth:`MsckfVio.from_rest`): gravity direction
and gyro bias from the static samples (:func:`~dualpose.estimation.initialization.static_alignment`), zero velocity,
the world frame the gravity-aligned start frame (yaw 0, position 0).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import chi2

import dualpose as dp
from dualpose import _native
from dualpose.estimation._stream import saved_quaternion
from dualpose.estimation.eskf import EskfStateAccessors
from dualpose.estimation.initialization import StaticAlignment, detect_rest, static_alignment
from dualpose.estimation.interface import AttitudeFix, Estimator, LinearMeasurement, UpdateResult
from dualpose.estimation.state import ESKF_ERROR, ESKF_STATE, MSCKF_CLONE_ERROR
from dualpose.types import CameraFrame, ImuNoise, _inputs
from dualpose.types.features import TrackFrame, TrackRecording

__all__ = ["MsckfVio", "MsckfOptions", "TrackUpdate", "VioResult"]

_NE = ESKF_ERROR.dim
_CE = MSCKF_CLONE_ERROR.dim
_REST_GUARD = 0.2  # s, one window of detect_rest
_POSE_ROWS = np.r_[np.arange(3) + ESKF_ERROR.offset("position"), np.arange(3) + ESKF_ERROR.offset("attitude")]
_NO_OFFSET = np.zeros(0)
_IMU_ROWS = np.arange(_NE)
_VEL, _BG = ESKF_STATE.slice("velocity"), ESKF_STATE.slice("gyro_bias")


class _TrackTable:
    """``np.isin`` for the non-negative int64 track ids of the frames and the window by a lookup table (three array
    operations, no sort, no allocation): :meth:`cover` must have seen every id a query holds; ids the table cannot
    hold (negative or from 2²² on) switch it to ``np.isin`` for good."""

    LIMIT = 1 << 22

    def __init__(self) -> None:
        self.table = np.zeros(0, bool)
        self.direct = True

    def cover(self, ids: NDArray[np.int64]) -> None:
        if not self.direct or len(ids) == 0:
            return
        lo, hi = int(ids.min()), int(ids.max())
        if lo < 0 or hi >= self.LIMIT:
            self.direct = False
        elif hi >= len(self.table):
            self.table = np.zeros(max(hi + 1, 2 * len(self.table)), bool)

    def member(self, a: NDArray[np.int64], b: NDArray[np.int64]) -> NDArray[np.bool_]:
        """Whether each of ``a`` is in ``b``."""
        if not self.direct:
            return np.isin(a, b)
        t = self.table
        t[b] = True
        found: NDArray[np.bool_] = t[a]
        t[b] = False
        return found


@dataclass(frozen=True)
class MsckfOptions:
    """Settings of :class:`MsckfVio` (one set of defaults, those of OpenVINS where it has one).

    ``max_clones`` the window length (OpenVINS ``max_clones`` 11); ``min_track`` the fewest observations a feature
    needs to be used; ``gate_probability`` of the per-feature χ² gate; ``min_depth``, ``max_depth`` (m) and
    ``min_parallax`` (largest baseline over depth) the triangulation's geometric checks.

    ``depth_test`` the triangulation's test against the noise (docs/vio.md "Triangulation"; docs/refusals.md): the
    inverse depth ρ of the Gauss–Newton solution has the variance ``σ² [(JᵀJ)⁻¹]_ρρ`` at the feature σ, and a feature
    is used only when ``ρ² / Var(ρ)`` exceeds the χ² quantile (1 dof) of ``gate_probability`` -- its depth is told
    apart from a point at infinity at the gate's probability, i.e. a relative depth σ below 1/1.96 = 51 % at 0.95.
    A feature that fails it is *undetermined* (``TrackUpdate.status`` −3, ``VioResult.n_undetermined``).

    ``adaptive_sigma`` estimates the feature σ online from the filter's own residuals (covariance matching,
    Mehra 1972; Mohamed & Schwarz 1999; docs/vio.md "Measurement noise"): the given σ is the starting value,
    ``sigma_floor`` (a fraction of it) the lowest value, ``sigma_memory`` the number of residual rows the running
    estimate remembers (its adaptation time constant in rows).

    ``max_slam`` the most long-lived features kept in the state as world points (OpenVINS' hybrid MSCKF/SLAM
    features, ``max_slam``; docs/vio.md "SLAM features"): a track still seen when it has spanned the whole window
    is initialised into the state instead of being used once, updated at every frame it is seen in, and
    marginalised when its track ends or its update fails the χ² gate; 0 gives the pure MSCKF.

    ``estimate_time_offset`` adds the camera–IMU time offset ``t_imu = t_cam + t_d`` to the state (the last error
    element, prior σ ``time_offset_sigma`` s around the given offset; OpenVINS ``calib_cam_timeoffset``, Li &
    Mourikis, "Online temporal calibration for camera-aided inertial navigation", IJRR 2014): each clone is the
    IMU pose at ``t_cam + t̂_d``, so its error gains ``[v_w, ω_b] δt_d`` (docs/vio.md "Time offset").
    """

    max_clones: int = 11
    min_track: int = 3
    gate_probability: float = 0.95
    min_depth: float = 0.1
    max_depth: float = 60.0
    min_parallax: float = 0.01
    adaptive_sigma: bool = False
    sigma_floor: float = 0.1
    sigma_memory: float = 1000.0
    max_slam: int = 25
    estimate_time_offset: bool = True
    time_offset_sigma: float = 0.01
    depth_test: bool = True

    def __post_init__(self) -> None:
        if int(self.max_clones) != self.max_clones or self.max_clones < 2:
            raise ValueError(f"max_clones must be a whole number >= 2; got {self.max_clones!r}")
        if int(self.min_track) != self.min_track or self.min_track < 2:
            raise ValueError(f"min_track must be a whole number >= 2; got {self.min_track!r}")
        if not 0.0 < self.gate_probability < 1.0:
            raise ValueError(f"gate_probability must be in (0, 1); got {self.gate_probability!r}")
        if not 0.0 < self.min_depth < self.max_depth or not self.min_parallax >= 0.0:
            raise ValueError("need 0 < min_depth < max_depth and min_parallax >= 0; got "
                             f"{self.min_depth!r}, {self.max_depth!r}, {self.min_parallax!r}")  # fmt: skip
        if int(self.max_slam) != self.max_slam or self.max_slam < 0:
            raise ValueError(f"max_slam must be a whole number >= 0; got {self.max_slam!r}")
        if not self.time_offset_sigma > 0.0:
            raise ValueError(f"time_offset_sigma must be > 0 s; got {self.time_offset_sigma!r}")
        if not 0.0 < self.sigma_floor <= 1.0 or not self.sigma_memory > 0.0:
            raise ValueError("need 0 < sigma_floor <= 1 and sigma_memory > 0; got "
                             f"{self.sigma_floor!r}, {self.sigma_memory!r}")  # fmt: skip


@dataclass(frozen=True)
class TrackUpdate(UpdateResult):
    """:class:`~dualpose.estimation.interface.UpdateResult` of a feature-track frame: ``nis``, ``accepted`` per used
    feature, ``feature_dof`` (G,) the degrees of freedom ``2m − 3`` of each (``dof`` is their sum over the accepted
    ones), ``status`` (G,) 1 accepted, 0 gated out, −1 triangulation failed (degenerate geometry), −3 depth not
    determined at the feature σ (:class:`MsckfOptions` ``depth_test``)."""

    feature_dof: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    status: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


@dataclass
class VioResult:
    """Output of :meth:`MsckfVio.run`: IMU-rate states ``t`` (N,) s, ``position`` (N, 3), ``velocity`` (N, 3),
    ``quat`` (N, 4) ``q_wb``, ``gyro_bias``, ``accel_bias`` (N, 3) (constant at the start pose during the rest
    period before ``t_start``); ``t_start`` the filter start (end of rest); feature statistics ``n_used``,
    ``n_gated``, ``n_failed``, ``n_undetermined`` (depth not determined at the feature σ); ``nis`` and ``nis_dof``
    of the accepted features; ``wall_time`` and ``cpu_time`` (the process's CPU time: what the filter costs on a
    shared machine) of the filter, s."""

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    quat: np.ndarray
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    t_start: float
    n_used: int
    n_gated: int
    n_failed: int
    nis: np.ndarray
    nis_dof: np.ndarray
    wall_time: float
    cpu_time: float = float("nan")
    n_undetermined: int = 0


class MsckfVio(EskfStateAccessors, Estimator):
    """MSCKF visual–inertial odometer over feature tracks (module docstring); an
    :class:`~dualpose.estimation.interface.Estimator` whose ``state`` / ``covariance`` are those of the
    IMU (the window is ``clones`` and ``full_covariance``).

    Parameters
    ----------
    state : (16,) initial nominal IMU state (:data:`~dualpose.estimation.state.ESKF_STATE`).
    covariance : (15, 15) its error covariance.
    imu_noise : ImuNoise (continuous-time densities).
    q_bc, p_bc : camera axes (xyzw) and camera centre (m) in the IMU frame.
    feature_sigma : σ of a normalised image coordinate (the starting value when ``options.adaptive_sigma``; the
        current one is ``feature_sigma``, its start ``nominal_sigma``).
    gravity : (3,) world gravity, m/s².  camera_time_offset : ``t_imu = t_cam + offset``, s.
    options : MsckfOptions.
    """

    state_layout = ESKF_STATE
    covariance_layout = ESKF_ERROR

    def __init__(
        self,
        state: np.ndarray,
        covariance: np.ndarray,
        imu_noise: ImuNoise | None = None,
        q_bc: ArrayLike = (0.0, 0.0, 0.0, 1.0),
        p_bc: ArrayLike = (0.0, 0.0, 0.0),
        feature_sigma: float = 1e-3,
        gravity: ArrayLike = (0.0, 0.0, -9.81),
        camera_time_offset: float = 0.0,
        options: MsckfOptions | None = None,
    ) -> None:
        # the filter-parameter checks every path shares (dualpose.types._inputs, docs/refusals.md)
        x = _inputs.finite_vector(state, "state", ESKF_STATE.dim)
        q = ESKF_STATE.get(x, "quat")
        q[:] = _inputs.unit_quaternion(q, "state[quat]")
        P = _inputs.covariance_matrix(covariance, "covariance", _NE)
        feature_sigma = _inputs.positive(feature_sigma, "feature_sigma", 1.0, "(normalised image units)")
        _inputs.check_imu_noise(ImuNoise() if imu_noise is None else imu_noise)
        q_bc = _inputs.unit_quaternion(q_bc, "q_bc")
        p_bc = _inputs.finite_vector(p_bc, "p_bc", 3, _inputs.MAX_POSITION_M, "m")
        gravity = _inputs.gravity_vector(gravity)
        camera_time_offset = _inputs.time_offset(camera_time_offset, "camera_time_offset")
        self.x = x
        self.P = 0.5 * (P + P.T)
        self.imu_noise = ImuNoise() if imu_noise is None else imu_noise
        n = self.imu_noise
        self.noise = np.array([n.gyroscope_noise_density**2, n.accelerometer_noise_density**2,
                               n.gyroscope_random_walk**2, n.accelerometer_random_walk**2,
                               n.gyroscope_scale_sigma**2, n.accelerometer_scale_sigma**2])  # fmt: skip
        self.q_bc = q_bc
        self.p_bc = np.asarray(p_bc, dtype=np.float64).reshape(3)
        self.feature_sigma = float(feature_sigma)
        self.nominal_sigma = float(feature_sigma)
        self.gravity = np.asarray(gravity, dtype=np.float64).reshape(3)
        self.camera_time_offset = float(camera_time_offset)
        self.options = MsckfOptions() if options is None else options
        o = self.options
        # scalar states after the SLAM features (the time offset), updated in place by msckf_update
        self._extra = np.array([self.camera_time_offset]) if o.estimate_time_offset else np.zeros(0)
        if o.estimate_time_offset:
            P = np.zeros((_NE + 1, _NE + 1))
            P[:_NE, :_NE] = self.P
            P[_NE, _NE] = o.time_offset_sigma**2
            self.P = P
        self._chi2 = np.r_[np.inf, chi2.ppf(o.gate_probability, np.arange(1, 2 * o.max_clones + 8))]
        self._open_gate = np.full_like(self._chi2, np.inf)
        # [min_depth, max_depth, min_parallax, min ρ/σ_ρ] of the native triangulation (0: no depth test)
        depth_z = math.sqrt(float(chi2.ppf(o.gate_probability, 1))) if o.depth_test else 0.0
        self._limits = np.array([o.min_depth, o.max_depth, o.min_parallax, depth_z])
        self.time: float | None = None
        self._t_imu: float | None = None  # the last IMU sample's time
        self._u = np.zeros(6)
        self._x_fej: np.ndarray | None = None  # the state before the updates since the last propagation (FEJ)
        self.clones = np.zeros((0, 7))  # [p_wb, q_wb] per clone, oldest first
        self.clones_fej = np.zeros((0, 7))
        self.clone_t = np.zeros(0)
        self._clone_id = np.zeros(0, np.int64)
        self._next_clone = 0
        self._ob_track = np.zeros(0, np.int64)  # the window's feature observations
        self._ob_clone = np.zeros(0, np.int64)
        self._ob_uv = np.zeros((0, 2))
        self.slam_id = np.zeros(0, np.int64)  # SLAM features in the state: track id, world point, first estimate
        self.slam_p = np.zeros((0, 3))
        self.slam_fej = np.zeros((0, 3))
        self._chi2_2 = float(chi2.ppf(self.options.gate_probability, 2))
        self.n_slam_init = 0  # SLAM features initialised so far
        #: the static alignment :meth:`from_rest` started from (its ``gravity_sigma``, rad), and what it doubted
        #: (``"gravity_sigma"``: the rest period determines the gravity direction only to more than 1°)
        self.start_alignment: StaticAlignment | None = None
        self.doubts: list[_inputs.Doubt] = []
        self._ids = _TrackTable()  # membership of the track ids seen

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_rest(
        cls, recording: TrackRecording, rest_seconds: float | None = None, options: MsckfOptions | None = None
    ) -> tuple[MsckfVio, int]:
        """A filter started at the end of the rest period at the start of ``recording``, and the index of that IMU
        sample.  Rest length: ``rest_seconds`` or :func:`~dualpose.estimation.initialization.detect_rest`; attitude
        (yaw 0) and gyro bias from :func:`~dualpose.estimation.initialization.static_alignment`, zero velocity and
        position, accelerometer bias 0 with its turn-on σ (at rest not separable from tilt).  The rest detection
        takes its noise level from the samples (a multirotor vibrates at rest), and the filter starts one detection
        window (0.2 s) before the detected end, so that a slow start of the motion is inside the filter."""
        r = recording
        n = r.imu_noise
        if rest_seconds is None:
            rest_seconds = detect_rest(r.t, r.gyro, r.accel, n.gyroscope_noise_density, n.accelerometer_noise_density,
                                       noise_from_samples=True)  # fmt: skip
            rest_seconds -= _REST_GUARD
        k = int(np.searchsorted(r.t, r.t[0] + rest_seconds, side="right")) - 1
        k = max(k, 1)
        rate = n.update_rate if n.update_rate > 0 else 1.0 / float(np.median(np.diff(r.t[: k + 2])))
        al = static_alignment(r.accel[: k + 1], r.gyro[: k + 1],
                              accelerometer_noise_density=n.accelerometer_noise_density, rate=rate)  # fmt: skip
        doubt = al.gravity_doubt(f"{r.name or 'recording'}: rest period of {r.t[k] - r.t[0]:.3g} s")  # > 5°: refused
        x = ESKF_STATE.assemble(position=np.zeros(3), velocity=np.zeros(3), quat=al.q_wb, gyro_bias=al.gyro_bias,
                                accel_bias=np.zeros(3))  # fmt: skip
        t_rest = max(r.t[k] - r.t[0], 1e-3)
        tilt = n.accelerometer_initial_bias_sigma / np.linalg.norm(al.specific_force)
        P = np.diag(ESKF_ERROR.assemble(
            position=np.full(3, 1e-3**2), velocity=np.full(3, 1e-2**2),
            attitude=np.array([tilt**2, tilt**2, np.radians(0.1) ** 2]),
            gyro_bias=np.full(3, n.gyroscope_noise_density**2 / t_rest + 1e-4**2),
            accel_bias=np.full(3, n.accelerometer_initial_bias_sigma**2),
        ))  # fmt: skip
        f = cls(x, P, n, r.q_bc, r.p_bc, r.feature_sigma, camera_time_offset=r.time_offset, options=options)
        f.time = f._t_imu = float(r.t[k])
        f._u = np.r_[r.gyro[k], r.accel[k]]
        f.start_alignment = al
        f.doubts = [] if doubt is None else [doubt]
        return f, k

    # ------------------------------------------------------------------ savable state (streaming)
    #: version of :meth:`state_dict`'s layout
    STATE_VERSION = 3

    def state_dict(self) -> dict[str, np.ndarray]:
        """Everything the filter needs to continue, as arrays (``np.savez`` writes it): the IMU state, its first
        estimate (``x_fej``, NaN when none is pending) and the held sample, the window (clones, first estimates,
        times, ids), the window's feature observations, the SLAM features, the full covariance, the current and
        nominal feature σ, the settings.  :meth:`from_state_dict` continues bit for bit (one sample / frame at a
        time)."""
        o = self.options
        return _inputs.seal({
            "version": np.array(self.STATE_VERSION), "x": self.x.copy(), "P": self.P.copy(), "u": self._u.copy(),
            "time": np.array(np.nan if self.time is None else self.time),
            "x_fej": np.full(ESKF_STATE.dim, np.nan) if self._x_fej is None else self._x_fej.copy(),
            "clones": self.clones.copy(),
            "clones_fej": self.clones_fej.copy(), "clone_t": self.clone_t.copy(), "clone_id": self._clone_id.copy(),
            "next_clone": np.array(self._next_clone), "ob_track": self._ob_track.copy(),
            "ob_clone": self._ob_clone.copy(), "ob_uv": self._ob_uv.copy(), "noise": self.noise.copy(),
            "slam_id": self.slam_id.copy(), "slam_p": self.slam_p.copy(), "slam_fej": self.slam_fej.copy(),
            "q_bc": self.q_bc.copy(), "p_bc": self.p_bc.copy(), "gravity": self.gravity.copy(),
            "feature_sigma": np.array(self.feature_sigma), "nominal_sigma": np.array(self.nominal_sigma),
            "camera_time_offset": np.array(self.camera_time_offset), "extra": self._extra.copy(),
            "t_imu": np.array(np.nan if self._t_imu is None else self._t_imu),
            "options": np.array([o.max_clones, o.min_track, o.gate_probability, o.min_depth, o.max_depth,
                                 o.min_parallax, float(o.adaptive_sigma), o.sigma_floor, o.sigma_memory,
                                 o.max_slam, float(o.estimate_time_offset), o.time_offset_sigma,
                                 float(o.depth_test)]),
        })  # fmt: skip

    @classmethod
    def from_state_dict(cls, d: Mapping[str, np.ndarray]) -> MsckfVio:
        """The filter saved by :meth:`state_dict` (a dict or an ``np.load`` of its ``np.savez``); ``ValueError`` for
        another layout version or missing entries."""
        try:
            if int(d["version"]) != cls.STATE_VERSION:
                raise ValueError(f"saved MSCKF state has layout version {int(d['version'])}; this is "
                                 f"{cls.STATE_VERSION}")  # fmt: skip
            o = np.asarray(d["options"], dtype=np.float64)
            opts = MsckfOptions(int(o[0]), int(o[1]), float(o[2]), float(o[3]), float(o[4]), float(o[5]), bool(o[6]),
                                float(o[7]), float(o[8]), int(o[9]), bool(o[10]), float(o[11]),
                                bool(o[12]) if len(o) > 12 else False)  # saved before the depth test: without it
            noise = np.asarray(d["noise"], dtype=np.float64)
            sd = np.sqrt(noise)
            ng, rg, na, ra = (float(v) for v in sd[[0, 2, 1, 3]])
            imu = ImuNoise(ng, rg, na, ra, gyroscope_scale_sigma=float(sd[4]), accelerometer_scale_sigma=float(sd[5]))
            P = np.array(d["P"], dtype=np.float64)
            f = cls(np.array(d["x"]), P[:_NE, :_NE], imu, d["q_bc"], d["p_bc"], float(d["nominal_sigma"]),
                    d["gravity"], float(d["camera_time_offset"]), opts)  # fmt: skip
            f.feature_sigma = float(d["feature_sigma"])
            f.noise = noise.copy()
            f.x = np.array(d["x"], dtype=np.float64)
            f.q_bc = np.array(d["q_bc"], dtype=np.float64)
            f.P = np.ascontiguousarray(P)
            f._u = np.array(d["u"], dtype=np.float64)
            x_fej = np.array(d["x_fej"], dtype=np.float64)
            f._x_fej = None if np.isnan(x_fej).any() else x_fej
            t = float(d["time"])
            f.time = None if np.isnan(t) else t
            f.clones = np.array(d["clones"], dtype=np.float64).reshape(-1, 7)
            f.clones_fej = np.array(d["clones_fej"], dtype=np.float64).reshape(-1, 7)
            f.clone_t = np.array(d["clone_t"], dtype=np.float64)
            f._clone_id = np.array(d["clone_id"], dtype=np.int64)
            f._next_clone = int(d["next_clone"])
            f._ob_track = np.array(d["ob_track"], dtype=np.int64)
            f._ob_clone = np.array(d["ob_clone"], dtype=np.int64)
            f._ob_uv = np.array(d["ob_uv"], dtype=np.float64).reshape(-1, 2)
            f.slam_id = np.array(d["slam_id"], dtype=np.int64)
            f.slam_p = np.array(d["slam_p"], dtype=np.float64).reshape(-1, 3)
            f.slam_fej = np.array(d["slam_fej"], dtype=np.float64).reshape(-1, 3)
            f._extra = np.array(d["extra"], dtype=np.float64).reshape(-1)
            f._ids.cover(f._ob_track)
            f._ids.cover(f.slam_id)
            t_imu = float(d["t_imu"])
            f._t_imu = None if np.isnan(t_imu) else t_imu
            _inputs.check_seal(d, "saved MSCKF state")
        except KeyError as exc:
            raise ValueError(f"saved MSCKF state lacks {exc}") from None
        except TypeError as exc:
            raise ValueError(f"saved MSCKF state holds values of the wrong kind: {exc}") from None
        if f.P.shape != (_NE + _CE * len(f.clones) + 3 * len(f.slam_id) + len(f._extra),) * 2:
            raise ValueError(f"saved MSCKF state: covariance {f.P.shape} does not match {len(f.clones)} clones and "
                             f"{len(f.slam_id)} SLAM features")  # fmt: skip
        f._check_saved()
        return f

    def _check_saved(self) -> None:
        """The values of a restored filter (docs/refusals.md): finite, unit quaternions, a symmetric positive
        semi-definite covariance, a finite time, clone times and observations that belong to the window."""
        name = "saved MSCKF state"
        n = len(self.clones)
        if not (np.isfinite(self.x).all() and np.isfinite(self.clones).all() and np.isfinite(self.clones_fej).all()
                and np.isfinite(self.clone_t).all() and np.isfinite(self._ob_uv).all() and np.isfinite(self._u).all()
                and np.isfinite(self.slam_p).all() and np.isfinite(self.slam_fej).all()
                and np.isfinite(self._extra).all() and (self.time is None or math.isfinite(self.time))):  # fmt: skip
            raise ValueError(f"{name}: values are not finite (a corrupted or altered state)")
        for q, what in [(ESKF_STATE.get(self.x, "quat"), "state quaternion"), *((c[3:], "clone quaternion")
                                                                                for c in self.clones)]:  # fmt: skip
            saved_quaternion(q, f"{name} {what}")
        dim = _NE + _CE * n + 3 * len(self.slam_id) + len(self._extra)
        _inputs.covariance_matrix(self.P, f"{name} covariance", dim)
        if (len(self.clone_t) != n or len(self._clone_id) != n or len(self.clones_fej) != n
                or np.any(np.diff(self.clone_t) < 0) or len(self._ob_clone) != len(self._ob_uv)
                or len(self._ob_track) != len(self._ob_uv)
                or (len(self._ob_clone) and not np.isin(self._ob_clone, self._clone_id).all())):  # fmt: skip
            raise ValueError(f"{name}: the window's clones and observations do not agree (a corrupted or altered "
                             "state)")  # fmt: skip

    # ------------------------------------------------------------------ the estimator interface
    @property
    def state(self) -> np.ndarray:
        """IMU nominal state (16,) (:data:`~dualpose.estimation.state.ESKF_STATE`), a copy."""
        return np.copy(self.x, order="C")

    @property
    def covariance(self) -> np.ndarray:
        """IMU error covariance (15, 15), a copy (the window: :attr:`full_covariance`)."""
        return np.copy(self.P[:_NE, :_NE], order="C")

    @property
    def full_covariance(self) -> np.ndarray:
        """Covariance (15 + 6C + 3L + E, same) of the IMU error, the C clones' ``[δp, δθ]``, the L SLAM features'
        world points and, when estimated (E = 1), the camera time offset, a copy."""
        return np.copy(self.P, order="C")

    def update(self, measurement: LinearMeasurement | AttitudeFix | CameraFrame | TrackFrame) -> UpdateResult:
        """Fuse a :class:`~dualpose.types.TrackFrame` (feature tracks; the filter first propagates to its time), or
        any measurement of :meth:`Estimator.update` (``LinearMeasurement``, ``AttitudeFix``)."""
        if isinstance(measurement, TrackFrame):
            return self.update_tracks(measurement)
        if isinstance(measurement, CameraFrame):
            raise TypeError("MsckfVio has no model for a CameraFrame (known landmarks); give it TrackFrame tracks")
        return super().update(measurement)

    def _update_linear(self, residual: np.ndarray, jacobian: np.ndarray, covariance: np.ndarray) -> UpdateResult:
        self._check_linear(residual, jacobian, covariance)
        H = np.zeros((len(residual), self.P.shape[0]))
        H[:, :_NE] = jacobian
        return UpdateResult(self._ekf_update(residual, H, covariance), len(residual), True)

    # ------------------------------------------------------------------ propagation
    def _steps(self, gyro: np.ndarray, accel: np.ndarray, dt: np.ndarray) -> np.ndarray:
        """Propagate over len(dt) steps of constant input; returns the states after every step (k, 16)."""
        k = len(dt)
        X = np.empty((k, ESKF_STATE.dim))
        if k == 0:
            return X
        x0 = self.x.copy() if self._x_fej is None else self._x_fej
        _native.msckf_propagate(self.x, x0, self.P, np.ascontiguousarray(gyro), np.ascontiguousarray(accel),
                                np.ascontiguousarray(dt, dtype=np.float64), self.gravity, self.noise, X)  # fmt: skip
        self._x_fej = None
        return X

    def propagate(self, t: float, gyro: ArrayLike, accel: ArrayLike, mag: ArrayLike | None = None) -> None:
        """Feed the IMU sample taken at ``t`` (as :meth:`ErrorStateEKF.propagate
        <dualpose.estimation.eskf.ErrorStateEKF.propagate>`: the mean of the held and the new sample over the
        step, then the new one held).  ``mag`` is not used."""
        u = np.r_[np.asarray(gyro, float).reshape(3), np.asarray(accel, float).reshape(3)]
        if (len(self._extra) and self.time is not None and t < self.time
                and (self._t_imu is None or t > self._t_imu)):  # fmt: skip
            # a frame at the estimated time offset took the clock past this sample: its interval was covered by the
            # held sample; hold the new one
            self._u, self._t_imu = u, float(t)
            return
        dt = self._elapsed(t, f"IMU sample at t={t}")
        if dt > 0:
            mid = 0.5 * (self._u + u)
            self._steps(mid[None, :3], mid[None, 3:], np.array([dt]))
        self.time = self._t_imu = float(t)
        self._u = u

    # ------------------------------------------------------------------ the window
    def _clone(self, t: float) -> None:
        n = self.P.shape[0]
        k = _NE + _CE * len(self.clones)  # the new clone's columns, before the SLAM features
        # the clone is the pose at t_cam + t̂_d when the offset is estimated: its error gains u δt_d, u = [v_w, ω_b]
        u = np.concatenate((self.x[_VEL], self._u[:3] - self.x[_BG])) if len(self._extra) else _NO_OFFSET
        P = np.empty((n + _CE, n + _CE))
        _native.msckf_clone(self.P, _POSE_ROWS, k, u, P)
        self.P = P
        c = np.concatenate([ESKF_STATE.get(self.x, "position"), ESKF_STATE.get(self.x, "quat")])
        self.clones = np.concatenate((self.clones, c[None]))
        self.clones_fej = np.concatenate((self.clones_fej, c[None]))
        self.clone_t = np.concatenate((self.clone_t, (t,)))
        self._clone_id = np.concatenate((self._clone_id, (self._next_clone,)))
        self._next_clone += 1

    def _drop_oldest_clone(self) -> None:
        n = self.P.shape[0]
        P = np.empty((n - _CE, n - _CE))
        _native.msckf_select(self.P, np.concatenate((_IMU_ROWS, np.arange(_NE + _CE, n))), P)
        self.P = P
        # the window's observations in the clone went with the update of their tracks (_frame_update)
        self.clones, self.clones_fej = self.clones[1:], self.clones_fej[1:]
        self.clone_t, self._clone_id = self.clone_t[1:], self._clone_id[1:]

    def _keep_obs(self, keep: np.ndarray) -> None:
        self._ob_track, self._ob_clone, self._ob_uv = self._ob_track[keep], self._ob_clone[keep], self._ob_uv[keep]

    # ------------------------------------------------------------------ updates
    def _ekf_update(self, r: np.ndarray, H: np.ndarray, R: np.ndarray) -> float:
        """EKF update (Joseph form) of the whole state with ``r = H δx + e``, ``e ~ N(0, R)``; returns the NIS."""
        P = self.P
        PHt = P @ H.T
        S = H @ PHt + R
        S = 0.5 * (S + S.T)
        cho = np.linalg.cholesky(S)
        y = np.linalg.solve(cho, r)
        nis = float(y @ y)
        K = np.linalg.solve(cho.T, np.linalg.solve(cho, PHt.T)).T
        IKH = -K @ H
        IKH[np.diag_indices_from(IKH)] += 1.0
        P = IKH @ P @ IKH.T + K @ R @ K.T
        dx = K @ r
        self._keep_first_estimate()
        self._inject(dx)
        # reset Jacobian of the IMU attitude error (Solà 2017 eq. 285-287), as the error-state filter applies it
        G = np.eye(len(dx))
        att = ESKF_ERROR.slice("attitude")
        G[att, att] -= dp.so3_hat(0.5 * ESKF_ERROR.get(dx[:_NE], "attitude"))
        P = G @ P @ G.T
        self.P = 0.5 * (P + P.T)
        return nis

    def _keep_first_estimate(self) -> None:
        """Remember the propagated state before the first update at this time: the next propagation step's
        transition is evaluated at it (first-estimates Jacobians, ``msckf_propagate``)."""
        if self._x_fej is None:
            self._x_fej = self.x.copy()

    def _inject(self, dx: np.ndarray) -> None:
        x = self.x
        for name in ("position", "velocity", "gyro_bias", "accel_bias"):
            ESKF_STATE.get(x, name)[:] += ESKF_ERROR.get(dx[:_NE], name)
        q = ESKF_STATE.get(x, "quat")
        q[:] = dp.quat_normalize(dp.quat_mul(q, dp.quat_from_rotvec(ESKF_ERROR.get(dx[:_NE], "attitude"))))
        k = _NE + _CE * len(self.clones)
        self.slam_p += dx[k : k + 3 * len(self.slam_id)].reshape(-1, 3)
        if len(self._extra):
            self._extra += dx[len(dx) - len(self._extra) :]
            self.camera_time_offset = float(self._extra[0])
        if len(self.clones):
            d = dx[_NE:k].reshape(-1, _CE)
            self.clones[:, :3] += MSCKF_CLONE_ERROR.get(d, "position")
            self.clones[:, 3:] = dp.quat_normalize(
                dp.quat_mul(self.clones[:, 3:], dp.quat_from_rotvec(MSCKF_CLONE_ERROR.get(d, "attitude")))
            )

    def update_tracks(self, frame: TrackFrame) -> TrackUpdate:
        """Propagate to the frame (the last IMU sample held), clone the IMU pose, and update with every feature whose
        track ended or whose oldest observation leaves the window; then drop the oldest clone if the window is
        over ``max_clones``."""
        if len(self._extra) and self.time is not None:
            # with the offset estimated, a frame may fall a little before the filter time (the clock ran ahead at
            # an earlier estimate): it is taken at the filter time, within 3 prior σ of the offset
            t = frame.t + self.camera_time_offset
            if t < self.time - 3.0 * self.options.time_offset_sigma:
                self._elapsed(t, f"frame at IMU time {t}")
            t = max(t, self.time)
        else:
            t = self._frame_time(frame.t, self.camera_time_offset)
        if self.time is not None and t > self.time:  # (_frame_time set the time)
            self._steps(self._u[None, :3], self._u[None, 3:], np.array([t - self.time]))
            self.time = t
        return self._frame_update(frame.track_id, frame.uv)

    def _frame_update(self, track_id: np.ndarray, uv: np.ndarray) -> TrackUpdate:
        """Marginalise the SLAM features whose track ended, clone, update with the tracks that end or leave the window
        (the long ones among them initialised as SLAM features while there is room) and with this frame's
        observations of the SLAM features, marginalise the oldest clone; a frame's ``track_id`` (m,) int64 and
        normalised ``uv`` (m, 2)."""
        o = self.options
        assert self.time is not None  # a frame update follows _frame_time or a propagation
        self._ids.cover(track_id)
        if len(self.slam_id):
            seen = self._ids.member(self.slam_id, track_id)
            if not seen.all():
                self._drop_landmarks(~seen)
        self._clone(self.time)
        cid = self._clone_id[-1]
        in_slam = self._ids.member(track_id, self.slam_id)
        slam_track, slam_uv = track_id[in_slam], uv[in_slam]
        if in_slam.any():
            track_id, uv = track_id[~in_slam], uv[~in_slam]
        use = np.zeros(len(self._ob_track) + len(track_id), bool)  # the observations of the tracks to use
        use[: len(self._ob_track)] = ~self._ids.member(self._ob_track, track_id)  # tracks that ended
        self._ob_track = np.concatenate([self._ob_track, track_id])
        self._ob_clone = np.concatenate([self._ob_clone, np.full(len(track_id), cid)])
        self._ob_uv = np.concatenate([self._ob_uv, uv])
        full = len(self.clones) > o.max_clones
        if full:  # and the tracks seen in the oldest clone, which leaves the window
            use |= self._ids.member(self._ob_track, self._ob_track[self._ob_clone == self._clone_id[0]])
        result = self._features_update(use, track_id if full else None, slam_track, slam_uv)
        self._keep_obs(~use)
        if full:
            self._drop_oldest_clone()
        return result

    def _features_update(self, use: np.ndarray, current: np.ndarray | None, slam_track: np.ndarray,
                         slam_uv: np.ndarray) -> TrackUpdate:  # fmt: skip
        """One EKF update with the window's observations ``use`` (boolean, per observation; whole tracks), of which
        the tracks still seen in this frame (``current`` track ids; None when the window is not full) may become
        SLAM features, and with the observations ``slam_uv`` of the SLAM features ``slam_track`` in the newest
        clone."""
        o = self.options
        status = np.zeros(0, np.int64)
        nis = np.zeros(0)
        dof = np.zeros(0, np.int64)
        blocks: list[tuple[np.ndarray, np.ndarray]] = []  # (H, r) rows, H over the state before any SLAM init
        resid: list[tuple[np.ndarray, np.ndarray]] = []  # every row before the gate and its (H P Hᵀ)_ii (σ estimate)
        rows = np.flatnonzero(use)
        if len(rows):
            order = rows[np.argsort(self._ob_track[rows], kind="stable")]
            ids, count = np.unique(self._ob_track[order], return_counts=True)
            enough = count >= o.min_track
            if enough.any():
                sel = order[np.repeat(enough, count)]  # the rows of the tracks long enough, grouped by track
                offsets = np.zeros(int(enough.sum()) + 1, np.int64)
                np.cumsum(count[enough], out=offsets[1:])
                obs_clone = np.searchsorted(self._clone_id, self._ob_clone[sel]).astype(np.int64)
                g = len(offsets) - 1
                n = self.P.shape[0]
                cap = int(np.sum(2 * count[enough] - 3))
                H = np.empty((cap, n))
                r = np.empty(cap)
                rvar = np.empty(cap)
                status = np.empty(g, np.int64)
                nis = np.empty(g)
                points = np.empty((g, 3))
                top = np.empty((g, 3, n + 4))
                uv_sel = np.ascontiguousarray(self._ob_uv[sel])
                # the kernel with an open gate returns the rows of every triangulated feature: the σ estimate sees
                # them all (a gate at the current σ would keep the small residuals and bias it low); the χ² gate is
                # applied here
                m = _native.msckf_features(np.ascontiguousarray(self.clones), np.ascontiguousarray(self.clones_fej),
                                           self.q_bc, self.p_bc, offsets, obs_clone, uv_sel, self.P,
                                           self.feature_sigma, self._open_gate, self._limits, H, r, rvar, status, nis,
                                           points, top)  # fmt: skip
                dof = 2 * count[enough] - 3
                solved = status == 1
                gated = solved & (nis > self._chi2[np.minimum(dof, len(self._chi2) - 1)])
                status[gated] = 0
                accepted = status == 1
                if m > 0:
                    resid.append((r[:m].copy(), rvar[:m].copy()))
                    keep = np.repeat(accepted[solved], dof[solved])
                    if keep.any():
                        blocks.append((H[:m], r[:m]) if keep.all() else (H[:m][keep], r[:m][keep]))
                    room = o.max_slam - len(self.slam_id)
                    if current is not None and room > 0:  # long tracks (seen in the oldest clone and now): SLAM
                        gid = ids[enough]
                        for f in np.flatnonzero(accepted & self._ids.member(gid, current))[:room]:
                            self._init_landmark(int(gid[f]), points[f], top[f])
        drop = np.zeros(len(self.slam_id), bool)
        if len(slam_track):
            Hs, rs, idx, ok, r_all, rvar_all = self._slam_rows(slam_track, slam_uv)
            resid.append((r_all, rvar_all))
            if len(rs):
                blocks.append((Hs, rs))
            drop[idx[~ok]] = True  # a SLAM feature whose update fails the gate is marginalised
        if blocks:
            n = self.P.shape[0]
            if len(blocks) == 1 and blocks[0][0].shape[1] == n:  # one block over the whole state: as it is
                Hk, rk = np.ascontiguousarray(blocks[0][0]), np.ascontiguousarray(blocks[0][1])
            else:  # stacked; rows from before a SLAM initialisation in this frame are zero in its columns
                Hk = np.zeros((sum(len(b[1]) for b in blocks), n))
                rk = np.concatenate([b[1] for b in blocks])
                i = 0
                for Hb, _ in blocks:
                    Hk[i : i + len(Hb), : Hb.shape[1]] = Hb
                    i += len(Hb)
            self._keep_first_estimate()  # one update of all accepted rows (QR-compressed in the kernel when m > n)
            _native.msckf_update(self.x, self.clones, self.slam_p, self._extra, self.P, Hk, rk, self.feature_sigma)
            if len(self._extra):
                self.camera_time_offset = float(self._extra[0])
        if drop.any():
            self._drop_landmarks(drop)
        if o.adaptive_sigma and resid:
            self.feature_sigma = self._adapted_sigma(np.concatenate([a for a, _ in resid]),
                                                     np.concatenate([b for _, b in resid]))  # fmt: skip
        accepted = status == 1
        return TrackUpdate(nis, int(dof[accepted].sum()), accepted, feature_dof=dof, status=status)

    # ------------------------------------------------------------------ SLAM features
    def _init_landmark(self, track: int, pw: np.ndarray, top: np.ndarray) -> None:
        """Put the feature ``track``, triangulated at ``pw`` (3,), into the state (delayed initialisation, Li &
        Mourikis, "Optimization-based estimator design for vision-aided inertial navigation", RSS 2012; OpenVINS
        ``StateHelper::initialize_invertible``) from the three rows ``top`` (3, n + 4) = ``[H_x1 | R | r1]`` that
        the nullspace projection of ``msckf_features`` sets aside (``r1 = H_x1 δx + R δf + n1``, ``R`` upper
        triangular; the other ``2m − 3`` rows are the MSCKF rows of the same update): the point
        ``pw + R⁻¹ r1``, its covariance ``A P Aᵀ + σ² R⁻¹ R⁻ᵀ`` and its cross-covariance ``−A P`` with
        ``A = R⁻¹ H_x1``; its first estimate is ``pw`` (where the Jacobians were taken)."""
        n, nt, E = self.P.shape[0], top.shape[1] - 4, len(self._extra)
        Rinv = np.linalg.inv(top[:, nt : nt + 3])
        A = np.zeros((3, n))  # R⁻¹ H_x1 in the current layout (points initialised before in this frame: zero)
        A[:, : nt - E] = Rinv @ top[:, : nt - E]
        A[:, n - E :] = Rinv @ top[:, nt - E : nt]
        AP = A @ self.P
        Pff = AP @ A.T + self.feature_sigma**2 * (Rinv @ Rinv.T)
        k, e = n - E, n - E + 3  # the point goes after the other points, before the scalar states
        P = np.empty((n + 3, n + 3))
        P[:k, :k], P[:k, e:], P[e:, :k], P[e:, e:] = self.P[:k, :k], self.P[:k, k:], self.P[k:, :k], self.P[k:, k:]
        P[k:e, :k], P[k:e, e:] = -AP[:, :k], -AP[:, k:]
        P[:k, k:e], P[e:, k:e] = -AP[:, :k].T, -AP[:, k:].T
        P[k:e, k:e] = 0.5 * (Pff + Pff.T)
        self.P = P
        self.slam_id = np.append(self.slam_id, track)
        self.slam_p = np.vstack([self.slam_p, pw + Rinv @ top[:, nt + 3]])
        self.slam_fej = np.vstack([self.slam_fej, pw])
        self.n_slam_init += 1

    def _slam_rows(
        self, track: np.ndarray, uv: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The rows (2 per feature) of the SLAM features ``track`` (k,) seen at ``uv`` (k, 2) in the newest clone
        that pass the χ² gate (2 dof) — ``H`` (2a, n), ``r`` (2a,) —, the features' indices in the state (k,),
        which of them passed (k,), and the residuals and their prior variances ``(H P Hᵀ)_ii`` of every feature
        in front of the camera, before the gate (for the σ estimate); the native ``msckf_slam_rows``."""
        srt = np.argsort(self.slam_id)
        idx = srt[np.searchsorted(self.slam_id, track, sorter=srt)].astype(np.int64)
        k = len(idx)
        H = np.empty((2 * k, self.P.shape[0]))
        r, r_all, rvar = np.empty(2 * k), np.empty(2 * k), np.empty(2 * k)
        status = np.empty(k, np.int64)
        rows, front = _native.msckf_slam_rows(self.clones, self.clones_fej, self.q_bc, self.p_bc, self.slam_p,
                                              self.slam_fej, idx, len(self.clones) - 1,
                                              np.ascontiguousarray(uv, dtype=np.float64), self.P, self.feature_sigma,
                                              self._chi2_2, H, r, status, r_all, rvar)  # fmt: skip
        return H[:rows], r[:rows], idx, status == 1, r_all[: 2 * front], rvar[: 2 * front]

    def _drop_landmarks(self, drop: np.ndarray) -> None:
        """Marginalise the SLAM features ``drop`` (L,) bool: delete their rows and columns."""
        k0 = _NE + _CE * len(self.clones)
        n = self.P.shape[0]
        keep = np.concatenate((np.arange(k0), (k0 + 3 * np.flatnonzero(~drop)[:, None] + np.arange(3)).reshape(-1),
                               np.arange(n - len(self._extra), n)))  # fmt: skip
        P = np.empty((len(keep), len(keep)))
        _native.msckf_select(self.P, keep, P)
        self.P = P
        self.slam_id, self.slam_p, self.slam_fej = self.slam_id[~drop], self.slam_p[~drop], self.slam_fej[~drop]

    def _adapted_sigma(self, r: np.ndarray, rvar: np.ndarray) -> float:
        """The feature σ after this frame's residual rows ``r`` (m,) of every triangulated feature, before the
        χ² gate, with their prior variances ``rvar`` (m,) ``= (H P Hᵀ)_ii`` (covariance matching, Mehra 1972 §IV;
        Mohamed & Schwarz 1999 eq. 20): a nullspace-projected row has ``E[r_i²] = (H P Hᵀ)_ii + σ²`` (the
        projection is orthonormal, so the noise stays ``σ² I``).  The frame's estimate is
        ``σ̂² = (1.4826 med|r_i|)² − med (H P Hᵀ)_ii`` (median absolute deviation: robust to the outliers among
        the rows), blended into the running value with weight ``m / (m + sigma_memory)``, floored at
        ``sigma_floor`` × the nominal (starting) σ."""
        o = self.options
        s2 = (1.4826 * np.median(np.abs(r))) ** 2 - np.median(rvar)
        w = len(r) / (len(r) + o.sigma_memory)
        var = (1.0 - w) * self.feature_sigma**2 + w * max(s2, 0.0)
        return float(max(np.sqrt(var), o.sigma_floor * self.nominal_sigma))

    # ------------------------------------------------------------------ a whole recording
    def run(self, recording: TrackRecording, start: int = 0) -> VioResult:
        """Filter ``recording`` from its IMU sample ``start`` (the filter taken to be at ``t[start]`` with that sample
        held), frame by frame: the IMU steps up to each frame in one native call (the signal linear between samples,
        the mean of consecutive samples per step, the held sample up to the frame time), then the frame update.
        States before ``start`` are the start state; at an IMU stamp that is also a frame time the state after the
        frame's update."""
        r = recording
        t, u = r.t, np.hstack([r.gyro, r.accel])
        n = len(t)
        X = np.empty((n, ESKF_STATE.dim))
        X[: start + 1] = self.x
        ft = r.tracks.t + self.camera_time_offset
        first = int(np.searchsorted(ft, t[start], side="right"))
        k = start  # last IMU sample consumed
        stats = {"used": 0, "gated": 0, "failed": 0, "undetermined": 0}
        nis_all, dof_all = [], []
        t0, c0 = time.perf_counter(), time.process_time()
        mid = 0.5 * (u[:-1] + u[1:])  # the mean of consecutive samples, per step
        gyro_mid, accel_mid, dt_all = np.ascontiguousarray(mid[:, :3]), np.ascontiguousarray(mid[:, 3:]), np.diff(t)
        for j in range(first, len(ft) + 1):
            # the frame on the IMU clock with the current offset estimate (online: never before the filter time)
            tf = max(r.tracks.t[j] + self.camera_time_offset, self.time) if j < len(ft) else np.inf
            k1 = int(np.searchsorted(t, tf, side="right")) - 1  # last sample at or before the frame
            if k1 > k:
                dts = dt_all[k:k1].copy()
                dts[0] = t[k + 1] - self.time
                X[k + 1 : k1 + 1] = self._steps(gyro_mid[k:k1], accel_mid[k:k1], dts)
                self.time, self._u, k = float(t[k1]), u[k1].copy(), k1
                self._t_imu = self.time
            if j == len(ft):
                break
            if self.time is not None and tf > self.time:  # (the time is set from t[start] on)
                self._steps(self._u[None, :3], self._u[None, 3:], np.array([tf - self.time]))
                self.time = float(tf)
            a, b = r.tracks.offsets[j], r.tracks.offsets[j + 1]  # the frame's rows (validated by FeatureTracks)
            res = self._frame_update(r.tracks.track_id[a:b], r.tracks.uv[a:b])
            if self.time == t[k]:  # a frame at an IMU stamp: the output there is the state after the update
                X[k] = self.x
            if len(res.status):
                acc = res.status == 1
                stats["used"] += int(np.count_nonzero(acc))
                stats["gated"] += int(np.count_nonzero(res.status == 0))
                stats["failed"] += int(np.count_nonzero(res.status == -1))
                stats["undetermined"] += int(np.count_nonzero(res.status == -3))
                nis_all.append(np.asarray(res.nis)[acc])
                dof_all.append(res.feature_dof[acc])
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        blocks = {name: ESKF_STATE.get(X, name) for name in ESKF_STATE.names}
        return VioResult(
            t=t, **blocks, t_start=float(t[start]), n_used=stats["used"], n_gated=stats["gated"],
            n_failed=stats["failed"], nis=np.concatenate(nis_all) if nis_all else np.zeros(0),
            nis_dof=np.concatenate(dof_all) if dof_all else np.zeros(0, np.int64), wall_time=wall, cpu_time=cpu,
            n_undetermined=stats["undetermined"],
        )  # fmt: skip
