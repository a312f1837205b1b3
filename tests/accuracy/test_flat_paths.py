"""The flat row-loop paths (C-contiguous batches of >= 64 elements) against mpmath and against the gufunc path.

``quat_rotate``, ``quat_log``, ``dualquat_transform`` and ``dualquat_mul`` switch to vectorised loops over flat
buffers for C-contiguous input without broadcasting (``dualpose.algebra._flat_kernels``; the transform and the
product through the explicit 8-row SIMD blocks of ``dualpose.algebra._simd``); everything else -- broadcasting,
strided views, small batches, extreme norms, zeros, outputs overlapping an input -- goes through the gufuncs.  Here
the same data is pushed through both paths (a strided copy forces the gufunc), the flat ``quat_log`` is held to
the 4ε bar of the accuracy suite on every one of its mpmath cases at once, the flat transform is checked against
an extended-precision evaluation of ``R p + t``, and the flat product against exact rational arithmetic.
"""

from __future__ import annotations

from fractions import Fraction

import accuracy_cases as cases
import accuracy_reference as ref
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dualpose as dp
import dualpose.algebra.dualquat as dq_module
from dualpose._validation import FLAT_MIN_ELEMENTS

N = 4 * FLAT_MIN_ELEMENTS


def strided(a: np.ndarray) -> np.ndarray:
    """A non-contiguous view with the values of ``a`` (forces the gufunc path)."""
    buf = np.zeros((*a.shape[:-1], 2 * a.shape[-1]))
    buf[..., ::2] = a
    view = buf[..., ::2]
    assert not view.flags.c_contiguous
    return view


def random_quats(rng: np.random.Generator, n: int) -> np.ndarray:
    """Non-unit quaternions with norms spread over 1e-3 .. 1e3 and some exactly unit-normalized rows."""
    q = rng.normal(size=(n, 4)) * 10.0 ** rng.uniform(-3, 3, size=(n, 1))
    q[::3] /= np.linalg.norm(q[::3], axis=1, keepdims=True)
    return q


