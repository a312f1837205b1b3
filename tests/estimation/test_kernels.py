"""The ESKF kernels' Joseph updates against the textbook dense formula; the native layout constants against
:mod:`dualpose.estimation.state`."""

from __future__ import annotations

import numpy as np

from dualpose import _native as K
from dualpose.estimation import state


def test_joseph_2d_equals_dense_joseph(rng) -> None:
    A = rng.normal(size=(15, 15))
    P = A @ A.T + np.eye(15)
    H = np.zeros((2, 15))
    H[:, 0:3] = rng.normal(size=(2, 3))
    H[:, 6:9] = rng.normal(size=(2, 3))
    s2 = 0.7
    S = H @ P @ H.T + s2 * np.eye(2)
    Kg = P @ H.T @ np.linalg.inv(S)
    I_KH = np.eye(15) - Kg @ H
    expected = I_KH @ P @ I_KH.T + s2 * Kg @ Kg.T
    got = P.copy()
    K.eskf_joseph_2d(got, Kg, H, s2)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)
    dense = P.copy()
    K.eskf_joseph(dense, Kg, H, s2 * np.eye(2))
    np.testing.assert_allclose(dense, expected, rtol=1e-12, atol=1e-12)
    # with the optimal gain Joseph equals the short form (I − KH) P
    np.testing.assert_allclose(got, I_KH @ P, rtol=1e-9, atol=1e-9)


def test_native_layout_constants_equal_state_py() -> None:
    """The offsets compiled into the native error-state kernels are the ones of the Python layout definitions."""
    names = [n for n in dir(state) if n.startswith("ESKF_") and isinstance(getattr(state, n), int)]
    assert len(names) == 12
    for name in names:
        assert getattr(K, name) == getattr(state, name), name
    for block in state.ESKF_STATE.names:
        assert getattr(K, "ESKF_" + block.upper()) == state.ESKF_STATE.offset(block)
    for block in state.ESKF_ERROR.names:
        assert getattr(K, "ESKF_D_" + block.upper()) == state.ESKF_ERROR.offset(block)
    assert (K.ESKF_DIM, K.ESKF_ERROR_DIM) == (state.ESKF_STATE.dim, state.ESKF_ERROR.dim)
