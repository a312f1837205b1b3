"""quat_log on non-unit quaternions: ln|q| switches between log1p and log by |q|**2 (algebra/_kutil.log_norm).

Both sides of each switch (|q|**2 = 1/2 and 2, and far away) must keep the normwise relative error within the bar,
against mpmath at 50 digits.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

import dualpose as dp

EPS = np.finfo(float).eps


def _reference_log(q: np.ndarray) -> list:
    with mp.workdps(50):
        x, y, z, w = (mp.mpf(float(v)) for v in q)
        s = mp.sqrt(x * x + y * y + z * z)
        f = mp.atan2(s, w) / s
        return [f * x, f * y, f * z, mp.log(mp.sqrt(s * s + w * w))]


_NORMS2 = [1e-250, 0.01, 0.4999, 0.5, 0.5001, 0.9, 1.0 + 1e-12, 1.9999, 2.0, 2.0001, 7.0, 1e250]


@pytest.mark.parametrize("norm2", _NORMS2)
def test_quat_log_nonunit_within_bar(norm2: float) -> None:
    rng = np.random.default_rng(int(abs(np.log(norm2)) * 1000))
    q = rng.normal(size=(40, 4))
    q[:10, :3] *= 1e-9  # near the real axis: ln|q| dominates the norm of the log
    q *= np.sqrt(norm2) / np.linalg.norm(q, axis=1, keepdims=True)
    out = dp.quat_log(q)
    for qi, li in zip(q, out, strict=True):
        ref = _reference_log(qi)
        with mp.workdps(50):
            err = mp.sqrt(sum((mp.mpf(float(a)) - b) ** 2 for a, b in zip(li, ref, strict=True)))
            rel = float(err / mp.sqrt(sum(b * b for b in ref)))
        assert rel <= 4 * EPS, (qi, rel / EPS)
