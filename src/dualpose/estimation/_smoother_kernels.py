"""numba kernels of the Rauch–Tung–Striebel smoother (linear, and over the error-state filter's nodes).

Imported lazily by :mod:`dualpose.estimation.smoother`.  Layouts (:mod:`dualpose.estimation.state`): nominal
state (16,) = ``ESKF_STATE``, error state (15,) = ``ESKF_ERROR`` with the local
(right) attitude error ``q = q̂ ⊗ Exp(δθ)``; covariances of an error state are expressed in the tangent space of
the nominal state they belong to.  The derivation is in ``docs/fusion.md`` ("Offline smoothing (RTS)").
"""

from __future__ import annotations

import numba as nb
import numpy as np

from dualpose.algebra._kutil import norm3, qmul
from dualpose.algebra._lie_kernels import so3_coeffs, so3_fill
from dualpose.algebra.series import atan2c
from dualpose.estimation._eskf_kernels import quat_mul_exp_inplace
from dualpose.estimation.state import ESKF_ACCEL_BIAS as _BA
from dualpose.estimation.state import ESKF_D_ACCEL_BIAS as _DBA
from dualpose.estimation.state import ESKF_D_ATTITUDE as _DTH
from dualpose.estimation.state import ESKF_D_GYRO_BIAS as _DBG
from dualpose.estimation.state import ESKF_D_POSITION as _DP
from dualpose.estimation.state import ESKF_D_VELOCITY as _DV
from dualpose.estimation.state import ESKF_ERROR_DIM as _NE
from dualpose.estimation.state import ESKF_GYRO_BIAS as _BG
from dualpose.estimation.state import ESKF_POSITION as _P
from dualpose.estimation.state import ESKF_QUAT as _Q
from dualpose.estimation.state import ESKF_VELOCITY as _V

V, M, T = "f8[::1]", "f8[:,::1]", "f8[:,:,::1]"
VA = "f8[:]"


def _jit(sig: str):
    """Eager compilation, as in :mod:`dualpose.estimation._eskf_kernels`."""
    return nb.njit(sig, cache=True, nogil=True)


@_jit(f"void({VA}, {VA}, {VA})")
def boxminus(x, y, out):
    """``out`` (15,) = ``x ⊟ y``, the error state that takes the nominal ``y`` (16,) to ``x`` (16,):
    ``x = y ⊞ out`` with ``δθ = Log(q_y* ⊗ q_x)`` (rotation vector, angle in [0, π])."""
    for i in range(3):
        out[_DP + i] = x[_P + i] - y[_P + i]
        out[_DV + i] = x[_V + i] - y[_V + i]
        out[_DBG + i] = x[_BG + i] - y[_BG + i]
        out[_DBA + i] = x[_BA + i] - y[_BA + i]
    # q_y* ⊗ q_x
    q, a = _Q, _DTH
    rx, ry, rz, rw = qmul(-y[q], -y[q + 1], -y[q + 2], y[q + 3], x[q], x[q + 1], x[q + 2], x[q + 3])
    if rw < 0.0:
        rx, ry, rz, rw = -rx, -ry, -rz, -rw
    f = 2.0 * atan2c(norm3(rx, ry, rz), rw)
    out[a], out[a + 1], out[a + 2] = f * rx, f * ry, f * rz


@_jit(f"void({VA}, {VA}, {VA})")
def boxplus(x, dx, out):
    """``out`` (16,) = ``x ⊞ δx``: ``p + δp``, ``v + δv``, ``q ⊗ Exp(δθ)``, ``b_g + δb_g``, ``b_a + δb_a``."""
    for i in range(3):
        out[_P + i] = x[_P + i] + dx[_DP + i]
        out[_V + i] = x[_V + i] + dx[_DV + i]
        out[_BG + i] = x[_BG + i] + dx[_DBG + i]
        out[_BA + i] = x[_BA + i] + dx[_DBA + i]
    for i in range(4):
        out[_Q + i] = x[_Q + i]
    quat_mul_exp_inplace(out[_Q : _Q + 4], dx[_DTH], dx[_DTH + 1], dx[_DTH + 2])


@_jit(f"void({VA}, f8, {M})")
def right_jacobian(phi, inverse, out):
    """``out`` (3, 3) = the SO(3) right Jacobian ``J_r(φ)`` (``inverse`` = 0) or ``J_r⁻¹(φ)`` (``inverse`` = 1).

    ``J_r(φ) = J_l(−φ)`` (Solà 2017 eq. 183, 186): ``Exp(φ + δφ) ≈ Exp(φ) Exp(J_r(φ) δφ)``.
    """
    x, y, z = phi[0], phi[1], phi[2]
    a, b, c = so3_coeffs(norm3(x, y, z), inverse)
    so3_fill(-x, -y, -z, a, b, c, out, 0, 0)


