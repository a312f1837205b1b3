"""register_pose: the three solvers agree, minimise the documented cost, match scipy, survive offsets and degeneracy."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

import dualpose as dp
from dualpose.registration import register_pose

METHODS = ("dq", "horn", "svd")


def _pose(rng: np.random.Generator, angle: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    q = dp.quat_normalize(rng.normal(size=4))
    if angle is not None:
        q = dp.quat_from_axis_angle(rng.normal(size=3), angle)
    return dp.quat_canonical(q), rng.normal(size=3) * 3


def _problem(rng, n=10, m=0, noise=0.0, offset=0.0, angle=None):
    q, t = _pose(rng, angle)
    p0 = rng.normal(size=(n, 3)) * 2 + offset
    p1 = dp.quat_rotate(q, p0) + t + noise * rng.normal(size=(n, 3))
    n0 = rng.normal(size=(m, 3))
    n0 /= np.linalg.norm(n0, axis=1, keepdims=True)
    n1 = dp.quat_rotate(q, n0) + noise * rng.normal(size=(m, 3))
    n1 /= np.linalg.norm(n1, axis=1, keepdims=True)
    return q, t, p0, p1, n0, n1


def _cost(q, t, p0, p1, beta, n0=None, n1=None, alpha=None, s=1.0):
    r = s * dp.quat_rotate(q, p0) + t - p1
    e = float(np.sum(beta * np.sum(r * r, axis=1)))
    if n0 is not None and len(n0):
        d = dp.quat_rotate(q, n0) - n1
        e += float(np.sum(alpha * np.sum(d * d, axis=1)))
    return e


def _same_rotation(q1, q2):
    return float(min(np.abs(q1 - q2).max(), np.abs(q1 + q2).max()))


# --------------------------------------------------------------------------------------------------------------
# the three methods agree, and find the documented optimum


@pytest.mark.parametrize(
    "kind",
    ["points", "weighted", "mixed", "noisy-mixed", "half-turn", "coplanar", "few-points-directions", "two-points-dir"],
)
def test_three_methods_agree(rng, kind):
    for _ in range(20):
        if kind == "points":
            _, _, p0, p1, n0, n1 = _problem(rng, n=int(rng.integers(3, 30)), noise=0.1)
            kw = {}
        elif kind == "weighted":
            _, _, p0, p1, n0, n1 = _problem(rng, n=12, noise=0.3)
            kw = {"point_weights": rng.uniform(0.1, 5.0, 12)}
        elif kind == "mixed":
            _, _, p0, p1, n0, n1 = _problem(rng, n=5, m=4, noise=0.05)
            kw = {"model_directions": n0, "measured_directions": n1, "direction_weights": rng.uniform(0.5, 9.0, 4)}
        elif kind == "noisy-mixed":
            _, _, p0, p1, n0, n1 = _problem(rng, n=4, m=6, noise=0.5)
            kw = {"model_directions": n0, "measured_directions": n1, "point_weights": rng.uniform(0.1, 2.0, 4)}
        elif kind == "half-turn":
            _, _, p0, p1, n0, n1 = _problem(rng, n=8, noise=0.01, angle=np.pi - 1e-3)
            kw = {}
        elif kind == "coplanar":
            q, t = _pose(rng)
            p0 = np.c_[rng.normal(size=(7, 2)), np.zeros(7)]
            p1 = dp.quat_rotate(q, p0) + t + 0.05 * rng.normal(size=(7, 3))
            kw = {}
        elif kind == "few-points-directions":
            _, _, p0, p1, n0, n1 = _problem(rng, n=1, m=2, noise=0.02)
            kw = {"model_directions": n0, "measured_directions": n1}
        else:
            _, _, p0, p1, n0, n1 = _problem(rng, n=2, m=1, noise=0.02)
            kw = {"model_directions": n0, "measured_directions": n1}
        ests = [register_pose(p0, p1, method=m, **kw) for m in METHODS]
        for e in ests[1:]:
            assert np.abs(e.quat - ests[0].quat).max() <= 1e-10
            assert np.abs(e.translation - ests[0].translation).max() <= 1e-10
            assert e.cost == pytest.approx(ests[0].cost, rel=1e-9, abs=1e-12)
        assert ests[0].rotation_unique


def test_optimum_of_documented_cost_with_mixed_weights(rng):
    # An independent minimiser (scipy least_squares over [rotvec, t]) of E = Σβ|Rp+t-p̃|² + Σα|Rn-ñ|² started
    # near the answer does not improve it: this checks Walker's 4x point-weight fix (without it directions
    # would count four times as much as the documented cost says).
    _, _, p0, p1, n0, n1 = _problem(rng, n=4, m=3, noise=0.4)
    beta, alpha = rng.uniform(0.2, 3.0, 4), rng.uniform(0.2, 3.0, 3)
    est = register_pose(
        p0, p1, model_directions=n0, measured_directions=n1, point_weights=beta, direction_weights=alpha
    )

    def resid(x):
        q = dp.quat_from_rotvec(x[:3])
        rp = (dp.quat_rotate(q, p0) + x[3:] - p1) * np.sqrt(beta)[:, None]
        rn = (dp.quat_rotate(q, n0) - n1) * np.sqrt(alpha)[:, None]
        return np.r_[rp.ravel(), rn.ravel()]

    x0 = np.r_[dp.rotvec_from_quat(est.quat) + 0.05, est.translation - 0.1]
    sol = least_squares(resid, x0, xtol=1e-15, ftol=1e-15, gtol=1e-15)
    assert 2 * sol.cost == pytest.approx(est.cost, rel=1e-9)
    assert _same_rotation(dp.quat_from_rotvec(sol.x[:3]), est.quat) <= 1e-7
    assert np.abs(sol.x[3:] - est.translation).max() <= 1e-7
    assert est.cost == pytest.approx(_cost(est.quat, est.translation, p0, p1, beta, n0, n1, alpha), rel=1e-12)


def test_dq_is_walkers_algorithm_written_out(rng):
    """A direct transcription of Walker §3.2 (eqs. (35)-(47)) with dp.quat_left_matrix (Q) / quat_right_matrix (W),
    points weighted 4β, uncentred, agrees with method='dq' near the origin; at a 1e6 offset it does not (and
    register_pose stays exact)."""

    def walker(p0, p1, n0, n1, beta, alpha):
        quat = lambda v, s: np.c_[s * v, np.zeros(len(v))]  # noqa: E731
        P0, P1, N0, N1 = quat(p0, 0.5), quat(p1, 0.5), quat(n0, 1.0), quat(n1, 1.0)
        Q, W = dp.quat_left_matrix, dp.quat_right_matrix
        bw = 4 * beta
        c1 = -2 * np.einsum("k,kji,kjl->il", alpha, Q(N1), W(N0)) - 2 * np.einsum("k,kji,kjl->il", bw, Q(P1), W(P0))
        c2 = bw.sum() * np.eye(4)
        c3 = 2 * np.einsum("k,kij->ij", bw, W(P0) - Q(P1))
        a = 0.5 * (c3.T @ np.linalg.inv(c2 + c2.T) @ c3 - c1 - c1.T)
        r = np.linalg.eigh(a)[1][:, -1]
        s = -np.linalg.inv(c2 + c2.T) @ c3 @ r
        t = 2 * (W(r).T @ s)[:3]
        return dp.quat_canonical(r), t

    q, t, p0, p1, n0, n1 = _problem(rng, n=6, m=3, noise=0.2)
    beta, alpha = rng.uniform(0.5, 2, 6), rng.uniform(0.5, 2, 3)
    est = register_pose(
        p0, p1, model_directions=n0, measured_directions=n1, point_weights=beta, direction_weights=alpha
    )
    rw, tw = walker(p0, p1, n0, n1, beta, alpha)
    assert np.abs(rw - est.quat).max() <= 1e-10
    assert np.abs(tw - est.translation).max() <= 1e-10

    # the same kind of noise-free problem (spread ~10) at a 1e6 offset: uncentred, Walker's A is dominated by the
    # offset and the rotation loses ~6 digits (translation off by units); centred, register_pose is exact to the
    # rounding of the data (see test_exact_at_large_offsets for the bounds)
    q, t, p0, _, _, _ = _problem(rng, n=10)
    p0 = p0 * 5.0 + 1e6
    p1 = dp.quat_rotate(q, p0) + t
    rw, tw = walker(p0, p1, n0[:0], n1[:0], np.ones(10), np.ones(0))
    est = register_pose(p0, p1)
    assert dp.quat_angle(rw, q) > 1e-7 and np.abs(tw - t).max() > 0.1
    assert dp.quat_angle(est.quat, q) <= 1e-10 and np.abs(est.translation - t).max() <= 1e-3


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("offset", [1e3, 1e5, 1e6])
def test_exact_at_large_offsets(rng, method, offset):
    # noise-free data of spread ~10 at a distance `offset` from the origin: exact to the rounding of the data
    # themselves (ulp(offset) in every coordinate) -- rotation ~ ulp/spread, the model centroid's image ~ ulp
    q, t, p0, _, _, _ = _problem(rng, n=10)
    p0 = p0 * 5.0 + offset
    p1 = dp.quat_rotate(q, p0) + t
    ulp = np.spacing(offset)
    est = register_pose(p0, p1, method=method)
    c0 = p0.mean(0)
    assert _same_rotation(est.quat, q) <= 20 * ulp / 10.0
    assert np.abs(dp.quat_rotate(est.quat, c0) + est.translation - (dp.quat_rotate(q, c0) + t)).max() <= 20 * ulp
    assert np.abs(est.translation - t).max() <= 20 * ulp / 10.0 * 2 * offset
    assert est.rmsd <= 5 * ulp


@settings(max_examples=60)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(3, 25),
    method=st.sampled_from(METHODS),
)
def test_exact_recovery_and_inverse_law(seed, n, method):
    rng = np.random.default_rng(seed)
    q, t, p0, p1, _, _ = _problem(rng, n=n)
    est = register_pose(p0, p1, method=method)
    assert _same_rotation(est.quat, q) <= 1e-12
    assert np.abs(est.translation - t).max() <= 1e-11
    inv = register_pose(p1, p0, method=method)  # measured -> model is the inverse transform
    qi, ti = dp.qt_conj(q, t)
    assert _same_rotation(inv.quat, qi) <= 1e-12
    assert np.abs(inv.translation - ti).max() <= 1e-11
    dq = dp.dualquat_mul(est.dualquat, inv.dualquat)
    assert min(np.abs(dq - dp.dualquat_identity()).max(), np.abs(dq + dp.dualquat_identity()).max()) <= 1e-11


# --------------------------------------------------------------------------------------------------------------
# scipy Rotation.align_vectors as the independent reference


@pytest.mark.parametrize("method", METHODS)
def test_matches_scipy_align_vectors(rng, method):
    for _ in range(10):
        _, _, p0, p1, n0, n1 = _problem(rng, n=6, m=3, noise=0.3)
        beta, alpha = rng.uniform(0.1, 3, 6), rng.uniform(0.1, 3, 3)
        # points only: centred, weighted
        est = register_pose(p0, p1, point_weights=beta, method=method)
        c0, c1 = beta @ p0 / beta.sum(), beta @ p1 / beta.sum()
        ref, _ = Rotation.align_vectors(p1 - c1, p0 - c0, weights=beta)
        assert _same_rotation(est.quat, ref.as_quat()) <= 1e-10
        assert np.abs(est.translation - (c1 - ref.apply(c0))).max() <= 1e-10
        # points and directions: the same cost is align_vectors on the stacked vectors
        est = register_pose(
            p0, p1, model_directions=n0, measured_directions=n1, point_weights=beta, direction_weights=alpha,
            method=method,
        )  # fmt: skip
        ref, _ = Rotation.align_vectors(np.r_[p1 - c1, n1], np.r_[p0 - c0, n0], weights=np.r_[beta, alpha])
        assert _same_rotation(est.quat, ref.as_quat()) <= 1e-10
        # directions only (Wahba)
        est = register_pose(None, None, model_directions=n0, measured_directions=n1, direction_weights=alpha)
        ref, _ = Rotation.align_vectors(n1, n0, weights=alpha)
        assert _same_rotation(est.quat, ref.as_quat()) <= 1e-10
        assert not est.translation_observable and est.degeneracy == "directions-only"
        assert np.all(est.translation == 0.0)


# --------------------------------------------------------------------------------------------------------------
# similarity (Umeyama)


@pytest.mark.parametrize("method", METHODS)
def test_scale_umeyama(rng, method):
    q, t, p0, _, _, _ = _problem(rng, n=9, offset=50.0)
    p1 = 2.5 * dp.quat_rotate(q, p0) + t
    est = register_pose(p0, p1, scale=True, method=method)
    assert est.scale == pytest.approx(2.5, rel=1e-13)
    assert _same_rotation(est.quat, q) <= 1e-12
    assert np.abs(est.translation - t).max() <= 1e-10
    assert np.abs(est.as_matrix()[:3, :3] - 2.5 * dp.matrix_from_quat(q)).max() <= 1e-12
    # noisy: independent least-squares over (rotvec, t, log s) finds the same optimum
    p1n = p1 + 0.3 * rng.normal(size=p1.shape)
    est = register_pose(p0, p1n, scale=True, method=method)

    def resid(x):
        return (np.exp(x[6]) * dp.quat_rotate(dp.quat_from_rotvec(x[:3]), p0) + x[3:6] - p1n).ravel()

    sol = least_squares(resid, np.r_[dp.rotvec_from_quat(est.quat) + 0.01, est.translation, np.log(est.scale) + 0.01],
                        xtol=1e-15, ftol=1e-15, gtol=1e-15)  # fmt: skip
    assert 2 * sol.cost == pytest.approx(est.cost, rel=1e-9)
    assert np.exp(sol.x[6]) == pytest.approx(est.scale, rel=1e-8)
    # Umeyama's scale is not symmetric: fitting measured -> model gives 1/s only without noise
    assert register_pose(p1, p0, scale=True).scale == pytest.approx(1 / 2.5, rel=1e-12)


# --------------------------------------------------------------------------------------------------------------
# degenerate data (Eggert, Lorusso & Fisher 1997): a correct answer where one exists, a report where not; no NaN


def _finite(est):
    fields = (est.quat, est.translation, est.eigenvalues, est.dualquat, est.point_residuals)
    return all(np.isfinite(f).all() for f in fields) and np.isfinite([est.cost, est.rmsd, est.eigen_gap]).all()


@pytest.mark.parametrize("method", METHODS)
def test_coplanar_points_unique_with_reflection_guard(rng, method):
    q, t = _pose(rng)
    p0 = np.c_[rng.normal(size=(6, 2)) * 3, np.zeros(6)] + [0, 0, 4.0]
    p1 = dp.quat_rotate(q, p0) + t
    est = register_pose(p0, p1, method=method)
    assert est.degeneracy == "coplanar" and est.rotation_unique
    assert _same_rotation(est.quat, q) <= 1e-12
    assert np.abs(est.translation - t).max() <= 1e-11
    assert np.linalg.det(est.rotation_matrix) == pytest.approx(1.0)
    if method == "svd":
        # noise-free coplanar data have a zero singular value; with the third axis flipped in the measured
        # cross-covariance the unguarded Kabsch answer is a reflection: the guard must fire and fix it
        assert est.singular_values[2] <= 1e-12 * est.singular_values[0]


def test_reflection_guard_fires(rng):
    # measured = a reflected copy of the model: the best *rotation* is not the reflection; svd must say d = -1
    p0 = rng.normal(size=(8, 3)) * np.array([3.0, 2.0, 1.0])
    p1 = p0 * np.array([1.0, 1.0, -1.0])
    ests = [register_pose(p0, p1, method=m) for m in METHODS]
    assert ests[2].reflection_sign == -1.0
    assert np.linalg.det(ests[2].rotation_matrix) == pytest.approx(1.0)
    for e in ests[1:]:
        assert np.abs(e.quat - ests[0].quat).max() <= 1e-10


@pytest.mark.parametrize("method", METHODS)
def test_collinear_points(rng, method):
    q, t = _pose(rng)
    u = dp.quat_normalize(rng.normal(size=4))[:3]
    p0 = np.outer(rng.normal(size=6), u) + [1.0, -2.0, 0.5]
    p1 = dp.quat_rotate(q, p0) + t
    est = register_pose(p0, p1, method=method)
    assert est.degeneracy == "collinear" and not est.rotation_unique
    assert _finite(est)
    assert est.rmsd <= 1e-12  # an exact fit exists and is returned: the line maps onto the measured line
    # the tie-break returns the smallest of the optimal rotations; the true one is not smaller
    assert dp.quat_angle(est.quat, dp.quat_identity()) <= dp.quat_angle(q, dp.quat_identity()) + 1e-12
    with pytest.raises(ValueError, match="unobservable"):
        est.covariance(0.1)
    same = [register_pose(p0, p1, method=m) for m in METHODS]
    for e in same:
        assert np.abs(e.quat - est.quat).max() <= 1e-9


@pytest.mark.parametrize("method", METHODS)
def test_single_point_and_duplicates(rng, method):
    q, t = _pose(rng)
    p0 = np.repeat(rng.normal(size=(1, 3)) * 1e3, 4, axis=0)
    p1 = dp.quat_rotate(q, p0) + t
    est = register_pose(p0, p1, method=method)
    assert est.degeneracy == "single-point" and not est.rotation_unique and _finite(est)
    assert np.abs(est.quat - [0, 0, 0, 1]).max() == 0.0  # no rotation information: the smallest, the identity
    assert np.abs(est.translation - (p1[0] - p0[0])).max() <= 1e-12 * 1e3
    # duplicates of two distinct points: collinear
    two = np.r_[np.repeat(p0[:1], 3, axis=0), np.repeat(p0[:1] + [1.0, 2.0, 3.0], 2, axis=0)]
    e2 = register_pose(two, dp.quat_rotate(q, two) + t, method=method)
    assert e2.degeneracy == "collinear" and _finite(e2) and e2.rmsd <= 1e-9
    # duplicates among non-degenerate points change nothing
    base = rng.normal(size=(4, 3))
    dup = np.r_[base, base[:2], base[:1]]
    e3 = register_pose(dup, dp.quat_rotate(q, dup) + t, method=method)
    assert e3.degeneracy == "none" and _same_rotation(e3.quat, q) <= 1e-12


def test_parallel_directions_and_point_on_axis(rng):
    q, _ = _pose(rng)
    n0 = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [0.0, 0.0, -1.0]])
    n1 = dp.quat_rotate(q, n0 / np.linalg.norm(n0, axis=1, keepdims=True))
    for m in METHODS:
        est = register_pose(None, None, model_directions=n0, measured_directions=n1, method=m)
        assert est.degeneracy == "parallel-directions" and _finite(est)
    # two points along the same line as a direction: rotation about that line is free
    p0 = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 5.0]])
    est = register_pose(p0, dp.quat_rotate(q, p0), model_directions=n0[:1], measured_directions=n1[:1])
    assert est.degeneracy == "collinear" and _finite(est) and est.cost <= 1e-20


# --------------------------------------------------------------------------------------------------------------
# bad input


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"model_points": np.zeros((2, 3)), "measured_points": np.zeros((2, 3))}, "not enough correspondences"),
        (
            {"model_points": np.zeros((1, 3)), "measured_points": np.zeros((1, 3)),
             "model_directions": [[1, 0, 0]], "measured_directions": [[1, 0, 0]]},
            "not enough correspondences",
        ),
        ({"model_points": None, "measured_points": None}, "give model_points"),
        ({"model_points": np.zeros((4, 3)), "measured_points": np.zeros((5, 3))}, "same shape"),
        ({"model_points": np.zeros((4, 2)), "measured_points": np.zeros((4, 2))}, r"model_points must have shape"),
        ({"model_points": np.zeros((4, 3)), "measured_points": None}, "together"),
        ({"model_points": np.zeros((4, 3)), "measured_points": np.zeros((4, 3)), "point_weights": [1, 1, -1, 1]},
         "non-negative"),
        ({"model_points": np.zeros((4, 3)), "measured_points": np.zeros((4, 3)), "point_weights": [1, 1, 1]},
         r"point_weights must have shape \(4,\)"),
        ({"model_points": np.ones((4, 3)), "measured_points": np.ones((4, 3)), "point_weights": [1, 1, 0, 0]},
         "not enough correspondences"),
        ({"model_points": np.zeros((4, 3)), "measured_points": np.zeros((4, 3)), "method": "quest"}, "method must"),
        ({"model_points": np.zeros((4, 3)), "measured_points": np.zeros((4, 3)), "scale": True,
          "model_directions": [[1, 0, 0]], "measured_directions": [[1, 0, 0]]}, "points only"),
        ({"model_points": None, "measured_points": None, "model_directions": [[1, 0, 0], [0, 0, 0]],
          "measured_directions": [[1, 0, 0], [0, 1, 0]]}, r"model_directions must be nonzero.*entry \(1,\)"),
        ({"model_points": [[0, 0, 0], [1, 0, 0], [0, 1, np.nan]], "measured_points": np.zeros((3, 3))},
         "model_points contains NaN"),
        ({"model_points": np.zeros((3, 3)), "measured_points": [[0, 0, 0], [1, 0, 0], [0, np.inf, 1]]},
         "measured_points contains NaN"),
    ],
)  # fmt: skip
def test_bad_input(kwargs, match):
    args = (kwargs.pop("model_points"), kwargs.pop("measured_points"))
    with pytest.raises(ValueError, match=match):
        register_pose(*args, **kwargs)


def test_non_numeric_input():
    with pytest.raises(TypeError, match="model_points"):
        register_pose([["a", "b", "c"]] * 3, np.zeros((3, 3)))


# --------------------------------------------------------------------------------------------------------------
# result object


def test_result_fields_are_consistent(rng):
    q, t, p0, p1, n0, n1 = _problem(rng, n=7, m=2, noise=0.2)
    beta = rng.uniform(0.5, 2, 7)
    est = register_pose(p0, p1, model_directions=n0, measured_directions=n1, point_weights=beta)
    r = est.rotation_matrix
    assert np.abs(est.point_residuals - (p0 @ r.T + est.translation - p1)).max() <= 1e-12
    assert np.abs(est.direction_residuals - (n0 @ r.T - n1)).max() <= 1e-12
    pr = est.point_residuals
    assert est.rmsd == pytest.approx(np.sqrt(np.sum(beta * np.sum(pr**2, 1)) / beta.sum()), rel=1e-12)
    qd, td = dp.qt_from_dualquat(est.dualquat)
    assert np.abs(qd - est.quat).max() <= 1e-15 and np.abs(td - est.translation).max() <= 1e-13
    assert np.abs(est.as_matrix() - dp.matrix_from_dualquat(est.dualquat)).max() <= 1e-14
    assert est.eigenvalues[0] - est.eigenvalues[1] == pytest.approx(est.eigen_gap)
    assert est.eigen_gap > est.gap_tolerance
    assert "PoseEstimate(method='dq'" in repr(est)
    # Walker eq. (50): E = constant - λ1 (with the documented weighting)
    const = 2 * 2 + np.sum(beta * (np.sum((p0 - beta @ p0 / beta.sum()) ** 2, 1)
                                   + np.sum((p1 - beta @ p1 / beta.sum()) ** 2, 1)))  # fmt: skip
    assert est.cost == pytest.approx(const - est.eigenvalues[0], rel=1e-9)
    svd = register_pose(p0, p1, model_directions=n0, measured_directions=n1, point_weights=beta, method="svd")
    # Horn's eigenvalues are sums of the singular values: λ1 = σ1 + σ2 + d σ3
    s, d = svd.singular_values, svd.reflection_sign
    assert svd.eigenvalues[0] == pytest.approx(s[0] + s[1] + d * s[2], rel=1e-12)
    assert est.singular_values is None and est.reflection_sign is None


# --------------------------------------------------------------------------------------------------------------
# covariance, validated by Monte Carlo


@pytest.mark.parametrize("with_directions", [False, True])
def test_covariance_monte_carlo(with_directions):
    rng = np.random.default_rng(11)
    q, t = _pose(rng)
    p0 = rng.normal(size=(6, 3)) * np.array([4.0, 2.0, 1.0]) + [10.0, -5.0, 3.0]  # off-centre: δθ/δt correlate
    sp, sd = 0.05, 0.02
    beta = rng.uniform(0.5, 2.0, 6)  # not inverse variances: the sandwich form is needed
    kw: dict = {"point_weights": beta}
    n0 = np.eye(3)[:2]
    if with_directions:
        kw.update(model_directions=n0, direction_weights=np.array([40.0, 5.0]))
    p1_true = dp.quat_rotate(q, p0) + t
    n1_true = dp.quat_rotate(q, n0)
    ref = register_pose(p0, p1_true, measured_directions=n1_true if with_directions else None, **kw)
    cov = ref.covariance(sp, sd)
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0)
    trials = 3000
    errs = np.empty((trials, 6))
    for i in range(trials):
        p1 = p1_true + sp * rng.normal(size=p1_true.shape)
        n1 = n1_true + sd * rng.normal(size=n1_true.shape) if with_directions else None
        est = register_pose(p0, p1, measured_directions=n1, **kw)
        errs[i, :3] = dp.rotvec_from_quat(dp.quat_mul(q, dp.quat_conj(est.quat)))  # R_true = exp(δθ×) R̂
        errs[i, 3:] = t - est.translation
    std_mc = errs.std(axis=0)
    std_pred = np.sqrt(np.diag(cov))
    assert np.all(np.abs(std_mc / std_pred - 1) <= 0.10), (std_mc, std_pred)
    # the correlations too (off-centre points couple δt to δθ)
    corr_mc = np.corrcoef(errs.T)
    corr_pred = cov / np.outer(std_pred, std_pred)
    assert np.abs(corr_mc - corr_pred).max() <= 0.1


def test_covariance_unit_weights_matches_closed_form(rng):
    q, t, p0, p1, _, _ = _problem(rng, n=8)
    est = register_pose(p0, p1)
    qc = dp.quat_rotate(q, p0 - p0.mean(0))
    info = np.sum([np.dot(v, v) * np.eye(3) - np.outer(v, v) for v in qc], axis=0)
    cov = est.covariance(0.3)
    assert np.abs(cov[:3, :3] - 0.09 * np.linalg.inv(info)).max() <= 1e-14
    with pytest.raises(ValueError, match="scale"):
        register_pose(p0, p1, scale=True).covariance(0.1)
    with pytest.raises(ValueError, match="non-negative"):
        est.covariance(-1.0)
