"""register_pose_batch on dask arrays: lazy (no task before compute), equal to the NumPy batch bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.registration import register_pose_batch

da = pytest.importorskip("dask.array")


def _problems(rng: np.random.Generator, b: int = 40, n: int = 6, m: int = 3) -> tuple[np.ndarray, ...]:
    q = dp.quat_normalize(rng.normal(size=(b, 4)))
    p0, n0 = rng.normal(size=(b, n, 3)), rng.normal(size=(b, m, 3))
    p1 = dp.quat_rotate(q[:, None], p0) + rng.normal(size=(b, 1, 3)) + 0.05 * rng.normal(size=(b, n, 3))
    n1 = dp.quat_rotate(q[:, None], n0) + 0.05 * rng.normal(size=(b, m, 3))
    return p0, p1, n0, n1, rng.uniform(0.2, 3, (b, n)), rng.uniform(0.2, 3, (b, m))


@pytest.mark.parametrize("method", ["dq", "svd"])
def test_lazy_batch_equals_numpy_bit_for_bit(rng, method: str, dask_task_counter) -> None:
    p0, p1, n0, n1, w, a = _problems(rng)
    expected = register_pose_batch(p0, p1, w, model_directions=n0, measured_directions=n1, direction_weights=a,
                                   method=method)
    lazy_in = [da.from_array(x, chunks=(15,) + (-1,) * (x.ndim - 1)) for x in (p0, p1, n0, n1)]
    counter = dask_task_counter
    with counter:
        lazy = register_pose_batch(lazy_in[0], lazy_in[1], w, model_directions=lazy_in[2],
                                   measured_directions=lazy_in[3], direction_weights=a, method=method)
        attrs = {k: getattr(lazy, k) for k in ("quat", "translation", "scale", "cost", "rmsd", "eigen_gap",
                                                "rotation_unique", "rotation_matrix", "dualquat")}
        assert counter.tasks == 0 and len(lazy) == 40 and "lazy" in repr(lazy)
    for k, v in attrs.items():
        assert isinstance(v, da.Array) and v.chunks[0] == (15, 15, 10), k
        np.testing.assert_array_equal(v.compute(), getattr(expected, k), err_msg=k)
    assert lazy[37].quat.tolist() == expected[37].quat.tolist() and lazy[37].degeneracy == expected[37].degeneracy
    done = lazy.compute()
    assert isinstance(done._rows, np.ndarray)
    np.testing.assert_array_equal(done._rows, expected._rows)
    # points only, unweighted
    np.testing.assert_array_equal(register_pose_batch(lazy_in[0], lazy_in[1]).quat.compute(),
                                  register_pose_batch(p0, p1).quat)


def test_lazy_batch_checks_shapes_at_call_and_values_when_computed(rng) -> None:
    p0, p1, n0, n1, w, _ = _problems(rng)
    x0, x1 = da.from_array(p0, chunks=(15, 6, 3)), da.from_array(p1, chunks=(15, 6, 3))
    with pytest.raises(ValueError, match=r"measured_points must have shape \(B, n, 3\); got shape \(40, 6, 2\)"):
        register_pose_batch(x0, x1[..., :2])
    with pytest.raises(ValueError, match="not enough correspondences"):
        register_pose_batch(x0[:, :2], x1[:, :2])
    with pytest.raises(ValueError, match=r"point_weights must have shape \(40, 6\)"):
        register_pose_batch(x0, x1, w[:, :5])
    w[33, 1:] = 0.0  # one point left in problem 33 (in the third block): found when computed, numbered globally
    lazy = register_pose_batch(x0, x1, da.from_array(w, chunks=(15, 6)))
    with pytest.raises(ValueError, match="^problem 33: not enough correspondences"):
        lazy.quat.compute()
    n0[21, 2] = 0.0
    lazy = register_pose_batch(x0, x1, model_directions=da.from_array(n0, chunks=(15, 3, 3)), measured_directions=n1)
    with pytest.raises(ValueError, match=r"entry \(21, 2\) is zero"):
        lazy.cost.compute()
