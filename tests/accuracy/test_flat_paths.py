"""The flat row-loop paths (C-contiguous batches of >= 64 elements) against mpmath and against the gufunc path.

``quat_rotate``, ``quat_log`` and ``dualquat_transform`` switch to vectorised loops over flat buffers for
C-contiguous input without broadcasting (``dualpose.algebra._flat_kernels``; the transform through the explicit
8-row SIMD blocks of ``dualpose.algebra._simd``); everything else -- broadcasting, strided views, small batches,
extreme norms, zeros, outputs overlapping an input -- goes through the gufuncs.  Here the same data is pushed
through both paths (a strided copy forces the gufunc), the flat ``quat_log`` is held to the 4ε bar of the
accuracy suite on every one of its mpmath cases at once, and the flat transform is checked against an
extended-precision evaluation of ``R p + t``.
"""

from __future__ import annotations

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
    """Non-unit quaternions with norms spread over 1e-3 .. 1e3 and some exactly unit-normalised rows."""
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


def flat_calls(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Count the calls of the flat transform kernel made by ``dp.dualquat_transform`` from now on."""
    calls: list[int] = []
    kernel = dq_module._fk("dualquat_transform")

    def spy(*args: np.ndarray) -> int:
        calls.append(1)
        return kernel(*args)

    get = dq_module._fk
    monkeypatch.setattr(dq_module, "_fk", lambda name: spy if name == "dualquat_transform" else get(name))
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


def test_transform_out_in_place_and_overlapping(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(11)
    n = 3 * FLAT_MIN_ELEMENTS + 7
    s, p = random_dualquats(rng, n), rng.normal(size=(n, 3))
    expect = dp.dualquat_transform(strided(s), p)
    calls = flat_calls(monkeypatch)
    out = np.empty((n, 3))
    assert dp.dualquat_transform(s, p, out=out) is out
    np.testing.assert_array_equal(out, expect)
    q = p.copy()
    assert dp.dualquat_transform(s, q, out=q) is q  # in place: each 8-row block is loaded before it is stored
    np.testing.assert_array_equal(q, expect)
    assert len(calls) == 2
    buf = np.zeros((n + 1, 3))  # out shifted by one row over the points: the gufunc, on NumPy's copies
    buf[:n] = p
    dp.dualquat_transform(s, buf[:n], out=buf[1:])
    np.testing.assert_array_equal(buf[1:], expect)
    fortran = np.asfortranarray(np.empty((n, 3)))
    dp.dualquat_transform(s, p, out=fortran)
    np.testing.assert_array_equal(fortran, expect)
    assert len(calls) == 2


def test_transform_broadcasting_and_strided_input_take_the_gufunc(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(12)
    n = 2 * FLAT_MIN_ELEMENTS
    s, p = random_dualquats(rng, n), rng.normal(size=(n, 3))
    calls = flat_calls(monkeypatch)
    one = dp.dualquat_transform(s[5], p)  # one transform, many points
    np.testing.assert_array_equal(one, dp.dualquat_transform(np.tile(s[5], (n, 1)), p))
    assert len(calls) == 1  # only the tiled call
    many = dp.dualquat_transform(s[:, None, :], p[None, :3, :])  # (n, 3, 3) by broadcasting
    np.testing.assert_array_equal(many[:, 1], dp.dualquat_transform(s, np.tile(p[1], (n, 1))))
    assert len(calls) == 2
    dp.dualquat_transform(strided(s), p)
    dp.dualquat_transform(s[: FLAT_MIN_ELEMENTS - 1], p[: FLAT_MIN_ELEMENTS - 1])
    assert len(calls) == 2
