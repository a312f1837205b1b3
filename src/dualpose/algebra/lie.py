"""SO(3) and SE(3): hat/vee, exponential and logarithm, Jacobians and adjoints.

Layouts
-------
* Rotation vectors ``φ`` are ``(..., 3)`` arrays, radians; ``Φ = [φ]×`` is the skew matrix (:func:`so3_hat`),
  ``θ = |φ|``.
* Twists (exponential coordinates) are ``(..., 6)`` arrays ``ξ = [ω, v]`` (rotation first, as scipy's
  ``RigidTransform.as_exp_coords``).  The se(3) element is ``ξ^ = [[ω×, v], [0, 0]]`` (:func:`se3_hat`) and the
  transform is ``exp(ξ^) = [[R, t], [0, 1]]`` with ``R = exp(ω×)`` and ``t = J_l(ω) v``.
* Rotations enter :func:`so3_adjoint` / :func:`se3_adjoint` as unit quaternions ``(..., 4)`` xyzw (see
  :mod:`dualpose.algebra.quat`), translations as ``(..., 3)``.

Jacobian conventions (Barfoot 2017, *State Estimation for Robotics*, §7.1.5 and §7.2.5; Solà et al. 2018)
---------------------------------------------------------------------------------------------------------
For small ``δ``::

    exp((ξ + δ)^) ≈ exp((J_l(ξ) δ)^) exp(ξ^)       (left Jacobian: perturbation in the space/world frame)
    exp((ξ + δ)^) ≈ exp(ξ^) exp((J_r(ξ) δ)^)       (right Jacobian: perturbation in the body frame)

and ``J_r(ξ) = J_l(−ξ)``, ``J_l(ξ) = Ad(exp ξ^) J_r(ξ)``.  Equivalently ``J_l(ξ) = Σ_k ad_ξ^k / (k+1)!``.

SO(3): ``J_l(φ) = I + cosc2(θ) Φ + sinc3(θ) Φ²`` and ``J_l(φ)⁻¹ = I − ½ Φ + jinv(θ) Φ²`` (pole at θ = 2π).

SE(3), in the ``[ω, v]`` order::

    J_l(ξ) = [[J_l(ω), 0], [Q(ω, v), J_l(ω)]]          J_l(ξ)⁻¹ = [[J⁻¹, 0], [−J⁻¹ Q J⁻¹, J⁻¹]]

with Barfoot's ``Q`` (eq. (7.86); his ``[ρ, φ]`` order has the blocks transposed into ``[[J, Q], [0, J]]``)::

    Q = ½ V + sinc3(θ) (ΦV + VΦ + ΦVΦ) + cosc4(θ) (Φ²V + VΦ² − 3ΦVΦ) + se3c(θ) (ΦVΦ² + Φ²VΦ),   V = [v]×

The scalar factors ``cosc2, sinc3, jinv, cosc4, se3c`` are the guarded series of :mod:`dualpose.algebra.series`,
so every function here is accurate down to θ = 1e-300 and exactly right at θ = 0 (no NaN).

Every function broadcasts over leading axes, accepts array-likes and returns float64.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose import _native
from dualpose._validation import as_array, call_kernel, check_finite, raise_if_zero_norm
from dualpose.algebra._fastpath import fast_path
from dualpose.algebra.hat import so3_hat, so3_vee
from dualpose.algebra.quat import matrix_from_quat, quat_from_matrix, rotvec_from_quat

__all__ = [
    "so3_hat",
    "so3_vee",
    "se3_hat",
    "se3_vee",
    "so3_exp",
    "so3_log",
    "se3_exp",
    "se3_log",
    "so3_left_jacobian",
    "so3_right_jacobian",
    "so3_left_jacobian_inv",
    "so3_right_jacobian_inv",
    "se3_left_jacobian",
    "se3_right_jacobian",
    "se3_left_jacobian_inv",
    "se3_right_jacobian_inv",
    "so3_adjoint",
    "se3_adjoint",
    "se3_adjoint_from_matrix",
    "se3_ad",
]



# ---------------------------------------------------------------------------------------------------------------
# hat / vee
# ---------------------------------------------------------------------------------------------------------------


def se3_hat(xi: ArrayLike) -> NDArray[np.float64]:
    """se(3) matrix ``[[ω×, v], [0, 0]]`` of twists ``ξ = [ω, v]``; shape (..., 6) -> (..., 4, 4)."""
    xi = as_array(xi, "xi", 6)
    o = np.zeros(xi.shape[:-1] + (4, 4))
    o[..., :3, :3] = so3_hat(xi[..., :3])
    o[..., :3, 3] = xi[..., 3:]
    return o


def se3_vee(matrix: ArrayLike) -> NDArray[np.float64]:
    """Inverse of :func:`se3_hat`: ``[vee(½(A − Aᵀ)), b]`` of ``[[A, b], [·, ·]]``; (..., 4, 4) -> (..., 6)."""
    m = as_array(matrix, "matrix", (4, 4))
    return np.concatenate([so3_vee(m[..., :3, :3]), m[..., :3, 3]], axis=-1)


# ---------------------------------------------------------------------------------------------------------------
# exp / log
# ---------------------------------------------------------------------------------------------------------------


@fast_path(_native.so3_exp)
def so3_exp(phi: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix ``exp([φ]×) = cos θ I + sinc(θ) Φ + cosc2(θ) φφᵀ`` (Rodrigues).

    Parameters
    ----------
    phi : array_like, shape (..., 3)
        Rotation vectors θu, radians.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Equal to ``matrix_from_quat(quat_from_rotvec(phi))`` (Dantam 2014 eqs. (50), (108)).
    """
    phi = as_array(phi, "phi", 3)
    result: NDArray[np.float64] = _native.so3_exp(phi)
    return result