def test_quat_log_flat_meets_the_bar_on_every_accuracy_case() -> None:
    """All quat_log cases of the accuracy suite (0, 1e-300 ... π − 1e-8, π) in one batch, each row within 4ε."""
    mine = [c for c in cases.all_cases() if c.func == "quat_log"]
    batch = np.stack([c.args[0] for c in mine])
    reps = max(2, -(-FLAT_MIN_ELEMENTS // len(batch)))
    out = dp.quat_log(np.tile(batch, (reps, 1)))
    for k, c in enumerate(mine):
        err = ref.normwise_error(out[k], c.truth())
        assert err <= ref.BAR, f"{c.cid}: flat quat_log error {err:.3g} ε"
        np.testing.assert_array_equal(out[k + len(mine)], out[k])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_quat_log_flat_matches_gufunc(seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = random_quats(rng, N)
    q[5] = [0.0, 0.0, 0.0, -2.0]  # negative real axis: [π, 0, 0, ln 2]
    q[6] = [1e-200, 0.0, 0.0, 1.0]  # tiny angle: series branch
    q[7] = [1e-200, 2e-200, 0.0, -3e-200]  # extreme norm
    flat, guf = dp.quat_log(q), dp.quat_log(strided(q))
    scale = np.maximum(np.linalg.norm(guf, axis=-1, keepdims=True), 1e-300)
    assert np.max(np.abs(flat - guf) / scale) <= 4 * np.finfo(float).eps
    np.testing.assert_array_equal(flat[5], [np.pi, 0.0, 0.0, np.log(2.0)])


def test_quat_log_flat_zero_raises_and_nan_propagates() -> None:
    q = random_quats(np.random.default_rng(4), N)
    q[9] = np.nan
    assert np.isnan(dp.quat_log(q)[9]).all() and np.isfinite(np.delete(dp.quat_log(q), 9, axis=0)).all()
    q[11] = 0.0
    with pytest.raises(ValueError, match=r"q must be a nonzero quaternion; element \(11,\) is zero"):
        dp.quat_log(q)


@pytest.mark.parametrize("shape", [(N,), (8, N // 8), (FLAT_MIN_ELEMENTS - 1,)])
def test_rotate_and_transform_flat_equal_gufunc_bit_for_bit(shape: tuple[int, ...]) -> None:
    rng = np.random.default_rng(5)
    q = random_quats(rng, int(np.prod(shape))).reshape(*shape, 4)
    v = rng.normal(size=(*shape, 3))
    dq = np.concatenate([q, rng.normal(size=(*shape, 4))], axis=-1)
    np.testing.assert_array_equal(dp.quat_rotate(q, v), dp.quat_rotate(strided(q), v))
    np.testing.assert_array_equal(dp.dualquat_transform(dq, v), dp.dualquat_transform(strided(dq), v))


@pytest.mark.parametrize("norm", [1e-200, 1e200])
def test_extreme_norms_fall_back_to_the_rescaling_gufunc(norm: float) -> None:
    rng = np.random.default_rng(6)
    q, v = random_quats(rng, N), rng.normal(size=(N, 3))
    q[17] = norm * np.array([0.0, 0.0, np.sin(0.5), np.cos(0.5)])  # rotation by 1 rad about z
    r = dp.quat_rotate(q, v)
    c, s = np.cos(1.0), np.sin(1.0)
    expect = [c * v[17, 0] - s * v[17, 1], s * v[17, 0] + c * v[17, 1], v[17, 2]]
    np.testing.assert_allclose(r[17], expect, rtol=0, atol=1e-15 * np.linalg.norm(v[17]))
    np.testing.assert_array_equal(r, dp.quat_rotate(strided(q), v))
    dq = np.concatenate([q, np.zeros((N, 4))], axis=-1)
    np.testing.assert_array_equal(dp.dualquat_transform(dq, v), r)


def test_zero_rotation_raises_on_the_flat_path() -> None:
    rng = np.random.default_rng(7)
    q, v = random_quats(rng, N), rng.normal(size=(N, 3))
    q[3] = 0.0
    with pytest.raises(ValueError, match=r"element \(3,\) is zero"):
        dp.quat_rotate(q, v)
    with pytest.raises(ValueError, match=r"element \(3,\) is zero"):
        dp.dualquat_transform(np.concatenate([q, q], axis=-1), v)


def test_out_argument_on_the_flat_path_including_in_place() -> None:
    rng = np.random.default_rng(8)
    q, v = random_quats(rng, N), rng.normal(size=(N, 3))
    expect = dp.quat_rotate(strided(q), v)
    out = np.empty((N, 3))
    assert dp.quat_rotate(q, v, out=out) is out
    np.testing.assert_array_equal(out, expect)
    dp.quat_rotate(q, v, out=v)  # in place: each row is read before it is written
    np.testing.assert_array_equal(v, expect)
    fortran = np.asfortranarray(np.empty((N, 3)))  # a non-contiguous out takes the gufunc path
    np.testing.assert_array_equal(dp.quat_rotate(q, expect @ np.eye(3), out=fortran), dp.quat_rotate(q, expect))


@settings(max_examples=25, deadline=None)
@given(n=st.integers(FLAT_MIN_ELEMENTS, 3 * FLAT_MIN_ELEMENTS), seed=st.integers(0, 2**32 - 1))
def test_flat_paths_agree_with_gufuncs_for_any_batch_size(n: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q, v = random_quats(rng, n), rng.normal(size=(n, 3))
    dq = np.concatenate([q, rng.normal(size=(n, 4))], axis=-1)
    np.testing.assert_array_equal(dp.quat_rotate(q, v), dp.quat_rotate(strided(q), v))
    np.testing.assert_array_equal(dp.dualquat_transform(dq, v), dp.dualquat_transform(strided(dq), v))
    g = dp.quat_log(strided(q))
    assert np.max(np.abs(dp.quat_log(q) - g) / np.linalg.norm(g, axis=-1, keepdims=True)) <= 4 * np.finfo(float).eps


# --- dualquat_transform: 8-row SIMD blocks plus a scalar tail -------------------------------------------------------


def random_dualquats(rng: np.random.Generator, n: int) -> np.ndarray:
    """Non-unit real parts (see :func:`random_quats`) and dual parts spread over 1e-6 .. 1e6."""
    return np.concatenate([random_quats(rng, n), rng.normal(size=(n, 4)) * 10.0 ** rng.uniform(-6, 6, (n, 1))], -1)


def flat_calls(monkeypatch: pytest.MonkeyPatch, func: str = "dualquat_transform") -> list[int]:
    """Count the calls of the flat kernel ``func`` made by ``dp.<func>`` from now on."""
    calls: list[int] = []
    kernel = dq_module._fk(func)

    def spy(*args: np.ndarray) -> int:
        calls.append(1)
        return kernel(*args)

    get = dq_module._fk
    monkeypatch.setattr(dq_module, "_fk", lambda name: spy if name == func else get(name))
    return calls


def test_transform_flat_matches_mpmath() -> None:
    """Every row within 4ε of R p + t evaluated in mpmath from the same float64 dual quaternion (R of r/|r|,
    t = 2 d (x) r* / |r|², Dantam 2014 eq. (78)), normwise over |R p| + |t| (the scale of the rounding)."""
    rng = np.random.default_rng(9)
    n = 203  # 25 blocks of 8 and a tail of 3
    s, p = random_dualquats(rng, n), rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(-6, 6, (n, 1))
    got = dp.dualquat_transform(s, p)
    worst = 0.0
    with ref.mp.workdps(ref.DPS):
        for k in range(n):
            sk, pk = ref.exact(s[k]), ref.exact(p[k])
            rp = [ref.mp.fsum(m * c for m, c in zip(row, pk, strict=True)) for row in ref.rot_matrix(sk[:4])]
            t = ref.dq_translation(sk)
            err = ref.norm([float(g) - (a + b) for g, a, b in zip(got[k], rp, t, strict=True)])
            worst = max(worst, float(err / (ref.norm(rp) + ref.norm(t)) / ref.EPS))
    assert worst <= ref.BAR, f"worst row {worst:.3g} ε"


@settings(max_examples=20, deadline=None)
@given(n=st.integers(FLAT_MIN_ELEMENTS, 4 * FLAT_MIN_ELEMENTS), seed=st.integers(0, 2**32 - 1),
       bad_row=st.integers(0, 10**6))
def test_transform_flat_bit_for_bit_and_nan_rows_stay_local(n: int, seed: int, bad_row: int) -> None:
    """Any batch size (blocks of 8 plus a 0..7-row tail): equal to the gufunc bit for bit; a NaN anywhere in one
    row (block or tail) makes exactly that output row NaN, on both paths."""
    rng = np.random.default_rng(seed)
    s, p = random_dualquats(rng, n), rng.normal(size=(n, 3))
    np.testing.assert_array_equal(dp.dualquat_transform(s, p), dp.dualquat_transform(strided(s), p))
    row, col = bad_row % n, bad_row % 11
    (s if col < 8 else p)[row, col % 8] = np.nan
    flat, guf = dp.dualquat_transform(s, p), dp.dualquat_transform(strided(s), p)
    np.testing.assert_array_equal(flat, guf)
    assert np.isnan(flat[row]).all() and np.isfinite(np.delete(flat, row, axis=0)).all()


@pytest.mark.parametrize("row", [13, 4 * FLAT_MIN_ELEMENTS + 2])  # in an 8-row block; in the tail
@pytest.mark.parametrize("norm", [1e-200, 1e200, 0.0])
def test_transform_flat_flags_extreme_norms_for_the_gufunc(row: int, norm: float) -> None:
    rng = np.random.default_rng(10)
    n = 4 * FLAT_MIN_ELEMENTS + 5
    s, p = random_dualquats(rng, n), rng.normal(size=(n, 3))
    # 1 rad about z and t = (1, 2, 3), scaled by `norm` (a scaled dual quaternion is the same transform)
    s[row] = norm * dp.dualquat_from_qt([0.0, 0.0, np.sin(0.5), np.cos(0.5)], [1.0, 2.0, 3.0])
    if norm == 0.0:
        s[row, 4:] = 1.0
        with pytest.raises(ValueError, match=rf"element \({row},\) is zero"):
            dp.dualquat_transform(s, p)
        return
    got = dp.dualquat_transform(s, p)
    np.testing.assert_array_equal(got, dp.dualquat_transform(strided(s), p))
    c, si = np.cos(1.0), np.sin(1.0)
    expect = [c * p[row, 0] - si * p[row, 1] + 1.0, si * p[row, 0] + c * p[row, 1] + 2.0, p[row, 2] + 3.0]
    np.testing.assert_allclose(got[row], expect, rtol=0, atol=1e-14)


def check_out_argument(monkeypatch: pytest.MonkeyPatch, func: str, args: tuple[np.ndarray, ...], width: int) -> None:
    """``out=`` of ``dp.<func>`` equals the gufunc result: a fresh array and in place over each input of the output's
    shape on the flat kernel (its 8-row blocks are loaded before they are stored); an ``out`` shifted by one row
    over such an input and a Fortran-ordered ``out`` on the gufunc."""
    f = getattr(dp, func).__wrapped__  # the Python path (the direct native entry in front of it takes a fresh out)
    n = args[0].shape[0]
    expect = f(strided(args[0]), *args[1:])
    fresh = np.empty((n, width))
    assert getattr(dp, func)(*args, out=fresh) is fresh
    np.testing.assert_array_equal(fresh, expect)
    calls = flat_calls(monkeypatch, func)
    out = np.empty((n, width))
    assert f(*args, out=out) is out
    np.testing.assert_array_equal(out, expect)
    same = [k for k, a in enumerate(args) if a.shape == out.shape]
    assert same
    for k in same:
        mine = [a.copy() if j == k else a for j, a in enumerate(args)]
        assert f(*mine, out=mine[k]) is mine[k]
        np.testing.assert_array_equal(mine[k], expect)
    assert len(calls) == 1 + len(same)
    buf = np.zeros((n + 1, width))
    buf[:n] = args[same[0]]
    f(*[buf[:n] if j == same[0] else a for j, a in enumerate(args)], out=buf[1:])
    np.testing.assert_array_equal(buf[1:], expect)
    fortran = np.asfortranarray(np.empty((n, width)))
    f(*args, out=fortran)
    np.testing.assert_array_equal(fortran, expect)
    assert len(calls) == 1 + len(same)


def test_transform_out_in_place_and_overlapping(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(11)
    n = 3 * FLAT_MIN_ELEMENTS + 7
    check_out_argument(monkeypatch, "dualquat_transform", (random_dualquats(rng, n), rng.normal(size=(n, 3))), 3)


def test_transform_broadcasting_and_strided_input_take_the_gufunc(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(12)
    n = 2 * FLAT_MIN_ELEMENTS
    s, p = random_dualquats(rng, n), rng.normal(size=(n, 3))
    calls = flat_calls(monkeypatch)
    f = dp.dualquat_transform.__wrapped__  # the Python path (the direct native entry in front of it declines these)
    one = f(s[5], p)  # one transform, many points
    np.testing.assert_array_equal(one, f(np.tile(s[5], (n, 1)), p))
    assert len(calls) == 1  # only the tiled call
    many = f(s[:, None, :], p[None, :3, :])  # (n, 3, 3) by broadcasting
    np.testing.assert_array_equal(many[:, 1], f(s, np.tile(p[1], (n, 1))))
    assert len(calls) == 2
    f(strided(s), p)
    f(s[: FLAT_MIN_ELEMENTS - 1], p[: FLAT_MIN_ELEMENTS - 1])
    assert len(calls) == 2


# --- dualquat_mul: 8-row SIMD blocks (two inputs) plus a scalar tail -----------------------------------------------


def exact_dualquat_product(a: np.ndarray, b: np.ndarray) -> tuple[list[Fraction], list[Fraction]]:
    """``a (x) b`` in exact rational arithmetic from the float64 rows (Dantam 2014 eq. (79), written out
    independently of the kernels: Hamilton product via scalar and vector parts), and for each component the sum
    of the absolute values of its products (the scale of the rounding error)."""

    def qmul_terms(p: list[Fraction], q: list[Fraction]) -> list[list[Fraction]]:
        (px, py, pz, pw), (qx, qy, qz, qw) = p, q
        # [pw q_v + qw p_v + p_v x q_v, pw qw - p_v . q_v], each component as its four products
        return [
            [pw * qx, qw * px, py * qz, -pz * qy],
            [pw * qy, qw * py, pz * qx, -px * qz],
            [pw * qz, qw * pz, px * qy, -py * qx],
            [pw * qw, -px * qx, -py * qy, -pz * qz],
        ]

    fa, fb = [Fraction(x) for x in a], [Fraction(x) for x in b]
    terms = qmul_terms(fa[:4], fb[:4]) + [
        e + f for e, f in zip(qmul_terms(fa[:4], fb[4:]), qmul_terms(fa[4:], fb[:4]), strict=True)
    ]
    return [sum(t, Fraction(0)) for t in terms], [sum((abs(x) for x in t), Fraction(0)) for t in terms]


def test_dualquat_mul_flat_matches_exact_arithmetic(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every component of 203 products (25 blocks of 8 and a tail of 3, magnitudes over 24 decades) within the
    a priori bound of a float64 sum of products, |error| <= γ_k Σ|products| (Higham 2002, eq. (3.4)), k = 4
    roundings on the way of each real-part product and 5 for the dual part (two 4-term sums, then their sum)."""
    rng = np.random.default_rng(13)
    n = 203
    a, b = random_dualquats(rng, n), random_dualquats(rng, n)
    calls = flat_calls(monkeypatch, "dualquat_mul")
    got = dp.dualquat_mul.__wrapped__(a, b)  # the Python path; the direct native entry runs the same row loop
    assert len(calls) == 1
    np.testing.assert_array_equal(dp.dualquat_mul(a, b), got)
    u = Fraction(1, 2**53)
    gamma = [k * u / (1 - k * u) for k in (4, 4, 4, 4, 5, 5, 5, 5)]
    worst = 0.0
    for r in range(n):
        truth, scale = exact_dualquat_product(a[r], b[r])
        for c in range(8):
            err = abs(Fraction(got[r, c]) - truth[c])
            assert err <= gamma[c] * scale[c], f"row {r} component {c}"
            worst = max(worst, float(err / scale[c] / u)) if scale[c] else worst
    assert worst > 0.0  # the products do round: the bound is exercised, not met trivially


@settings(max_examples=20, deadline=None)
@given(n=st.integers(FLAT_MIN_ELEMENTS, 4 * FLAT_MIN_ELEMENTS), seed=st.integers(0, 2**32 - 1),
       bad=st.integers(0, 10**6))
def test_dualquat_mul_flat_bit_for_bit_and_nan_rows_stay_local(n: int, seed: int, bad: int) -> None:
    """Any batch size (blocks of 8 plus a 0..7-row tail): equal to the gufunc bit for bit; a NaN anywhere in one
    row of ``a`` or ``b`` (block or tail) makes exactly that output row NaN -- every component of the product
    reads all 8 of one input and ``r``, or for the real part 4 and 4 -- on both paths."""
    rng = np.random.default_rng(seed)
    a, b = random_dualquats(rng, n), random_dualquats(rng, n)
    np.testing.assert_array_equal(dp.dualquat_mul(a, b), dp.dualquat_mul(strided(a), b))
    row, col = bad % n, bad % 16
    (a if col < 8 else b)[row, col % 8] = np.nan
    flat, guf = dp.dualquat_mul(a, b), dp.dualquat_mul(a, strided(b))
    np.testing.assert_array_equal(flat, guf)
    reads_nan = np.ones(8, bool) if col % 8 < 4 else np.arange(8) >= 4  # a NaN dual part only reaches the dual part
    assert np.isnan(flat[row]).tolist() == reads_nan.tolist()
    assert np.isfinite(np.delete(flat, row, axis=0)).all()


def test_dualquat_mul_out_in_place_and_overlapping(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(14)
    n = 3 * FLAT_MIN_ELEMENTS + 7
    a, b = random_dualquats(rng, n), random_dualquats(rng, n)
    check_out_argument(monkeypatch, "dualquat_mul", (a, b), 8)  # in place over a, then over b
    sq = a.copy()
    dp.dualquat_mul(sq, sq, out=sq)  # both inputs and the output one array
    np.testing.assert_array_equal(sq, dp.dualquat_mul(strided(a), a))


def test_dualquat_mul_broadcasting_strided_and_small_batches_take_the_gufunc(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(15)
    n = 2 * FLAT_MIN_ELEMENTS
    a, b = random_dualquats(rng, n), random_dualquats(rng, n)
    calls = flat_calls(monkeypatch, "dualquat_mul")
    f = dp.dualquat_mul.__wrapped__  # the Python path (the direct native entry in front of it declines these)
    one = f(a[5], b)  # one transform composed with many
    np.testing.assert_array_equal(one, f(np.tile(a[5], (n, 1)), b))
    assert len(calls) == 1  # only the tiled call
    table = f(a[:, None, :], b[None, :3, :])  # (n, 3, 8) by broadcasting
    np.testing.assert_array_equal(table[:, 2], f(a, np.tile(b[2], (n, 1))))
    assert len(calls) == 2
    f(a, strided(b))
    small = f(a[: FLAT_MIN_ELEMENTS - 1], b[: FLAT_MIN_ELEMENTS - 1])
    np.testing.assert_array_equal(small, f(a, b)[: FLAT_MIN_ELEMENTS - 1])
    assert len(calls) == 3
    grid = f(a.reshape(8, n // 8, 8), b.reshape(8, n // 8, 8))  # any leading shape, flat when equal
    np.testing.assert_array_equal(grid.reshape(n, 8), f(strided(a), b))
    assert len(calls) == 4
