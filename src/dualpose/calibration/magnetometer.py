"""Magnetometer self-calibration (hard iron, per-axis scale, symmetric soft iron) from the magnetometer alone, with an
objective decision whether the data support it.

A magnetometer in a homogeneous static field ``m_e`` with hard-iron offset ``b`` and soft-iron distortion reads
``m = A⁻¹ Rᵀ m_e + b``; the calibrated field ``A (m − b)`` then has a constant magnitude whatever the orientation::

    |A (m − b)|² = (m − b)ᵀ M (m − b) = r²,   M = AᵀA = I + D                                       (1)

Expanding (1) gives an equation linear in the parameters (``v = M b``, ``c = r² − bᵀ M b``)::

    mᵀm = −mᵀ D m + 2 mᵀ v + c                                                                         (2)

with ``trace D = 0`` fixing the (irrelevant) overall scale.  Three nested models are fitted by linear least squares
over the *undisturbed* samples (``|m|`` within ``norm_tolerance`` of its median; after a first fit re-selected by
the calibrated magnitude and refitted, so that a large hard iron does not truncate the data selectively):
``"hard_iron"`` (``D = 0``, 4 parameters: the classical sphere fit), ``"diagonal"`` (``D`` diagonal: per-axis
scale, 6) and ``"symmetric"`` (full symmetric ``D``: soft iron without a rotation part, 9).  Then ``b = M⁻¹ v``
and ``A = M^½`` (symmetric), refined by geometric least squares of ``|A (m − b)| − r`` (the algebraic fit is
biased by the noise in its quadratic regressors).

The decision to apply a model is taken by fixed, reference-free criteria computed from the magnetometer alone (the
same thresholds for every recording; docs/broad.md says what was known when they were chosen):

* **orientation coverage**: the smallest eigenvalue of the covariance of the unit field directions ``m / |m|`` over
  the used samples must be at least ``min_coverage`` (0.02; an isotropic sphere gives 1/3, rotation about one axis
  only gives 0): without rotation about every axis (1) cannot separate an offset from the field itself and the fit
  is ill-conditioned (BROAD's translation trials: ≤ 5·10⁻⁴);
* **well-determined parameters**: the standard errors of ``b`` (µT) and of ``A − I`` from the least-squares
  covariance, with the residual variance inflated by the residual's integrated autocorrelation time (consecutive
  samples are not independent), must be at most ``max_sigma`` (2 %) of the field magnitude and of 1, respectively;
* **a substantial reduction of the field-magnitude spread**: the relative standard deviation of ``|m|`` in excess
  of the sensor noise (``sqrt(var_rel − σ²_noise,rel)``, the noise from the sample-to-sample differences of ``|m|``)
  must drop by at least the factor ``min_reduction`` (2, i.e. the model explains ≥ 75 % of the excess variance of
  the magnitude).  A spread the model cannot explain (a spatially inhomogeneous field, a field that changes in
  time) is not a calibration error, and fitting it would only distort the field directions.

and the excess spread must be at least ``min_excess`` (0.5 %) to begin with.  Models are tried smallest first (hard
iron, diagonal, symmetric); a model is chosen when it meets all criteria, with the reduction measured against the
raw data for the first chosen model and against the model chosen so far for a larger one (a larger model must halve
the spread left by the smaller one again, i.e. the smallest model that explains the data is kept).  When no model
qualifies, the data are used raw.  :class:`MagCalibration` reports the decision, the reason and every number behind it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, TypedDict

import numpy as np
from numpy.typing import NDArray

from dualpose.calibration.sensor_time_offset import check_samples

__all__ = [
    "MagCalibration", "MagCandidate", "MAG_CALIBRATION_MODELS", "estimate_mag_calibration", "fit_mag_calibration"
]

#: nested models, smallest first
MAG_CALIBRATION_MODELS = ("hard_iron", "diagonal", "symmetric")


class MagCandidate(TypedDict):
    """One fitted model of the ``candidates`` of :class:`MagCalibration`: the excess relative spread of ``|m|`` after it
    (``spread``) and of the raw samples it was fitted on (``spread_raw``), the largest standard errors of the offset
    (µT) and of a matrix entry, the offset ``b`` (3,) µT, the matrix ``A`` (3, 3) and the number of samples."""

    spread: float
    spread_raw: float
    offset_sigma: float
    matrix_sigma: float
    offset: NDArray[np.float64]
    matrix: NDArray[np.float64]
    samples: int


@dataclass(frozen=True)
class MagCalibration:
    """Result of :func:`estimate_mag_calibration`.

    Attributes
    ----------
    applied : bool
        Whether the calibration passed the decision rule (if False, :meth:`apply` returns the data unchanged).
    model : str
        The applied model, or ``"none"``.
    offset : ndarray, shape (3,)
        Hard-iron offset ``b``, µT (sensor axes); zeros when not applied.
    matrix : ndarray, shape (3, 3)
        Symmetric soft-iron matrix ``A`` (calibrated field ``A (m − b)``); identity when not applied.
    reason : str
        Why it was (not) applied.
    samples : int
        Undisturbed samples used in the fit.
    coverage : ndarray, shape (3,)
        Eigenvalues (ascending) of the covariance of the unit field directions.
    noise_spread : float
        Relative white-noise standard deviation of ``|m|`` per sample.
    spread_before : float
        Relative standard deviation of ``|m|`` in excess of the noise, raw data.
    candidates : dict
        Per model: ``spread`` (excess relative spread after calibration), ``offset_sigma`` (µT, max over axes),
        ``matrix_sigma`` (max over entries), ``offset``, ``matrix``, ``samples`` (after re-selecting the
        undisturbed samples by the calibrated magnitude) and ``spread_raw`` (the raw excess spread on those samples).
    """

    applied: bool
    model: str
    offset: np.ndarray
    matrix: np.ndarray
    reason: str
    samples: int
    coverage: np.ndarray
    noise_spread: float
    spread_before: float
    candidates: dict[str, MagCandidate] = field(default_factory=dict)

    @property
    def spread_after(self) -> float:
        """Excess relative spread of ``|m|`` after the applied calibration (= before when not applied)."""
        return self.candidates[self.model]["spread"] if self.applied else self.spread_before

    def apply(self, mag: np.ndarray) -> np.ndarray:
        """Calibrated field ``A (m − b)`` of samples ``mag`` (n, 3) µT; a copy of ``mag`` when not applied."""
        m = np.asarray(mag, dtype=np.float64)
        out: NDArray[np.float64] = m.copy() if not self.applied else (m - self.offset) @ self.matrix.T
        return out

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "mag_calibration_applied": self.applied,
            "mag_calibration_model": self.model,
            "mag_calibration_reason": self.reason,
            "mag_hard_iron_uT": self.offset.tolist(),
            "mag_soft_iron_matrix": self.matrix.tolist(),
            "mag_coverage_min_eigenvalue": float(self.coverage[0]),
            "mag_norm_spread_before": self.spread_before,
            "mag_norm_spread_after": self.spread_after,
        }


def _design(m: np.ndarray, model: str) -> np.ndarray:
    x, y, z = m.T
    cols = []
    if model in ("diagonal", "symmetric"):
        cols += [-(x * x - z * z), -(y * y - z * z)]
    if model == "symmetric":
        cols += [-2 * x * y, -2 * x * z, -2 * y * z]
    cols += [2 * x, 2 * y, 2 * z, np.ones_like(x)]
    return np.stack(cols, axis=1)


def _integrated_autocorrelation_time(r: np.ndarray) -> float:
    """1 + 2 Σ ρ_k summed until ρ first drops below 0.05 (FFT autocorrelation); ≥ 1."""
    r = r - r.mean()
    n = r.shape[0]
    f = np.fft.rfft(r, 2 * n)
    ac = np.fft.irfft(f * np.conj(f))[:n]
    if not ac[0] > 0:
        return 1.0
    rho = ac / ac[0]
    below = np.nonzero(rho < 0.05)[0]
    k = below[0] if below.size else n
    return float(max(1.0, 1.0 + 2.0 * rho[1:k].sum()))


def _sym_from_params(p: np.ndarray, n_d: int) -> np.ndarray:
    D = np.zeros((3, 3))
    if n_d >= 2:
        D[0, 0], D[1, 1] = p[0], p[1]
        D[2, 2] = -p[0] - p[1]
    if n_d == 5:
        D[0, 1] = D[1, 0] = p[2]
        D[0, 2] = D[2, 0] = p[3]
        D[1, 2] = D[2, 1] = p[4]
    return D


def fit_mag_calibration(mag: np.ndarray, model: str) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Fit one calibration model: algebraic least squares of eq. (2), refined by geometric least squares.

    The algebraic fit (linear, closed form) is biased by noise in its quadratic regressors (errors in variables);
    it only initialises a Gauss–Newton / trust-region refinement of the geometric residual
    ``|A (m − b)| − r`` over ``b``, ``r`` and the trace-free part ``S`` of ``A = I + S`` (``scipy.optimize.
    least_squares``).

    Parameters
    ----------
    mag : ndarray, shape (n, 3)
        Field samples, µT (undisturbed ones).
    model : {"hard_iron", "diagonal", "symmetric"}

    Returns
    -------
    offset : ndarray, shape (3,)
        ``b``, µT.
    matrix : ndarray, shape (3, 3)
        Symmetric ``A`` with ``trace A = 3``.
    offset_sigma : float
        Largest standard error of ``b`` (µT) from the Gauss–Newton covariance ``s² (JᵀJ)⁻¹``, inflated by the
        residual's integrated autocorrelation time (consecutive samples are not independent).
    matrix_sigma : float
        Largest standard error of an entry of ``A`` (same covariance).
    """
    from scipy.optimize import least_squares

    if model not in MAG_CALIBRATION_MODELS:
        raise ValueError(f"model must be one of {MAG_CALIBRATION_MODELS}; got {model!r}")
    m = np.asarray(mag, dtype=np.float64)
    X = _design(m, model)
    y = np.einsum("ij,ij->i", m, m)
    p, *_ = np.linalg.lstsq(X, y, rcond=None)
    n_d = X.shape[1] - 4
    M = np.eye(3) + _sym_from_params(p, n_d)
    w, V = np.linalg.eigh(M)
    if not (w > 0).all():  # not an ellipsoid: no calibration can make the magnitude constant
        return np.full(3, np.nan), np.full((3, 3), np.nan), math.inf, math.inf
    b0 = np.linalg.solve(M, p[n_d:n_d + 3])
    A0 = (V * np.sqrt(w)) @ V.T
    A0 *= 3.0 / np.trace(A0)
    S0 = A0 - np.eye(3)
    s_init = {0: [], 2: [S0[0, 0], S0[1, 1]], 5: [S0[0, 0], S0[1, 1], S0[0, 1], S0[0, 2], S0[1, 2]]}[n_d]
    r0 = float(np.mean(np.linalg.norm((m - b0) @ A0.T, axis=1)))
    x0 = np.concatenate([s_init, b0, [r0]])

    def residual(x: np.ndarray) -> np.ndarray:
        A = np.eye(3) + _sym_from_params(x, n_d)
        r: NDArray[np.float64] = np.linalg.norm((m - x[n_d:n_d + 3]) @ A.T, axis=1) - x[-1]
        return r

    sol = least_squares(residual, x0, method="lm", x_scale="jac")
    x, r, J = sol.x, sol.fun, np.asarray(sol.jac, dtype=np.float64)  # method="lm": a dense Jacobian
    dof = max(1, r.shape[0] - x.shape[0])
    cov = np.linalg.pinv(J.T @ J) * (r @ r / dof) * _integrated_autocorrelation_time(r)
    sig = np.sqrt(np.maximum(np.diag(cov), 0.0))
    A = np.eye(3) + _sym_from_params(x, n_d)
    matrix_sigma = float(sig[:n_d].max()) if n_d else 0.0
    if n_d >= 2:  # A_zz − 1 = −S_xx − S_yy
        matrix_sigma = max(matrix_sigma, math.sqrt(max(cov[0, 0] + cov[1, 1] + 2 * cov[0, 1], 0.0)))
    return x[n_d:n_d + 3].copy(), A, float(sig[n_d:n_d + 3].max()), matrix_sigma


