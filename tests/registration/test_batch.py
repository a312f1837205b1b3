"""register_pose_batch: the same answers as register_pose, problem by problem, for every method and input kind."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dualpose as dp
from dualpose.registration import register_pose, register_pose_batch


def _batch(rng, b=40, n=6, m=0, noise=0.1):
    q = dp.quat_normalize(rng.normal(size=(b, 4)))
    t = rng.normal(size=(b, 3)) * 4
    p0 = rng.normal(size=(b, n, 3)) * 2
    p1 = dp.quat_rotate(q[:, None], p0) + t[:, None] + noise * rng.normal(size=(b, n, 3))
    n0 = rng.normal(size=(b, m, 3))
    n1 = dp.quat_rotate(q[:, None], n0) + noise * rng.normal(size=(b, m, 3))
    return q, t, p0, p1, n0, n1


@pytest.mark.parametrize("method", ["dq", "horn", "svd"])
def test_batch_equals_single(rng, method):
    _, _, p0, p1, n0, n1 = _batch(rng, m=3)
    w = rng.uniform(0.2, 3, p0.shape[:2])
    a = rng.uniform(0.2, 3, n0.shape[:2])
    kw = {"model_directions": n0, "measured_directions": n1, "direction_weights": a, "method": method}
    res = register_pose_batch(p0, p1, w, **kw)
    assert len(res) == 40 and res.quat.shape == (40, 4) and res.translation.shape == (40, 3)
    for i in range(40):
        one = register_pose(p0[i], p1[i], model_directions=n0[i], measured_directions=n1[i], point_weights=w[i],
                            direction_weights=a[i], method=method)  # fmt: skip
        assert np.abs(res.quat[i] - one.quat).max() <= 1e-15
        assert np.abs(res.translation[i] - one.translation).max() <= 1e-14
        assert res.cost[i] == one.cost and res.rmsd[i] == pytest.approx(one.rmsd, rel=1e-12)
        assert res[i].degeneracy == one.degeneracy
    assert np.abs(res.dualquat - dp.dualquat_from_qt(res.quat, res.translation)).max() == 0
    assert res.rotation_matrix.shape == (40, 3, 3) and res.rotation_unique.all()
    assert res[-1].quat.tolist() == res.quat[-1].tolist()


def test_batch_matches_scipy_loop(rng):
    _, _, p0, p1, _, _ = _batch(rng, b=200, n=10)
    res = register_pose_batch(p0, p1)
    for i in range(0, 200, 7):
        c0, c1 = p0[i].mean(0), p1[i].mean(0)
        rot, _ = Rotation.align_vectors(p1[i] - c1, p0[i] - c0)
        ref = rot.as_quat()
        assert min(np.abs(res.quat[i] - ref).max(), np.abs(res.quat[i] + ref).max()) <= 1e-12
        assert np.abs(res.translation[i] - (c1 - rot.apply(c0))).max() <= 1e-12


def test_batch_scale_directions_only_and_degenerate_members(rng):
    q, t, p0, _, _, _ = _batch(rng, b=5, n=5)
    p1 = 1.7 * dp.quat_rotate(q[:, None], p0) + t[:, None]
    res = register_pose_batch(p0, p1, scale=True)
    assert np.allclose(res.scale, 1.7, rtol=1e-13, atol=0)
    # directions only
    _, _, _, _, n0, n1 = _batch(rng, b=5, n=0, m=3, noise=0.0)
    res = register_pose_batch(None, None, model_directions=n0, measured_directions=n1)
    assert np.all(res.translation == 0) and res[2].degeneracy == "directions-only"
    # one collinear member among good ones: flagged, finite, the others unaffected
    _, _, p0, p1, _, _ = _batch(rng, b=4, n=5, noise=0.0)
    p0[1] = np.outer(np.arange(5.0), [1.0, 2.0, 3.0])
    p1[1] = p0[1] + 1.0
    res = register_pose_batch(p0, p1)
    assert res.rotation_unique.tolist() == [True, False, True, True]
    assert np.isfinite(res.quat).all() and res[1].degeneracy == "collinear"
    assert np.abs(res.quat[1] - [0, 0, 0, 1]).max() <= 1e-12  # the smallest optimal rotation: none


def test_batch_padding_with_zero_weights(rng):
    _, _, p0, p1, _, _ = _batch(rng, b=3, n=8)
    w = np.ones((3, 8))
    w[0, 5:] = 0.0
    p1[0, 5:] = 1e9  # garbage in padded slots must not matter
    res = register_pose_batch(p0, p1, w)
    one = register_pose(p0[0, :5], p1[0, :5])
    assert np.abs(res.quat[0] - one.quat).max() <= 1e-14


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((np.zeros((2, 4, 3)), np.zeros((2, 5, 3))), {}, "same shape"),
        ((np.zeros((4, 3)), np.zeros((4, 3))), {}, r"shape \(B, n, 3\)"),
        ((np.zeros((2, 2, 3)), np.zeros((2, 2, 3))), {}, "not enough correspondences"),
        ((np.zeros((2, 4, 3)), np.zeros((2, 4, 3)), np.ones((2, 3))), {}, r"point_weights must have shape \(2, 4\)"),
        ((np.zeros((2, 4, 3)), np.zeros((2, 4, 3)), [[1, 1, 1, 1], [1, 1, 0, 0]]), {}, "problem 1: not enough"),
        ((np.zeros((2, 4, 3)), np.zeros((2, 4, 3))), {"method": "x"}, "method must"),
    ],
)
def test_batch_bad_input(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        register_pose_batch(*args, **kwargs)


def test_batch_nan_names_problem():
    p = np.random.default_rng(0).normal(size=(3, 4, 3))
    q = p.copy()
    q[2, 1, 0] = np.nan
    with pytest.raises(ValueError, match="problem 2: measured_points contains NaN"):
        register_pose_batch(p, q)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("which", ["model_points", "measured_points"])
def test_batch_non_finite_point_found_past_first_block(value, which):
    """The kernel finds a non-finite input from its sums (0·inf and inf - inf are NaN), also where the point has
    zero weight, in a later block of problems, and names the problem and the input."""
    rng = np.random.default_rng(7)
    p = rng.normal(size=(100, 5, 3))
    q = p + 1.0
    w = np.ones((100, 5))
    w[77, 3] = 0.0
    (p if which == "model_points" else q)[77, 3, 1] = value
    with pytest.raises(ValueError, match=f"problem 77: {which} contains NaN or infinity"):
        register_pose_batch(p, q, w)


def test_batch_overflowing_moments_raise_instead_of_nan():
    """Finite inputs whose moments overflow are not called non-finite, and give an error instead of a NaN pose."""
    p = np.random.default_rng(8).normal(size=(3, 5, 3))
    p[1] = np.sign(p[1]) * 1.5e308  # the centroid sums overflow (spreads of 1e200 are normalised internally)
    with pytest.raises(ValueError, match="problem 1: the weighted second moments overflow"):
        register_pose_batch(p, p + 1.0)
    with pytest.raises(ValueError, match="^the weighted second moments overflow"):
        register_pose(p[1], p[1] + 1.0)
    res = register_pose_batch(p[[0, 2]] * 1e100, p[[0, 2]] * 1e100 + 1.0)  # large but representable moments
    assert np.allclose(res.quat, [0, 0, 0, 1], atol=1e-12)


@pytest.mark.parametrize("kind", ["random", "thin", "near-line", "half-turn", "noisy", "tiny", "huge"])
def test_closed_form_eigen_solve_against_lapack(kind):
    """The batch kernel's closed-form eigen-solve (with its Jacobi fallback) against numpy's LAPACK eigh of Horn's N
    on stressed inputs: error x relative eigen-gap stays at rounding level (eigenvector error ~ eps / gap)."""
    rng = np.random.default_rng(["random", "thin", "near-line", "half-turn", "noisy", "tiny", "huge"].index(kind))
    b = 2000
    p0 = rng.normal(size=(b, 6, 3)) * {"tiny": 1e-8, "huge": 1e8}.get(kind, 1.0)
    if kind == "thin":
        p0[:, :, 2] *= 1e-4
    if kind == "near-line":
        p0[:, :, 1:] *= 1e-5
    q = dp.quat_normalize(rng.normal(size=(b, 4)))
    if kind == "half-turn":
        q = dp.quat_from_axis_angle(rng.normal(size=(b, 3)), np.pi - rng.uniform(0, 1e-6, b))
    noise = (1.0 if kind == "noisy" else 1e-3) * np.abs(p0).max()
    p1 = dp.quat_rotate(q[:, None], p0) + noise * rng.normal(size=p0.shape)
    c0, c1 = p0.mean(1, keepdims=True), p1.mean(1, keepdims=True)
    h = np.einsum("bni,bnj->bij", p0 - c0, p1 - c1)
    tr = np.trace(h, axis1=1, axis2=2)
    n = np.zeros((b, 4, 4))
    n[:, :3, :3] = h + h.transpose(0, 2, 1) - tr[:, None, None] * np.eye(3)
    d = np.stack([h[:, 1, 2] - h[:, 2, 1], h[:, 2, 0] - h[:, 0, 2], h[:, 0, 1] - h[:, 1, 0]], 1)
    n[:, :3, 3], n[:, 3, :3], n[:, 3, 3] = d, d, tr
    w, v = np.linalg.eigh(n)
    ref = v[:, :, -1]
    rel_gap = (w[:, -1] - w[:, -2]) / np.abs(w).max(axis=1)
    for method in ("dq", "horn"):
        res = register_pose_batch(p0, p1, method=method)
        err = np.minimum(np.abs(res.quat - ref).max(1), np.abs(res.quat + ref).max(1))
        assert np.isfinite(res.quat).all()
        unique = res.rotation_unique
        assert (err * rel_gap)[unique].max() <= 1e-12
        # problems reported as not unique have a gap at the tolerance (1e-9 of the spectrum's scale): there the
        # smallest optimal rotation is returned, not LAPACK's arbitrary vector
        assert np.all(rel_gap[~unique] <= 4e-9)
    # all four eigenvalues of N (Newton for the largest two, the deflated quadratic for the rest) against LAPACK
    ev = np.array([res[i].eigenvalues for i in range(0, b, 7)])
    scale = np.abs(w[::7]).max(axis=1, keepdims=True)
    assert (np.abs(ev - w[::7, ::-1]) / scale).max() <= 1e-12
