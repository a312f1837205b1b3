"""Rotation-vector and screw-vector (dual) update algorithms; attitude and pose integration; relative pose.

Conventions (docs/inertial.md §1)
---------------------------------
* Attitude ``q = q_b^i`` (body to inertial), ``(..., 4)`` xyzw.  Body frame: ``q̇ = ½ q (x) ω^b`` and the update is
  ``q_{k+1} = q_k (x) exp(Φ_k/2)``.  Inertial frame: ``q̇ = ½ ω^i (x) q`` and ``q_{k+1} = exp(Φ_k/2) (x) q_k``;
  every cross-product term of the algorithm changes sign.
* Pose ``q̂ = q + ε ½ t^i (x) q``, ``(..., 8)``.  Body frame: ``q̂̇ = ½ q̂ (x) ω̂`` with the body twist
  ``ω̂ = ω^b + ε v^b`` (``v^b = q* ṫ^i q``, the origin's inertial velocity in body axes).  Inertial frame:
  ``q̂̇ = ½ ω̂_s (x) q̂`` with the spatial twist ``ω̂_s = ω^i + ε (ṫ^i − ω^i × t^i)``.
* Increments over sub-interval j: ``Δθ_j = ∫ ω dt``, ``Δu_j = ∫ v dt``; dual increments are ``(..., M, 6)`` rows
  ``[Δθ, Δu]`` (radians, metres), ``M = K·N`` for K updates of N samples.
* The screw-vector algorithm is the rotation-vector algorithm over dual numbers: every θ becomes ``θ + εu`` and
  every cross product the dual cross product ``(a + εa′) × (b + εb′) = a × b + ε (a × b′ + a′ × b)``.  The screw
  exponential maps ``Φ̂ = σ + εσ′`` to ``r + ε ½ Δt (x) r`` with ``r = exp(σ/2)``, ``Δt = J_l(σ) σ′``.

Paper: Adv. Mech. Eng. 2019, "Research on the rigid body pose estimation using dual quaternions", eqs. (14)-(21)
(rotation vector) and (22)-(31) (screw vector); the coefficient tables are in :mod:`.coefficients`.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp
from dualpose import _native
from dualpose._validation import as_array, check_finite
from dualpose.inertial.coefficients import PREVIOUS_COEFFICIENT, check_algorithm, coning_coefficients

__all__ = [
    "rotation_vector",
    "screw_vector",
    "screw_exp",
    "integrate_attitude",
    "integrate_pose",
    "relative_pose",
]

Frame = Literal["body", "space"]
Family = Literal["coning-optimal", "polynomial", "one-plus-previous"]


def _frame_sign(frame: object) -> float:
    if frame == "body":
        return 1.0
    if frame == "space":
        return -1.0
    raise ValueError(f"frame must be 'body' or 'space' (as in dualpose.quat_integrate); got {frame!r}")


def _split_updates(x: np.ndarray, name: str, samples: int) -> NDArray[np.float64]:
    """Check (..., M, w) increments: M a positive multiple of samples, finite values."""
    if x.ndim < 2:
        raise ValueError(f"{name} must have shape (..., K*N, {x.shape[-1]}); got shape {x.shape}")
    m = x.shape[-2]
    if m == 0 or m % samples:
        raise ValueError(f"{name} has {m} rows, which is not a positive multiple of samples={samples}")
    check_finite(x, name)
    return x


def _algorithm(samples: int, coefficients: str, frame: object) -> tuple[NDArray[np.float64], float, float]:
    samples, coefficients = check_algorithm(samples, coefficients)
    cprev = float(PREVIOUS_COEFFICIENT) if coefficients == "one-plus-previous" else 0.0
    return np.ascontiguousarray(coning_coefficients(samples, coefficients)), cprev, _frame_sign(frame)


def _batch(
    x0: np.ndarray | None, x: np.ndarray,
) -> tuple[tuple[int, ...], NDArray[np.float64] | None, NDArray[np.float64]]:
    """Broadcast the leading axes of x0 (..., w0) and x (..., M, w); flatten them to one batch axis."""
    lead = x.shape[:-2] if x0 is None else np.broadcast_shapes(x0.shape[:-1], x.shape[:-2])
    xb = np.ascontiguousarray(np.broadcast_to(x, (*lead, *x.shape[-2:])).reshape(-1, *x.shape[-2:]))
    if x0 is None:
        return lead, None, xb
    x0b = np.ascontiguousarray(np.broadcast_to(x0, (*lead, x0.shape[-1])).reshape(-1, x0.shape[-1]))
    return lead, x0b, xb


def _update_vectors(x: np.ndarray, samples: int, coefficients: str, frame: object) -> NDArray[np.float64]:
    kmat, cprev, sgn = _algorithm(samples, coefficients, frame)
    lead, _, xb = _batch(None, x)
    out = np.empty((xb.shape[0], x.shape[-2] // kmat.shape[0], x.shape[-1]))
    _native.inertial_update_vectors(xb, kmat.shape[0], kmat, cprev, sgn, out)
    return out.reshape(*lead, *out.shape[1:])


def rotation_vector(
    dtheta: ArrayLike, samples: int = 1, coefficients: Family = "coning-optimal", frame: Frame = "body"
) -> NDArray[np.float64]:
    """Rotation vector of each update from N angle increments (paper eqs. (17)-(21); docs/inertial.md §2).

    ``Φ_k = Σ_i θ_i + s Σ_{i<j} k_ij θ_i × θ_j`` with ``s = +1`` (body) or ``−1`` (inertial).  For
    ``"one-plus-previous"`` (N = 1) ``Φ_k = θ_k + s/12 θ_{k−1} × θ_k`` and ``θ_0 = 0`` (the first update has no
    previous sample).

    Parameters
    ----------
    dtheta : array_like, shape (..., K*N, 3)
        Angle increments ``∫ ω dt`` over consecutive sub-intervals, radians; body axes (``frame="body"``) or
        inertial axes (``frame="space"``).
    samples : int
        N, increments per update (1..4).
    coefficients : {"coning-optimal", "polynomial", "one-plus-previous"}
        Coefficient family (:func:`dualpose.inertial.coning_coefficients`).
    frame : {"body", "space"}

    Returns
    -------
    ndarray, shape (..., K, 3)
        Rotation vectors (radians) such that ``q_{k+1} = q_k (x) exp(Φ_k/2)`` (body) or ``exp(Φ_k/2) (x) q_k``.
    """
    x = _split_updates(as_array(dtheta, "dtheta", 3), "dtheta", samples)
    return _update_vectors(x, samples, coefficients, frame)


def screw_vector(
    dual_increments: ArrayLike, samples: int = 1, coefficients: Family = "coning-optimal", frame: Frame = "body"
) -> NDArray[np.float64]:
    """Screw vector ``Φ̂ = σ + εσ′`` of each update from N dual increments (paper eqs. (25)-(31); docs/inertial.md §2).

    The rotation-vector formula over dual numbers: ``σ`` is :func:`rotation_vector` of the ``Δθ`` and
    ``σ′ = Σ Δu_i + s Σ_{i<j} k_ij (Δθ_i × Δu_j + Δu_i × Δθ_j)``.

    Parameters
    ----------
    dual_increments : array_like, shape (..., K*N, 6)
        Rows ``[Δθ, Δu]``: ``∫ ω dt`` (radians) and ``∫ v dt`` (metres) over consecutive sub-intervals, with the
        body twist ``[ω^b, v^b]`` (``frame="body"``) or the spatial twist ``[ω^i, ṫ − ω^i × t]`` (inertial).
    samples, coefficients, frame
        As :func:`rotation_vector`.

    Returns
    -------
    ndarray, shape (..., K, 6)
        ``[σ, σ′]`` per update; :func:`screw_exp` of half of it is the update dual quaternion.
    """
    x = _split_updates(as_array(dual_increments, "dual_increments", 6), "dual_increments", samples)
    return _update_vectors(x, samples, coefficients, frame)


def screw_exp(screw: ArrayLike) -> NDArray[np.float64]:
    """Unit dual quaternion ``exp(Φ̂/2)`` of screw vectors ``Φ̂ = σ + εσ′`` (docs/inertial.md §2; paper eq. (23)).

    ``r = exp(σ/2)`` (:func:`dualpose.quat_from_rotvec`), ``Δt = J_l(σ) σ′`` (:func:`dualpose.so3_left_jacobian`)
    and the result is ``r + ε ½ Δt (x) r``: the rigid motion rotating by ``σ`` and translating by ``Δt``.  Equal to
    :func:`dualpose.dualquat_from_twist` of ``[σ, σ′]``.

    Parameters
    ----------
    screw : array_like, shape (..., 6)
        ``[σ, σ′]``, radians and metres.

    Returns
    -------
    ndarray, shape (..., 8)
        ``[real xyzw, dual xyzw]``.
    """
    screw = as_array(screw, "screw", 6)
    sigma = screw[..., :3]
    dt = np.einsum("...ij,...j->...i", dp.so3_left_jacobian(sigma), screw[..., 3:])
    return dp.dualquat_from_qt(dp.quat_from_rotvec(sigma), dt)


def _fold(
    x0: np.ndarray, name0: str, x: np.ndarray, name: str, samples: int, coefficients: str, frame: object
) -> NDArray[np.float64]:
    kmat, cprev, sgn = _algorithm(samples, coefficients, frame)
    x = _split_updates(x, name, samples)
    check_finite(x0, name0)
    if np.any(np.all(x0[..., :4] == 0.0, axis=-1)):
        raise ValueError(f"{name0} must have a nonzero (real part) quaternion")
    lead, x0b, xb = _batch(x0, x)
    w = x0.shape[-1]
    out = np.empty((xb.shape[0], x.shape[-2] // kmat.shape[0] + 1, w))
    fold = _native.inertial_fold_quat if w == 4 else _native.inertial_fold_dualquat
    fold(x0b, xb, kmat.shape[0], kmat, cprev, sgn, out)
    return out.reshape(*lead, *out.shape[1:])


def _is_dask(x: object) -> bool:
    return type(x).__module__.startswith("dask.")


def _lazy_fold(integrate: Callable[..., np.ndarray], x0: Any, name0: str, x: Any, name: str, w0: int, w: int,
               samples: int, *options: Any) -> Any:
    """Lazy ``integrate(x0, x, samples, *options)`` for dask inputs: blocks over the leading (batch) axes only.

    Integration is sequential along time, so each block holds whole time series: the time and component axes of
    ``x`` and the component axis of ``x0`` in one chunk, the leading axes chunked as given.  Each block is the
    NumPy function's result on its rows (bit for bit); shapes are checked when the call is made.  dask is imported
    (a dask array is among the inputs).
    """
    da = sys.modules["dask.array"]
    x0, x = da.asarray(x0), da.asarray(x)
    if x0.ndim < 1 or x0.shape[-1] != w0:
        raise ValueError(f"{name0} must have shape (..., {w0}); got shape {x0.shape}")
    if x.ndim < 2 or x.shape[-1] != w:
        raise ValueError(f"{name} must have shape (..., K*N, {w}); got shape {x.shape}")
    m = x.shape[-2]
    if m == 0 or m % samples:
        raise ValueError(f"{name} has {m} rows, which is not a positive multiple of samples={samples}")
    x0 = x0.rechunk({x0.ndim - 1: -1})
    x = x.rechunk({x.ndim - 2: -1, x.ndim - 1: -1})
    n_lead = max(x0.ndim - 1, x.ndim - 2)
    lead = tuple(f"l{i}" for i in range(n_lead))

    def block(b0: Any, b: Any) -> NDArray[np.float64]:
        while isinstance(b0, list):  # the one-chunk axes missing from the output come as nested lists
            b0 = b0[0]
        while isinstance(b, list):
            b = b[0]
        return integrate(b0, b, samples, *options)

    return da.blockwise(block, (*lead, "k", "c"), x0, (*lead[n_lead - (x0.ndim - 1):], "c0"),
                        x, (*lead[n_lead - (x.ndim - 2):], "m", "c1"), new_axes={"k": m // samples + 1, "c": w0},
                        concatenate=False, dtype=np.float64, meta=np.empty((0,) * (n_lead + 2)))


def integrate_attitude(
    q0: ArrayLike,
    dtheta: ArrayLike,
    samples: int = 1,
    coefficients: Family = "coning-optimal",
    frame: Frame = "body",
) -> NDArray[np.float64]:
    """Attitude quaternions from gyro angle increments with an N-sample rotation-vector algorithm.

    ``q_{k+1} = q_k (x) exp(Φ_k/2)`` (body) or ``exp(Φ_k/2) (x) q_k`` (inertial), renormalized each update, with
    ``Φ_k`` from :func:`rotation_vector` (paper eqs. (14)-(21)).  One compiled pass, no Python loop over updates.

    Parameters
    ----------
    q0 : array_like, shape (..., 4)
        Initial attitude ``q_b^i`` (xyzw); normalized before use.  Broadcasts with the leading axes of ``dtheta``.
    dtheta : array_like, shape (..., K*N, 3)
        Angle increments, radians (body axes for ``frame="body"``, inertial axes for ``"space"``).
    samples, coefficients, frame
        See :func:`rotation_vector`.

    Returns
    -------
    ndarray, shape (..., K+1, 4)
        ``q_0 … q_K`` at the update times ``0, T, …, K T`` (xyzw).  With a dask array among ``q0``, ``dtheta``:
        a lazy dask array, chunked over the leading (batch) axes as given, each series whole in one chunk
        (integration is sequential along time; docs/scaling.md, "Lazy and out-of-core").
    """
    if _is_dask(q0) or _is_dask(dtheta):
        result: NDArray[np.float64] = (
            _lazy_fold(integrate_attitude, q0, "q0", dtheta, "dtheta", 4, 3, samples, coefficients, frame)
        )
        return result
    q0 = as_array(q0, "q0", 4)
    return _fold(q0, "q0", as_array(dtheta, "dtheta", 3), "dtheta", samples, coefficients, frame)


def integrate_pose(
    dq0: ArrayLike,
    dual_increments: ArrayLike,
    samples: int = 1,
    coefficients: Family = "coning-optimal",
    frame: Frame = "body",
) -> NDArray[np.float64]:
    """Pose dual quaternions from dual increments ``[Δθ, Δu]`` with an N-sample screw-vector algorithm.

    ``q̂_{k+1} = q̂_k (x) exp(Φ̂_k/2)`` (body) or ``exp(Φ̂_k/2) (x) q̂_k`` (inertial), renormalized each update
    (dual-number norm), with ``Φ̂_k`` from :func:`screw_vector` and the exponential of :func:`screw_exp` (paper
    eqs. (22)-(31)).  One compiled pass.

    Parameters
    ----------
    dq0 : array_like, shape (..., 8)
        Initial pose ``q + ε ½ t^i (x) q``; normalized before use.  Broadcasts with the leading axes of
        ``dual_increments``.
    dual_increments : array_like, shape (..., K*N, 6)
        Rows ``[Δθ, Δu]``, radians and metres (see :func:`screw_vector` for the frames).
    samples, coefficients, frame
        See :func:`rotation_vector`.

    Returns
    -------
    ndarray, shape (..., K+1, 8)
        ``q̂_0 … q̂_K`` at ``0, T, …, K T``.  With a dask array among the inputs: lazy, as in
        :func:`integrate_attitude`.
    """
    if _is_dask(dq0) or _is_dask(dual_increments):
        result: NDArray[np.float64] = _lazy_fold(
            integrate_pose, dq0, "dq0", dual_increments, "dual_increments", 8, 6, samples, coefficients, frame
        )
        return result
    dq0 = as_array(dq0, "dq0", 8)
    x = as_array(dual_increments, "dual_increments", 6)
    return _fold(dq0, "dq0", x, "dual_increments", samples, coefficients, frame)


def relative_pose(leader: ArrayLike, follower: ArrayLike) -> NDArray[np.float64]:
    """Pose of the follower in the leader frame, ``q̂_LF = q̂_L* (x) q̂_F`` (paper eqs. (32)-(34)).

    Parameters
    ----------
    leader : array_like, shape (..., 4) or (..., 8)
        Leader attitude quaternion (xyzw; a dual quaternion with zero translation, the leader sitting at the
        inertial origin as in the paper) or leader pose dual quaternion.
    follower : array_like, shape (..., 8)
        Follower pose ``q_F + ε ½ t_F (x) q_F`` in the inertial frame.

    Returns
    -------
    ndarray, shape (..., 8)
        ``q̂_LF``: rotation ``q_L* (x) q_F`` and translation ``q_L* (t_F − t_L) q_L`` (leader axes).
    """
    width = np.shape(leader)[-1:]
    if width == (4,):
        q = as_array(leader, "leader", 4)
        lead = np.concatenate([q, np.zeros(q.shape)], axis=-1)
    elif width == (8,):
        lead = as_array(leader, "leader", 8)
    else:
        raise ValueError(f"leader must have shape (..., 4) or (..., 8); got shape {np.shape(leader)}")
    follower = as_array(follower, "follower", 8)
    return dp.dualquat_mul(dp.dualquat_conj(lead), follower)
