"""Pose from point and direction correspondences (Walker, Shao & Volz 1991 §3; Horn 1987; Arun 1987; Umeyama 1991).

Frames: the estimate maps **model** coordinates to **measured** coordinates, ``p̃ ≈ s R p⁰ + t`` (Walker eq. (28)
with an optional scale ``s``).  Quaternions are xyzw (scalar last, Hamilton); dual quaternions ``[real xyzw, dual
xyzw]`` with ``dual = ½ t (x) real``.

Cost (the one every method minimises, for weights ``β_i`` on points and ``α_j`` on directions)::

    E = Σ β_i ‖s R p⁰_i + t − p̃_i‖² + Σ α_j ‖R n⁰_j − ñ_j‖²

Directions are normalized to unit length on input.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose import _native
from dualpose.registration import _row as R
from dualpose.registration._inputs import _EMPTY, _EMPTY3, Problem, method_code, prepare_single

__all__ = ["PoseEstimate", "register_pose", "classify_degeneracy"]

_BAD_INPUT = R.BAD_INPUT_NAMES


def bad_input_message(code: float) -> str:
    """The error for a non-zero result-row code ``row[BAD_INPUT]`` of the solver (see ``_row``)."""
    if int(code) == len(_BAD_INPUT) + 1:
        return ("the weighted second moments overflow (the weighted centroid sums exceed the largest double, "
                "~1.8e308): rescale the inputs")  # fmt: skip
    return f"{_BAD_INPUT[int(code) - 1]} contains NaN or infinity"

#: relative size (squared length, against the largest model scatter eigenvalue: a relative thickness of ~1e-5)
#: below which a direction of the model scatter counts as empty when labelling a degeneracy
_RANK_RTOL = 1e-10


def classify_degeneracy(
    n_points: int, n_directions: int, rotation_unique: bool, scatter_eigenvalues: np.ndarray, coord_scale: float
) -> str:
    """Label the geometry of a registration problem (after Eggert, Lorusso & Fisher 1997).

    Returns one of ``"none"``, ``"coplanar"`` (points only, in one plane: unique, but SVD needs the reflection
    guard), ``"directions-only"`` (rotation unique, translation unobservable), ``"collinear"`` (points on one line,
    possibly with directions along it: rotation about the line unobservable), ``"parallel-directions"``
    (directions only, all parallel), ``"single-point"`` (every point coincides and no direction: rotation
    unobservable) or ``"rotation-ambiguous"`` (the optimum is not unique for another reason, e.g. degenerate
    measured data).  Duplicate points are classified by the distinct geometry they leave.
    """
    mu = np.asarray(scatter_eigenvalues, dtype=float)
    floor = _RANK_RTOL * max(float(mu[0]), 0.0) + (1e-13 * coord_scale) ** 2 * max(n_points, 1)
    rank = int((mu > floor).sum()) if mu[0] > 0 else 0
    if rotation_unique:
        if n_points == 0:
            return "directions-only"
        if n_directions == 0 and rank == 2:
            return "coplanar"
        return "none"
    if rank == 0:
        return "single-point" if n_points > 0 else "parallel-directions"
    if rank == 1:
        return "parallel-directions" if n_points == 0 else "collinear"
    return "rotation-ambiguous"


class PoseEstimate:
    """Result of :func:`register_pose`: the transform model -> measured, ``p̃ ≈ scale · R p⁰ + t``.

    Attributes
    ----------
    quat : ndarray, shape (4,)
        Rotation, unit quaternion xyzw with ``w >= 0``.
    translation : ndarray, shape (3,)
        ``t`` in measured-frame units.  Zero when only directions were given (``translation_observable`` False).
    scale : float
        ``s`` (1 unless ``scale=True``); Umeyama's convention: it multiplies the rotated *model* points.
    cost : float
        The minimised ``E`` (module docstring), from the residuals.
    rmsd : float
        Weighted root-mean-square point residual ``sqrt(Σβ‖r_i‖² / Σβ)``; for directions only, the same over
        direction residuals (chord length).
    degeneracy : str
        See :func:`classify_degeneracy`.
    rotation_unique, translation_observable : bool
        Whether the optimum is unique.  When it is not, the rotation returned is the *smallest* rotation among the
        optimal ones (the identity's projection onto the optimal eigenspace) and ``translation`` matches it.
    eigenvalues : ndarray, shape (4,)
        Descending eigenvalues of the 4x4 matrix that decided the rotation: Walker's ``A`` (eq. (47)) for
        ``"dq"``, Horn's ``N`` for ``"horn"`` and ``"svd"``.
    eigen_gap, gap_tolerance : float
        The gap that decided uniqueness (``λ1 − λ2``; for ``"svd"`` ``2 (σ2 + d σ3)``, which equals Horn's
        ``λ1 − λ2``) and the threshold it was compared with (``1e-9 × Σ(β‖p⁰'‖² + β‖p̃'‖²) + 2Σα``, times 2 for
        Walker's ``A``).
    singular_values : ndarray (3,) or None
        Singular values of the cross-covariance ``H = Σβ p⁰' p̃'ᵀ + Σα n⁰ ñᵀ`` (``"svd"`` only).
    reflection_sign : float or None
        Umeyama's ``d = sign det(V Uᵀ)`` (``"svd"`` only; −1 means the unguarded Kabsch answer was a reflection).
    scatter_eigenvalues : ndarray, shape (3,)
        Descending eigenvalues of the model scatter ``Σβ p⁰'p⁰'ᵀ + Σα n⁰n⁰ᵀ`` (centred points).
    method : str
    n_points, n_directions : int
    """

    __slots__ = ("_row", "_data", "method", "n_points", "n_directions", "_degeneracy")

    def __init__(self, row: NDArray[np.float64], method: str, data: Problem) -> None:
        self._row = row
        self._data = data
        self.method = method
        self.n_points = int(data[0].shape[0])
        self.n_directions = int(data[3].shape[0])
        self._degeneracy: str | None = None

    # ---- solver output (views of the kernel's result row) ----------------------------------------------------
    quat = property(lambda self: self._row[R.QUAT], doc="Rotation, unit quaternion xyzw, w >= 0, shape (4,).")
    translation = property(lambda self: self._row[R.TRANSLATION], doc="Translation t, shape (3,).")
    scale = property(lambda self: float(self._row[R.SCALE]), doc="Scale s (1 unless scale=True).")
    cost = property(lambda self: float(self._row[R.COST]), doc="The minimised cost E.")
    eigenvalues = property(lambda self: self._row[R.EIGENVALUES], doc="Eigenvalues (descending) of A (dq) or N.")
    eigen_gap = property(lambda self: float(self._row[R.EIGEN_GAP]), doc="The gap that decided uniqueness.")
    gap_tolerance = property(lambda self: float(self._row[R.GAP_TOLERANCE]), doc="Threshold the gap was compared with.")
    rotation_unique = property(lambda self: bool(self._row[R.UNIQUE]), doc="Whether the optimal rotation is unique.")
    closed_form = property(
        lambda self: bool(self._row[R.CLOSED_FORM]), doc="Whether the closed-form eigen-solve decided (else Jacobi)."
    )

    @property
    def point_exponent(self) -> int:
        """``e``: the solver worked on the centred points times ``2**e`` (0 unless their spread is extreme)."""
        return int(self._row[R.POINT_EXPONENT])

    def _scaled_scatter_eigenvalues(self) -> NDArray[np.float64]:
        """The scatter eigenvalues of the centred points times ``2**e`` (and direction weights times ``2**(2e)``),
        ``e`` = :attr:`point_exponent`: no underflow or overflow at any magnitude."""
        p0, _, beta, n0, _, alpha = self._data
        e = self.point_exponent
        c = beta @ p0 / beta.sum() if beta.sum() > 0 else np.zeros(3)
        d = np.ldexp(p0 - c, e)
        m = np.einsum("n,ni,nj->ij", beta, d, d) + np.einsum("n,ni,nj->ij", np.ldexp(alpha, 2 * e), n0, n0)
        return np.asarray(np.linalg.eigvalsh(m)[::-1], dtype=np.float64)

    @property
    def scatter_eigenvalues(self) -> NDArray[np.float64]:
        """Eigenvalues (3,), descending, of the model scatter ``Σβ p⁰'p⁰'ᵀ + Σα n⁰n⁰ᵀ`` (centred points)."""
        return np.asarray(np.ldexp(self._scaled_scatter_eigenvalues(), -2 * self.point_exponent), dtype=np.float64)

    @property
    def singular_values(self) -> NDArray[np.float64] | None:
        """Singular values of ``H`` (``"svd"`` only)."""
        return self._row[R.SINGULAR] if self.method == "svd" else None

    @property
    def reflection_sign(self) -> float | None:
        """Umeyama's ``d`` (``"svd"`` only)."""
        return float(self._row[R.REFLECTION]) if self.method == "svd" else None

    @property
    def translation_observable(self) -> bool:
        """False when only directions were given (or every point weight is zero)."""
        return bool(self._data[2].sum() > 0)

    @property
    def rmsd(self) -> float:
        """Weighted RMS point residual ``sqrt(Σβ‖r_i‖² / Σβ)`` (directions only: the same over directions)."""
        bsum = float(self._data[2].sum())
        e = self.point_exponent
        if bsum > 0 and e != 0:  # extreme spread: the residuals' squares in exactly rescaled units
            r = np.ldexp(self.point_residuals, e)
            return float(np.ldexp(np.sqrt(float(self._data[2] @ np.einsum("ij,ij->i", r, r)) / bsum), -e))
        if bsum > 0:
            return float(np.sqrt(max(self._row[R.POINT_COST], 0.0) / bsum))
        return float(np.sqrt(max(self._row[R.COST] - self._row[R.POINT_COST], 0.0) / float(self._data[5].sum())))

    @property
    def degeneracy(self) -> str:
        """Label of the problem's geometry (:func:`classify_degeneracy`)."""
        if self._degeneracy is None:
            p0, p1, beta, _, _, alpha = self._data
            coord = float(max(np.abs(p0).max(initial=0.0), np.abs(p1).max(initial=0.0), 1e-300))
            e = self.point_exponent  # classified in the solver's exactly rescaled units
            self._degeneracy = classify_degeneracy(
                int((beta > 0).sum()), int((alpha > 0).sum()), self.rotation_unique,
                self._scaled_scatter_eigenvalues(), float(np.ldexp(coord, e)),
            )  # fmt: skip
        return self._degeneracy

    # ---- derived representations -------------------------------------------------------------------------
    @property
    def rotation_matrix(self) -> NDArray[np.float64]:
        """``R``, shape (3, 3): ``matrix_from_quat(quat)``."""
        import dualpose as dp

        return dp.matrix_from_quat(self.quat)

    @property
    def dualquat(self) -> NDArray[np.float64]:
        """Unit dual quaternion (8,) ``[q, ½ t (x) q]`` of the rigid part ``p ↦ R p + t`` (the scale is not in it:
        the full estimate is ``dualquat_transform(dualquat, scale * p)``)."""
        import dualpose as dp

        return dp.dualquat_from_qt(self.quat, self.translation)

    def as_matrix(self) -> NDArray[np.float64]:
        """Homogeneous 4x4 ``[[s R, t], [0, 1]]``."""
        m = np.eye(4)
        m[:3, :3] = self.scale * self.rotation_matrix
        m[:3, 3] = self.translation
        return m

    # ---- residuals -----------------------------------------------------------------------------------------
    @property
    def point_residuals(self) -> NDArray[np.float64]:
        """``s R p⁰_i + t − p̃_i``, shape (n, 3), evaluated on centred data (exact at large offsets)."""
        p0, p1, beta = self._data[:3]
        if p0.shape[0] == 0 or beta.sum() == 0:
            return np.zeros((p0.shape[0], 3))
        c0 = beta @ p0 / beta.sum()
        c1 = beta @ p1 / beta.sum()
        r = self.rotation_matrix
        t_c = self.translation - (c1 - self.scale * r @ c0)  # ~0: Walker's centred translation, if any
        result: NDArray[np.float64] = self.scale * (p0 - c0) @ r.T + t_c - (p1 - c1)
        return result

    @property
    def direction_residuals(self) -> NDArray[np.float64]:
        """``R n⁰_j − ñ_j`` for the unit directions, shape (m, 3)."""
        n0, n1 = self._data[3], self._data[4]
        result: NDArray[np.float64] = n0 @ self.rotation_matrix.T - n1
        return result

    # ---- uncertainty ---------------------------------------------------------------------------------------
    def covariance(self, sigma_points: float, sigma_directions: float = 0.0) -> NDArray[np.float64]:
        """First-order covariance (6, 6) of ``[δθ, δt]`` for isotropic noise on the *measured* data.

        The perturbation is on the left (measured frame): ``R_true = exp(δθ×) R̂``, ``t_true = t̂ + δt``.  With the
        Jacobians of the residuals, ``J_i = [−(R p⁰_i)×, I]`` for points and ``J_j = [−(R n⁰_j)×, 0]`` for
        directions, and ``H = Σβ J_iᵀJ_i + Σα J_jᵀJ_j``, the weighted least-squares estimate has the sandwich
        covariance ``H⁻¹ (σ_p² Σβ² J_iᵀJ_i + σ_d² Σα² J_jᵀJ_j) H⁻¹``.  It is evaluated on centred points (where
        ``H`` is block diagonal) and moved to the model origin with ``δt = δu + (R c⁰)× δθ``.  With unit weights
        and points only this is ``Cov(δθ) = σ² (Σ (|q|² I − q qᵀ))⁻¹`` over the centred, rotated model points
        ``q`` and ``Cov(δu) = σ² I / n``.

        Parameters
        ----------
        sigma_points : float
            Standard deviation of each coordinate of each measured point (measured-frame units).
        sigma_directions : float
            Standard deviation of each coordinate of each measured direction (unit vectors; radians, to first
            order, for the tangential part).

        Raises
        ------
        ValueError
            For a negative sigma, a scaled estimate (not covered), or when some of the six components are
            unobservable (``rotation_unique`` or ``translation_observable`` False).
        """
        if not (np.isfinite(sigma_points) and np.isfinite(sigma_directions)) or min(sigma_points, sigma_directions) < 0:
            raise ValueError("sigma_points and sigma_directions must be finite and non-negative")
        if self.scale != 1.0:
            raise ValueError("covariance() is derived for rigid estimates (scale=False) only")
        if not (self.rotation_unique and self.translation_observable):
            raise ValueError(f"covariance undefined: part of the pose is unobservable (degeneracy={self.degeneracy!r})")
        import dualpose as dp

        p0, _, beta, _, _, _ = self._data
        r = self.rotation_matrix
        c0 = beta @ p0 / beta.sum()
        gram_q, gram_u, h_inv = self._rotation_information()
        alpha = self._data[5]
        s_rot = sigma_points**2 * np.einsum("n,nij->ij", beta**2, gram_q) + sigma_directions**2 * np.einsum(
            "n,nij->ij", alpha**2, gram_u
        )
        cov = np.zeros((6, 6))
        cov[:3, :3] = h_inv @ s_rot @ h_inv
        cov[3:, 3:] = np.eye(3) * sigma_points**2 * float((beta**2).sum()) / float(beta.sum()) ** 2
        # u is uncorrelated with δθ on centred data; δt = u + (R c0)× δθ
        t_map = np.eye(6)
        t_map[3:, :3] = dp.so3_hat(r @ c0)
        result: NDArray[np.float64] = t_map @ cov @ t_map.T
        return result

    def _rotation_information(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """``(gram_q (n, 3, 3), gram_u (m, 3, 3), H_rot⁻¹ (3, 3))`` on centred points: ``gram = (x×)ᵀ(x×)`` of the
        rotated centred model points ``q`` and rotated model directions ``u``; ``H_rot = Σβ gram_q + Σα gram_u``."""
        import dualpose as dp

        p0, _, beta, n0, _, alpha = self._data
        r = self.rotation_matrix
        c0 = beta @ p0 / beta.sum() if beta.sum() > 0 else np.zeros(3)
        kq = dp.so3_hat((p0 - c0) @ r.T)  # (n, 3, 3)
        ku = dp.so3_hat(n0 @ r.T)
        gram_q = np.einsum("nki,nkj->nij", kq, kq)  # (q×)ᵀ(q×) = |q|² I − q qᵀ
        gram_u = np.einsum("nki,nkj->nij", ku, ku)
        h_rot = np.einsum("n,nij->ij", beta, gram_q) + np.einsum("n,nij->ij", alpha, gram_u)
        try:
            h_inv = np.linalg.inv(h_rot)
        except np.linalg.LinAlgError:
            raise ValueError("covariance undefined: the rotation information matrix is singular") from None
        return gram_q, gram_u, h_inv

    def direction_influence(self) -> NDArray[np.float64]:
        """First-order influence (m, 3, 3) of an error on each *measured* direction on the rotation error.

        With ``ñ_j = ñ_j,true + e_j``, the estimate moves by ``R̂ = exp(ε×) R_true`` (left, measured frame; ``ε`` is
        minus the ``δθ`` of :meth:`covariance`) with ``ε = Σ_j G_j e_j``, ``G_j = H_rot⁻¹ α_j (u_j×)``,
        ``u_j = R n⁰_j`` (valid with or without points; the centred-point problem decouples rotation from
        translation).  An error ``e⁰_j`` on a
        *model* direction acts like the measured error ``−R e⁰_j``.  Use it to propagate correlated or anisotropic
        direction errors: ``Cov(δθ) = Σ_j G_j C_j G_jᵀ`` for independent errors of covariance ``C_j`` (3, 3), or
        ``(Σ_j G_j M_j) Σ (Σ_j G_j M_j)ᵀ`` for errors ``e_j = M_j b`` sharing a common source ``b``.

        Raises
        ------
        ValueError
            When the rotation is not unique (``rotation_unique`` False).
        """
        if not self.rotation_unique:
            raise ValueError(
                f"direction influence undefined: the rotation is not unique (degeneracy={self.degeneracy!r})"
            )
        import dualpose as dp

        _, _, h_inv = self._rotation_information()
        n0, alpha = self._data[3], self._data[5]
        ku = dp.so3_hat(n0 @ self.rotation_matrix.T)  # (m, 3, 3), (u×)ᵀ = −(u×)
        result: NDArray[np.float64] = np.einsum("ij,m,mjk->mik", h_inv, alpha, ku)
        return result

    def rotation_covariance(
        self,
        sigma_points: float = 0.0,
        sigma_directions: float = 0.0,
        direction_covariances: np.ndarray | None = None,
    ) -> NDArray[np.float64]:
        """First-order covariance (3, 3) of the rotation error ``δθ`` alone (left perturbation, measured frame).

        Unlike :meth:`covariance` it needs only a unique rotation, so it covers the directions-only (Wahba) case.
        Noise on the measured data: isotropic ``sigma_points`` per point coordinate and ``sigma_directions`` per
        direction coordinate, or per-direction covariances ``direction_covariances`` (m, 3, 3) in the measured
        frame (anisotropic, e.g. tangent-plane noise; the radial part has no first-order effect).  The sandwich
        ``H_rot⁻¹ (σ_p² Σβ² gram_q) H_rot⁻¹ + Σ_j G_j C_j G_jᵀ`` with :meth:`direction_influence` ``G_j``; with
        isotropic directions this equals ``covariance(...)[:3, :3]``.
        """
        if not (np.isfinite(sigma_points) and np.isfinite(sigma_directions)) or min(sigma_points, sigma_directions) < 0:
            raise ValueError("sigma_points and sigma_directions must be finite and non-negative")
        m = self.n_directions
        if direction_covariances is None:
            cd = np.broadcast_to(np.eye(3) * sigma_directions**2, (m, 3, 3))
        else:
            cd = np.asarray(direction_covariances, dtype=np.float64)
            if cd.shape != (m, 3, 3) or not np.isfinite(cd).all():
                raise ValueError(f"direction_covariances must be a finite array of shape ({m}, 3, 3); got {cd.shape}")
            if sigma_directions != 0.0:
                raise ValueError("give sigma_directions or direction_covariances, not both")
        g = self.direction_influence()
        gram_q, _, h_inv = self._rotation_information()
        beta = self._data[2]
        cov = sigma_points**2 * h_inv @ np.einsum("n,nij->ij", beta**2, gram_q) @ h_inv
        cov = cov + np.einsum("mij,mjk,mlk->il", g, cd, g)
        result: NDArray[np.float64] = 0.5 * (cov + cov.T)
        return result

    def __repr__(self) -> str:
        with np.printoptions(precision=6, suppress=True):
            return (
                f"PoseEstimate(method={self.method!r}, quat={self.quat}, translation={self.translation}, "
                f"scale={self.scale:.6g}, rmsd={self.rmsd:.3g}, degeneracy={self.degeneracy!r})"
            )


def _plain_points(p0: object, p1: object) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """``(p0, p1)`` when both are C-contiguous float64 ndarrays of the same shape (n, 3) with n >= 3, else None."""
    if (
        type(p0) is np.ndarray
        and type(p1) is np.ndarray
        and p0.dtype == np.float64
        and p1.dtype == np.float64
        and p0.ndim == 2
        and p0.shape == p1.shape
        and p0.shape[1] == 3
        and p0.shape[0] >= 3
        and p0.flags.c_contiguous
        and p1.flags.c_contiguous
    ):
        return p0, p1
    return None


def register_pose(
    model_points: ArrayLike | None,
    measured_points: ArrayLike | None,
    *,
    model_directions: ArrayLike | None = None,
    measured_directions: ArrayLike | None = None,
    point_weights: ArrayLike | None = None,
    direction_weights: ArrayLike | None = None,
    method: str = "dq",
    scale: bool = False,
) -> PoseEstimate:
    """Rigid (or similarity) transform that maps model points/directions onto measured ones.

    Minimises ``E = Σ β_i ‖s R p⁰_i + t − p̃_i‖² + Σ α_j ‖R n⁰_j − ñ_j‖²`` (``s = 1`` unless ``scale``).

    Parameters
    ----------
    model_points, measured_points : array_like, shape (n, 3), or None
        Corresponding points ``p⁰_i`` (model frame) and ``p̃_i`` (measured frame).  ``None`` for directions only
        (Wahba's problem): the rotation is returned and ``translation_observable`` is False.
    model_directions, measured_directions : array_like, shape (m, 3), optional
        Corresponding directions ``n⁰_j``, ``ñ_j`` (e.g. surface normals, edge directions); normalized here.
    point_weights, direction_weights : array_like, shape (n,) / (m,), optional
        ``β_i``, ``α_j`` >= 0 (default 1).  With inverse variances (``β = 1/σ_p²``, ``α = 1/σ_d²``) the estimate
        is maximum likelihood for isotropic Gaussian noise.
    method : {"dq", "horn", "svd"}
        ``"dq"``: Walker 1991 §3.2 — ``C1, C2, C3`` (eqs. (35)-(37)), ``A`` (eq. (47)), ``r`` the eigenvector of the
        largest eigenvalue, ``s = −(C2 + C2ᵀ)⁻¹ C3 r`` (eq. (45)), ``t = 2 vec(W(r)ᵀ s)``.  Two changes to the
        paper: point weights are multiplied by 4, because Walker's position quaternions ``½[p; 0]`` would
        otherwise weight directions 4x relative to points (so ``E`` above is what is minimised); and the points
        are centred on their weighted centroids before the matrices are built (uncentred, ``A`` grows with the
        squared distance from the origin: at a 1e6 offset with a spread of 10 the rotation loses ~6 digits and
        the translation is off by units; see docs/registration.md).
        ``"horn"``: Horn 1987's 4x4 symmetric ``N`` (largest algebraic eigenvalue).  ``"svd"``: Arun 1987 /
        Kabsch with Umeyama 1991's reflection guard.  All three minimise the same cost and return the same optimum
        (to ~1e-12).  The 4x4 eigenproblems are solved in closed form (quartic characteristic polynomial,
        adjugate eigenvector) when a residual check vouches for the answer, else by a cyclic Jacobi iteration.
    scale : bool
        Estimate a similarity ``p̃ ≈ s R p⁰ + t`` (Umeyama 1991 eq. (42)): ``s = Σβ p̃'·R p⁰' / Σβ‖p⁰'‖²``, the
        scale multiplies the model (it is not symmetric in model and measured).  Points only.

    Returns
    -------
    PoseEstimate

    Raises
    ------
    ValueError
        Bad shapes, non-finite values, negative weights, zero direction vectors, ``scale`` with directions, or
        fewer correspondences than needed to fix a rotation (3 points, 1 point + 2 directions, 2 points + 1
        direction, or 2 directions).  Degenerate geometry (collinear, coincident points) is not an error: see
        ``PoseEstimate.degeneracy``.

    Examples
    --------
    >>> import numpy as np, dualpose as dp
    >>> from dualpose.registration import register_pose
    >>> model = np.random.default_rng(0).normal(size=(5, 3))
    >>> q = dp.quat_from_rotvec([0.1, 0.2, 0.3])
    >>> est = register_pose(model, dp.quat_rotate(q, model) + [1.0, 0.0, 0.0])
    >>> bool(np.allclose(est.quat, q)), est.translation.round(12) + 0.0
    (True, array([1., 0., 0.]))
    """
    code = method_code(method)
    plain = _plain_points(model_points, measured_points)
    data: Problem
    if plain is not None and (
        model_directions is None and measured_directions is None and point_weights is None and direction_weights is None
    ):  # fast path: the same checks, cheaper (a single problem of 10 points costs a few microseconds)
        data = (plain[0], plain[1], np.ones(plain[0].shape[0]), _EMPTY3, _EMPTY3, _EMPTY)
    else:
        data = prepare_single(
            model_points, measured_points, model_directions, measured_directions, point_weights, direction_weights
        )
    if scale and data[3].shape[0] > 0:
        raise ValueError("scale=True is supported for points only (the direction term does not scale)")
    row = np.empty(R.ROW_SIZE)
    _native.registration_solve_one(*data, code, bool(scale), row)
    if row[R.BAD_INPUT]:
        raise ValueError(bad_input_message(row[R.BAD_INPUT]))
    return PoseEstimate(row, method, data)