def _excess_spread(norm: np.ndarray, noise_rel: float) -> float:
    rel = float(np.std(norm) / np.mean(norm))
    return math.sqrt(max(rel * rel - noise_rel * noise_rel, 0.0))


def estimate_mag_calibration(
    mag: np.ndarray,
    *,
    norm_tolerance: float = 0.10,
    min_coverage: float = 0.02,
    max_sigma: float = 0.02,
    min_reduction: float = 2.0,
    min_excess: float = 0.005,
    max_fit_samples: int = 8000,
    noise_spread: float | None = None,
    models: tuple[str, ...] = MAG_CALIBRATION_MODELS,
) -> MagCalibration:
    """Fit the magnetometer calibration models and decide whether to apply one (module docstring).

    Parameters
    ----------
    mag : array_like, shape (n, 3)
        Magnetic field samples, µT (any unit), sensor axes.
    norm_tolerance : float
        Samples whose ``|m|`` deviates from the median by more than this fraction are treated as disturbed and
        left out (default 10 %).
    min_coverage : float
        Minimum of the smallest eigenvalue of the unit-direction covariance (default 0.02; isotropic = 1/3).
    max_sigma : float
        Maximum standard error of ``b`` relative to the median ``|m|`` and of the entries of ``A`` (default 2 %).
    min_reduction : float
        Required factor of reduction of the excess relative spread of ``|m|`` (default 2).
    min_excess : float
        Excess relative spread below which nothing is fitted (default 0.5 % of the field, ≈ 0.25 µT of the
        earth's field: direction errors ≲ 0.3°, not worth a calibration).
    max_fit_samples : int
        The fit uses every k-th undisturbed sample so that at most this many enter it (default 8000; consecutive
        samples are strongly correlated, and the standard errors account for the correlation that remains).
    noise_spread : float, optional
        Relative standard deviation of ``|m|`` due to sensor noise alone (e.g. measured at rest:
        :func:`~dualpose.estimation.ahrs.estimate_orientation` passes the rest period's robust value).  Default: from
        the sample-to-sample differences of ``|m|``, which underestimates coloured (low-passed) noise and so makes
        the reduction criterion stricter, never looser.
    models : tuple of str
        Candidate models, tried in this order (default smallest first).

    Returns
    -------
    MagCalibration
    """
    m = check_samples(mag, "mag")
    for name in models:
        if name not in MAG_CALIBRATION_MODELS:
            raise ValueError(f"models must be taken from {MAG_CALIBRATION_MODELS}; got {name!r}")
    norm = np.linalg.norm(m, axis=1)
    med = float(np.median(norm)) if norm.size else 0.0

    def refuse(reason: str, n: int = 0, cov: NDArray[np.float64] | None = None, noise: float = math.nan,
               before: float = math.nan, cand: dict[str, MagCandidate] | None = None) -> MagCalibration:
        cov = np.zeros(3) if cov is None else cov
        return MagCalibration(False, "none", np.zeros(3), np.eye(3), reason, n, cov, noise, before, cand or {})

    if m.shape[0] < 100 or not med > 0:
        return refuse("fewer than 100 samples or zero field")
    keep = np.abs(norm / med - 1.0) <= norm_tolerance
    mk, nk = m[keep], norm[keep]
    if mk.shape[0] < 100:
        return refuse("fewer than 100 undisturbed samples", int(mk.shape[0]))
    u = mk / nk[:, None]
    coverage = np.linalg.eigvalsh(np.cov(u.T))
    if noise_spread is None:
        d = np.diff(norm)
        noise_rel = float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0) / med)
    elif not (np.isfinite(noise_spread) and noise_spread >= 0):
        raise ValueError(f"noise_spread must be a non-negative relative standard deviation; got {noise_spread}")
    else:
        noise_rel = float(noise_spread)
    before = _excess_spread(nk, noise_rel)
    if coverage[0] < min_coverage:
        return refuse(f"orientation coverage too small (smallest direction eigenvalue {coverage[0]:.2g} < "
                      f"{min_coverage})", int(mk.shape[0]), coverage, noise_rel, before)
    cand: dict[str, MagCandidate] = {}
    chosen: str | None = None
    for name in models:
        sel = keep
        for _ in range(2):  # re-select the undisturbed samples by the calibrated magnitude, refit
            idx = np.nonzero(sel)[0]
            b, A, sb, sA = fit_mag_calibration(m[idx[:: max(1, -(-idx.size // max_fit_samples))]], name)
            if not np.isfinite(sb):
                break
            cn = np.linalg.norm((m - b) @ A.T, axis=1)
            new_sel = np.abs(cn / np.median(cn) - 1.0) <= norm_tolerance
            if new_sel.sum() < 100 or (new_sel == sel).all():
                break
            sel = new_sel
        if np.isfinite(sb):
            raw = _excess_spread(norm[sel], noise_rel)
            after = _excess_spread(np.linalg.norm((m[sel] - b) @ A.T, axis=1), noise_rel)
        else:
            raw, after = before, math.inf
        cand[name] = {"spread": after, "spread_raw": raw, "offset_sigma": sb, "matrix_sigma": sA, "offset": b,
                      "matrix": A, "samples": int(sel.sum())}
        # reference: the raw data (on the same samples), or the model chosen so far (a larger model must again cut
        # the spread by the factor, on top of the smaller one)
        ref = raw if chosen is None else cand[chosen]["spread"]
        ok = sb <= max_sigma * med and sA <= max_sigma and ref >= min_excess and after * min_reduction <= ref
        if ok:
            chosen = name
    if chosen is None:
        best = min(cand, key=lambda k: cand[k]["spread"])
        return refuse(f"no model reduces the excess field-magnitude spread {before:.4f} by {min_reduction}x with "
                      f"well-determined parameters (minimum excess {min_excess}; best: {best}, "
                      f"{cand[best]['spread']:.4f})",
                      int(mk.shape[0]), coverage, noise_rel, before, cand)
    c = cand[chosen]
    return MagCalibration(True, chosen, c["offset"], c["matrix"],
                          f"{chosen}: excess spread {c['spread_raw']:.4f} -> {c['spread']:.4f}", int(mk.shape[0]),
                          coverage, noise_rel, before, cand)
