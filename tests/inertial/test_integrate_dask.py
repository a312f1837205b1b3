"""Lazy dask inputs to the inertial integrators: chunked over batch axes, each series whole; equal to NumPy."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.inertial import integrate_attitude, integrate_pose

da = pytest.importorskip("dask.array")


@pytest.mark.parametrize(("integrate", "w0", "w"), [(integrate_attitude, 4, 3), (integrate_pose, 8, 6)])
def test_lazy_integration_equals_numpy_bit_for_bit(integrate, w0: int, w: int, dask_task_counter) -> None:
    rng = np.random.default_rng(5)
    x0 = dp.dualquat_normalize(rng.normal(size=(6, 8))) if w0 == 8 else dp.quat_normalize(rng.normal(size=(6, 4)))
    x = 0.01 * rng.normal(size=(6, 40, w))
    expected = integrate(x0, x, 2, "coning-optimal", "space")
    counter = dask_task_counter
    with counter:
        lazy = integrate(da.from_array(x0, chunks=(2, w0)), da.from_array(x, chunks=(3, 10, w)), 2,
                         "coning-optimal", "space")
        assert counter.tasks == 0
    assert isinstance(lazy, da.Array)
    assert lazy.chunks == ((2, 1, 1, 2), (21,), (w0,))  # batch chunks unified (2,2,2) x (3,3); time whole
    np.testing.assert_array_equal(lazy.compute(), expected)
    # one initial state against many dask series
    np.testing.assert_array_equal(integrate(x0[0], da.from_array(x, chunks=(2, 40, w)), 2).compute(),
                                  integrate(x0[0], x, 2))


def test_lazy_integration_checks_shapes_when_called() -> None:
    with pytest.raises(ValueError, match="not a positive multiple of samples=2"):
        integrate_attitude(np.array([0.0, 0, 0, 1]), da.zeros((4, 5, 3), chunks=2), 2)
    with pytest.raises(ValueError, match=r"q0 must have shape \(\.\.\., 4\)"):
        integrate_attitude(da.zeros((4, 3), chunks=2), da.zeros((4, 6, 3), chunks=2))