@_jit(f"void({M}, {M})")
def congruence_attitude(S, A):
    """``S ← J S Jᵀ`` in place for ``J = diag(I₆, A, I₆)`` (15, 15): a change of attitude chart (``A`` (3, 3));
    the changed rows/columns are symmetrised."""
    n = S.shape[0]
    rows = np.empty((3, n))
    for i in range(3):
        for j in range(n):
            s = 0.0
            for k in range(3):
                s += A[i, k] * S[_DTH + k, j]
            rows[i, j] = s
    for i in range(3):
        for j in range(n):
            S[_DTH + i, j] = rows[i, j]
    for j in range(n):
        a, b, c = _DTH, _DTH + 1, _DTH + 2
        c0 = S[j, a] * A[0, 0] + S[j, b] * A[0, 1] + S[j, c] * A[0, 2]
        c1 = S[j, a] * A[1, 0] + S[j, b] * A[1, 1] + S[j, c] * A[1, 2]
        c2 = S[j, a] * A[2, 0] + S[j, b] * A[2, 1] + S[j, c] * A[2, 2]
        S[j, a], S[j, b], S[j, c] = c0, c1, c2
    for i in range(_DTH, _DTH + 3):
        for j in range(n):
            s = 0.5 * (S[i, j] + S[j, i])
            S[i, j] = s
            S[j, i] = s


@_jit(f"void({M}, {M}, {M}, {V}, {M}, {V}, {M})")
def rts_step(P_post, P_prior_next, F, mu_next, S_next, d_out, S_out):
    """One backward RTS step in error coordinates (Särkkä 2013 Thm 8.2; Solà 2017 §7 charts).

    ``P_post`` (n, n) filtered covariance at node i, ``P_prior_next`` (n, n) predicted covariance at i + 1,
    ``F`` (n, n) transition i → i + 1, ``mu_next`` (n,) / ``S_next`` (n, n) the smoothed mean / covariance at i + 1
    relative to the prediction at i + 1.  Writes the smoothed mean relative to the filtered one at i, ``d_out`` (n,)
    ``= G mu_next``, and its covariance ``S_out = P_post + G (S_next − P_prior_next) Gᵀ`` with the gain
    ``G = P_post Fᵀ P_prior_next⁻¹`` obtained by a linear solve (``P_prior_next Gᵀ = F P_post``), symmetrised.
    """
    n = P_post.shape[0]
    Gt = np.linalg.solve(P_prior_next, F @ P_post)
    G = Gt.T
    d_out[:] = G @ mu_next
    D = S_next - P_prior_next
    S_out[:, :] = P_post + G @ D @ Gt
    for i in range(n):
        for j in range(i + 1, n):
            s = 0.5 * (S_out[i, j] + S_out[j, i])
            S_out[i, j] = s
            S_out[j, i] = s


@_jit(f"void({M}, {T}, {M}, {T}, {T}, {M}, {T})")
def rts_linear(x_post, P_post, x_prior, P_prior, F, x_smooth, P_smooth):
    """Linear RTS over K steps: ``x_post``/``x_prior`` (K, n), ``P_post``/``P_prior`` (K, n, n), ``F`` (K, n, n)
    with ``F[i]`` the transition i → i + 1 (``F[K−1]`` unused); writes ``x_smooth`` (K, n), ``P_smooth``
    (K, n, n)."""
    K, n = x_post.shape[0], x_post.shape[1]
    x_smooth[K - 1] = x_post[K - 1]
    P_smooth[K - 1] = P_post[K - 1]
    mu = np.empty(n)
    d = np.empty(n)
    for i in range(K - 2, -1, -1):
        for j in range(n):
            mu[j] = x_smooth[i + 1, j] - x_prior[i + 1, j]
        rts_step(P_post[i], P_prior[i + 1], F[i], mu, P_smooth[i + 1], d, P_smooth[i])
        for j in range(n):
            x_smooth[i, j] = x_post[i, j] + d[j]


@_jit(f"void({M}, {T}, {M}, {T}, {T}, {M}, {T})")
def rts_error_state(x_post, P_post, x_prior, P_prior, F, x_smooth, P_smooth):
    """Error-state RTS over the K nodes of the error-state filter (layouts in the module docstring).

    Inputs as :func:`rts_linear` with nominal states (K, 16) and error covariances (K, 15, 15), each covariance in
    the chart of its own nominal state.  For i = K − 2 … 0: the smoothed state at i + 1 is written in the chart of the
    prediction there, ``μ = x^s_{i+1} ⊟ x⁻_{i+1}``, ``Σ = J_r⁻¹(μ_θ) P^s_{i+1} J_r⁻ᵀ(μ_θ)`` (attitude block); one
    linear step :func:`rts_step` gives ``δ`` and ``S`` in the chart of the filtered state ``x⁺_i``; then
    ``x^s_i = x⁺_i ⊞ δ`` and ``P^s_i = J_r(δ_θ) S J_rᵀ(δ_θ)`` (the smoother's reset, of which the filter's
    ``G = I − [½δθ]×`` is the first-order form).  Writes ``x_smooth`` (K, 16), ``P_smooth`` (K, 15, 15).
    """
    K = x_post.shape[0]
    x_smooth[K - 1] = x_post[K - 1]
    P_smooth[K - 1] = P_post[K - 1]
    mu = np.empty(_NE)
    d = np.empty(_NE)
    S = np.empty((_NE, _NE))
    A = np.empty((3, 3))
    for i in range(K - 2, -1, -1):
        boxminus(x_smooth[i + 1], x_prior[i + 1], mu)
        S[:, :] = P_smooth[i + 1]
        right_jacobian(mu[_DTH : _DTH + 3], 1.0, A)
        congruence_attitude(S, A)
        rts_step(P_post[i], P_prior[i + 1], F[i], mu, S, d, P_smooth[i])
        boxplus(x_post[i], d, x_smooth[i])
        right_jacobian(d[_DTH : _DTH + 3], 0.0, A)
        congruence_attitude(P_smooth[i], A)