def so3_log(matrix: ArrayLike) -> NDArray[np.float64]:
    """Rotation vector of rotation matrices, angle in [0, π]; shape (..., 3, 3) -> (..., 3), radians.

    Computed as ``rotvec_from_quat(quat_from_matrix(R))`` (Shepperd, then the atan2 form of Dantam 2014 eq. (51)),
    so it is accurate near θ = π.  Input must be finite.
    """
    return rotvec_from_quat(quat_from_matrix(matrix))


@fast_path(_native.se3_exp)
def se3_exp(xi: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exponential of twists: ``exp([[ω×, v], [0, 0]]) = [[R, t], [0, 1]]``.

    Parameters
    ----------
    xi : array_like, shape (..., 6)
        Twists ``[ω, v]`` (ω in radians, v in length units), as scipy's ``RigidTransform.from_exp_coords``.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        ``exp(ω×)``.
    t : ndarray, shape (..., 3)
        ``J_l(ω) v`` — the *left Jacobian*, not ``R`` (the small-angle trap of some libraries).
    """
    xi = as_array(xi, "xi", 6)
    result: tuple[NDArray[np.float64], NDArray[np.float64]] = _native.se3_exp(xi)
    return result


def se3_log(rotation: ArrayLike, translation: ArrayLike) -> NDArray[np.float64]:
    """Twist ``[ω, v]`` with ``|ω| <= π`` of the transform ``[[R, t], [0, 1]]``: ``ω = log R``, ``v = J_l(ω)⁻¹ t``.

    Parameters
    ----------
    rotation : array_like, shape (..., 3, 3)
        Rotation matrices (finite; a nearly orthogonal matrix is projected as in :func:`quat_from_matrix`).
    translation : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 6)
        The principal twist (as scipy's ``RigidTransform.as_exp_coords``).
    """
    omega = so3_log(rotation)
    t = as_array(translation, "translation", 3)
    v = call_kernel(_native.so3_jacobian_apply, (omega, t, 1.0, 1.0), ("rotation", "translation"))
    return np.concatenate(np.broadcast_arrays(omega, v), axis=-1)


# ---------------------------------------------------------------------------------------------------------------
# Jacobians
# ---------------------------------------------------------------------------------------------------------------


def _so3_jac(phi: ArrayLike, sgn: float, inv: float) -> NDArray[np.float64]:
    phi = as_array(phi, "phi", 3)
    result: NDArray[np.float64] = _native.so3_jacobian(phi, sgn, inv)
    return result


def _se3_jac(xi: ArrayLike, sgn: float, inv: float) -> NDArray[np.float64]:
    xi = as_array(xi, "xi", 6)
    result: NDArray[np.float64] = _native.se3_jacobian(xi, sgn, inv)
    return result


@fast_path(_native.so3_jacobian, fixed=(1.0, 0.0))
def so3_left_jacobian(phi: ArrayLike) -> NDArray[np.float64]:
    """SO(3) left Jacobian ``J_l(φ) = I + (1 − cos θ)/θ² Φ + (θ − sin θ)/θ³ Φ²``.

    Defined by ``exp((φ + δ)×) ≈ exp((J_l δ)×) exp(φ×)``; it also maps a rotation-vector rate to the space-frame
    angular velocity, ``ω_space = J_l(φ) φ̇``, and gives the SE(3) translation ``t = J_l(ω) v``.

    Parameters
    ----------
    phi : array_like, shape (..., 3)
        Rotation vectors, radians.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    return _so3_jac(phi, 1.0, 0.0)


@fast_path(_native.so3_jacobian, fixed=(-1.0, 0.0))
def so3_right_jacobian(phi: ArrayLike) -> NDArray[np.float64]:
    """SO(3) right Jacobian ``J_r(φ) = J_l(−φ)``: ``exp((φ + δ)×) ≈ exp(φ×) exp((J_r δ)×)``; (..., 3) -> (..., 3, 3).

    ``ω_body = J_r(φ) φ̇``.
    """
    return _so3_jac(phi, -1.0, 0.0)


@fast_path(_native.so3_jacobian, fixed=(1.0, 1.0))
def so3_left_jacobian_inv(phi: ArrayLike) -> NDArray[np.float64]:
    """Inverse left Jacobian ``J_l(φ)⁻¹ = I − ½ Φ + (1 − (θ/2) cot(θ/2))/θ² Φ²``; (..., 3) -> (..., 3, 3).

    Singular only at θ = 2πk, k ≥ 1 (so regular on the principal ball θ ≤ π).
    """
    return _so3_jac(phi, 1.0, 1.0)


@fast_path(_native.so3_jacobian, fixed=(-1.0, 1.0))
def so3_right_jacobian_inv(phi: ArrayLike) -> NDArray[np.float64]:
    """Inverse right Jacobian ``J_r(φ)⁻¹ = J_l(−φ)⁻¹ = I + ½ Φ + jinv(θ) Φ²``; (..., 3) -> (..., 3, 3)."""
    return _so3_jac(phi, -1.0, 1.0)


@fast_path(_native.se3_jacobian, fixed=(1.0, 0.0))
def se3_left_jacobian(xi: ArrayLike) -> NDArray[np.float64]:
    """SE(3) left Jacobian in the ``[ω, v]`` order: ``[[J_l(ω), 0], [Q(ω, v), J_l(ω)]]``.

    Defined by ``exp((ξ + δ)^) ≈ exp((J_l(ξ) δ)^) exp(ξ^)``; equal to ``Σ_k ad_ξ^k / (k+1)!``.  ``Q`` is Barfoot's
    (see the module docstring).

    Parameters
    ----------
    xi : array_like, shape (..., 6)
        Twists ``[ω, v]``.

    Returns
    -------
    ndarray, shape (..., 6, 6)
    """
    return _se3_jac(xi, 1.0, 0.0)


@fast_path(_native.se3_jacobian, fixed=(-1.0, 0.0))
def se3_right_jacobian(xi: ArrayLike) -> NDArray[np.float64]:
    """SE(3) right Jacobian ``J_r(ξ) = J_l(−ξ)``: ``exp((ξ + δ)^) ≈ exp(ξ^) exp((J_r δ)^)``; (..., 6) -> (..., 6, 6)."""
    return _se3_jac(xi, -1.0, 0.0)


@fast_path(_native.se3_jacobian, fixed=(1.0, 1.0))
def se3_left_jacobian_inv(xi: ArrayLike) -> NDArray[np.float64]:
    """Inverse SE(3) left Jacobian ``[[J⁻¹, 0], [−J⁻¹ Q J⁻¹, J⁻¹]]`` (``J = J_l(ω)``); (..., 6) -> (..., 6, 6)."""
    return _se3_jac(xi, 1.0, 1.0)


@fast_path(_native.se3_jacobian, fixed=(-1.0, 1.0))
def se3_right_jacobian_inv(xi: ArrayLike) -> NDArray[np.float64]:
    """Inverse SE(3) right Jacobian ``J_l(−ξ)⁻¹``; (..., 6) -> (..., 6, 6)."""
    return _se3_jac(xi, -1.0, 1.0)


# ---------------------------------------------------------------------------------------------------------------
# adjoints
# ---------------------------------------------------------------------------------------------------------------


def so3_adjoint(q: ArrayLike) -> NDArray[np.float64]:
    """Adjoint of SO(3): ``Ad_R = R``, so ``exp((R φ)×) = R exp(φ×) Rᵀ``.

    ``q`` is (..., 4) xyzw (normalized inside; zero raises); returns (..., 3, 3) = :func:`matrix_from_quat`.
    """
    return matrix_from_quat(q)


@fast_path(_native.se3_adjoint, nan_declines=True)
def se3_adjoint(q: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Adjoint of the transform ``T = (R(q), t)`` acting on ``[ω, v]`` twists: ``[[R, 0], [t× R, R]]``.

    ``exp((Ad_T ξ)^) = T exp(ξ^) T⁻¹``: it maps a twist expressed in the body frame of ``T`` to the world frame.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Rotation, xyzw (normalized inside; zero raises ``ValueError``).
    t : array_like, shape (..., 3)
        Translation.

    Returns
    -------
    ndarray, shape (..., 6, 6)
    """
    q = as_array(q, "q", 4)
    t = as_array(t, "t", 3)
    out = call_kernel(_native.se3_adjoint, (q, t), ("q", "t"))
    raise_if_zero_norm(out, q, "q")
    return out


def se3_adjoint_from_matrix(matrix: ArrayLike) -> NDArray[np.float64]:
    """:func:`se3_adjoint` of homogeneous transforms ``[[R, t], [0, 1]]``; (..., 4, 4) -> (..., 6, 6).

    ``R`` is used as given (not re-orthogonalised); input must be finite.
    """
    m = as_array(matrix, "matrix", (4, 4))
    check_finite(m, "matrix")
    r = m[..., :3, :3]
    o = np.zeros(m.shape[:-2] + (6, 6))
    o[..., :3, :3] = r
    o[..., 3:, 3:] = r
    o[..., 3:, :3] = so3_hat(m[..., :3, 3]) @ r
    return o


def se3_ad(xi: ArrayLike) -> NDArray[np.float64]:
    """Small adjoint ``ad_ξ = [[ω×, 0], [v×, ω×]]`` (the Lie bracket ``[ξ^, η^] = (ad_ξ η)^``); (..., 6) -> (..., 6, 6).

    ``Ad(exp ξ^) = exp(ad_ξ)`` and ``J_l(ξ) = Σ_k ad_ξ^k / (k+1)!``.
    """
    xi = as_array(xi, "xi", 6)
    o = np.zeros(xi.shape[:-1] + (6, 6))
    w = so3_hat(xi[..., :3])
    o[..., :3, :3] = w
    o[..., 3:, 3:] = w
    o[..., 3:, :3] = so3_hat(xi[..., 3:])
    return o
