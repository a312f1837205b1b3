"""The flat row-loop paths (C-contiguous batches of >= 64 elements) against mpmath and against the gufunc path.

``quat_rotate`` and ``quat_log`` switch to vectorised loops over flat buffers for
C-contiguous input without broadcasting (``dualpose.algebra._flat_kernels``); everything else -- broadcasting,
strided views, small batches, extreme norms, zeros -- goes through the gufuncs.  Here the same data is pushed
through both paths (a strided copy forces the gufunc), and the flat ``quat_log`` is held to the 4ε bar of the
accuracy suite on every one of its mpmath cases at once.
"""

from __future__ import annotations

import accuracy_cases as cases
import accuracy_reference as ref
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dualpose as dp
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
