"""Offline Rauch–Tung–Striebel smoothing of the error-state filter (Rauch, Tung & Striebel 1965; Särkkä 2013,
"Bayesian Filtering and Smoothing", Thm 8.2; error-state charts after Solà 2017, §6-7).

:func:`rts_smooth` runs the backward pass over the nodes that :meth:`ErrorStateEKF.run(..., record_nodes=True)
<dualpose.estimation.eskf.ErrorStateEKF.run>` stores (every IMU time and camera time, with the prior and posterior of
each camera update, so the filter's error-state reset is accounted for) and returns smoothed states at the IMU
times.  :func:`rts_smooth_linear` is the plain linear-Gaussian RTS smoother (as filterpy's ``rts_smoother`` but
taking the filter's stored priors instead of ``Q``).  Both backward passes are native kernels
(``dualpose._native.smoother_*``, ``src/native/estimation/smoother*``); the derivation is in ``docs/fusion.md``,
"Offline smoothing (RTS)".

Example
-------
>>> from dualpose import sim
>>> from dualpose.estimation import eskf, smoother
>>> run = sim.simulate_eight(0)
>>> f = eskf.ErrorStateEKF.for_run(run, run.truth["position"][0], run.truth["velocity"][0], run.truth["quat"][0])
>>> smoothed = smoother.rts_smooth(f.run_recording(run, record_nodes=True))
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from dualpose import _native
from dualpose.estimation.eskf import FilterResult
from dualpose.estimation.state import ESKF_ERROR, ESKF_STATE

__all__ = ["SmoothedResult", "rts_smooth", "rts_smooth_linear"]


@dataclass
class SmoothedResult:
    """Output of :func:`rts_smooth`: smoothed states at the IMU times of the filtered run.

    Attributes
    ----------
    t : (N,) IMU times, s.
    position : (N, 3) ``p_wb``, world frame, m.   velocity : (N, 3) ``v_w``, world frame, m/s.
    quat : (N, 4) ``q_wb`` xyzw (body → world).
    gyro_bias : (N, 3) rad/s.   accel_bias : (N, 3) m/s², body frame.
    covariance : (N, 15, 15)
        Smoothed error covariance over ``[δp, δv, δθ, δb_g, δb_a]`` in the chart of the smoothed state
        (``q = q_s ⊗ Exp(δθ)``, δθ in the body frame).
    node_t : (K,) times of all filter nodes (IMU and camera times), s.
    node_states : (K, 16) smoothed nominal states ``[p, v, q_wb, b_g, b_a]`` at the nodes.
    node_covariance : (K, 15, 15) smoothed error covariances at the nodes.
    wall_time : float, seconds spent in the backward pass.
    """

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    quat: np.ndarray
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    covariance: np.ndarray
    node_t: np.ndarray
    node_states: np.ndarray
    node_covariance: np.ndarray
    wall_time: float = float("nan")


def rts_smooth(filter_result: FilterResult) -> SmoothedResult:
    """Error-state RTS smoother over an :class:`~dualpose.estimation.eskf.ErrorStateEKF` run.

    For node i (backwards from the last, where the smoother equals the filter) with the filter's posterior
    ``x⁺_i, P⁺_i``, the prior at the next node ``x⁻_{i+1}, P⁻_{i+1}`` and the transition ``F_i``:
    ``μ = x^s_{i+1} ⊟ x⁻_{i+1}``, ``C_i = P⁺_i F_iᵀ (P⁻_{i+1})⁻¹`` (a solve), ``δ = C_i μ``,
    ``x^s_i = x⁺_i ⊞ δ``, ``P^s_i = J_r(δ_θ) [P⁺_i + C_i (J_r⁻¹(μ_θ) P^s_{i+1} J_r⁻ᵀ(μ_θ) − P⁻_{i+1}) C_iᵀ]
    J_rᵀ(δ_θ)`` (docs/fusion.md, "Offline smoothing (RTS)").

    Parameters
    ----------
    filter_result : FilterResult
        From ``ErrorStateEKF.run(..., record_nodes=True)`` (or ``run_recording(run, record_nodes=True)``).

    Returns
    -------
    SmoothedResult
        Smoothed states and covariances at the IMU times (and at every node).

    Raises
    ------
    TypeError
        ``filter_result`` is not a FilterResult.
    ValueError
        The run was filtered without ``record_nodes=True``, or a predicted covariance is singular (an error-state
        component with neither prior uncertainty nor process noise).
    """
    if not isinstance(filter_result, FilterResult):
        raise TypeError(f"filter_result must be an eskf.FilterResult; got {type(filter_result).__name__}")
    nodes = filter_result.nodes
    if nodes is None:
        raise ValueError("filter_result has no node record: filter with ErrorStateEKF.run(..., record_nodes=True)")
    k = len(nodes.t)
    xs = np.empty((k, ESKF_STATE.dim))
    Ps = np.empty((k, ESKF_ERROR.dim, ESKF_ERROR.dim))
    t0 = time.perf_counter()
    try:
        _native.smoother_rts_error_state(
            nodes.posterior_states, nodes.posterior_covariance, nodes.prior_states, nodes.prior_covariance,
            nodes.transition, xs, Ps,
        )  # fmt: skip
    except np.linalg.LinAlgError:
        raise ValueError(
            "a predicted error covariance of the run is singular: the RTS gain needs every error-state component to "
            "have prior uncertainty or process noise (e.g. nonzero bias random walks or initial bias sigmas)"
        ) from None
    wall = time.perf_counter() - t0
    at = nodes.imu_node
    x = xs[at]
    blocks = {name: ESKF_STATE.get(x, name) for name in ESKF_STATE.names}
    return SmoothedResult(
        t=filter_result.t.copy(), **blocks, covariance=Ps[at], node_t=nodes.t.copy(), node_states=xs,
        node_covariance=Ps, wall_time=wall,
    )  # fmt: skip


def rts_smooth_linear(
    posterior_means: np.ndarray,
    posterior_covariances: np.ndarray,
    prior_means: np.ndarray,
    prior_covariances: np.ndarray,
    transitions: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Linear-Gaussian RTS smoother from a Kalman filter's stored predictions and updates (Särkkä 2013, Thm 8.2).

    Parameters
    ----------
    posterior_means : (K, n) filtered means ``x_{k|k}``.
    posterior_covariances : (K, n, n) filtered covariances ``P_{k|k}``.
    prior_means : (K, n) predicted means ``x_{k|k−1}`` (row 0 is not used).
    prior_covariances : (K, n, n) predicted covariances ``P_{k|k−1} = F_{k−1} P_{k−1|k−1} F_{k−1}ᵀ + Q_{k−1}``
        (row 0 is not used).
    transitions : (K, n, n) ``F_k`` with ``x_{k+1} = F_k x_k + w_k`` (the last row is not used).

    Returns
    -------
    means : (K, n) smoothed means ``x_{k|K}``.
    covariances : (K, n, n) smoothed covariances ``P_{k|K}``.
    """
    xb = _array(posterior_means, "posterior_means", 2)
    kk, n = xb.shape
    xa = _array(prior_means, "prior_means", 2, (kk, n))
    Pb = _array(posterior_covariances, "posterior_covariances", 3, (kk, n, n))
    Pa = _array(prior_covariances, "prior_covariances", 3, (kk, n, n))
    F = _array(transitions, "transitions", 3, (kk, n, n))
    if kk == 0:
        raise ValueError("posterior_means must hold at least one step")
    xs = np.empty((kk, n))
    Ps = np.empty((kk, n, n))
    _native.smoother_rts_linear(xb, Pb, xa, Pa, F, xs, Ps)
    return xs, Ps


def _array(a: np.ndarray, name: str, ndim: int, shape: tuple[int, ...] | None = None) -> np.ndarray:
    out = np.ascontiguousarray(a, dtype=np.float64)
    if out.ndim != ndim or (shape is not None and out.shape != shape):
        want = shape if shape is not None else ("K", "n")
        raise ValueError(f"{name} must have shape {want}; got {out.shape}")
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{name} must be finite")
    return out
