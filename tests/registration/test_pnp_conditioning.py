"""PnP refuses a pose its points do not determine (nearly collinear points): the rotation standard deviation at the
given pixel noise, not an exact rank test, decides (docs/refusals.md)."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.registration import pnp

K = np.array([[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]])


def _pixels(points: np.ndarray, rng: np.random.Generator, sigma: float) -> np.ndarray:
    """Camera at the origin looking down +z (R_cw = I, t = 0), pixel noise ``sigma``."""
    uvw = points @ K.T
    return uvw[:, :2] / uvw[:, 2:] + rng.normal(0.0, sigma, (len(points), 2))


def test_spread_points_pass_nearly_collinear_points_are_refused():
    rng = np.random.default_rng(3)
    spread = np.column_stack([rng.uniform(-1, 1, 12), rng.uniform(-1, 1, 12), rng.uniform(4, 6, 12)])
    res = pnp.solve_pnp(_pixels(spread, rng, 0.5), spread, K, pixel_sigma=0.5)
    assert dp.quat_angle(res.q_wc, [0, 0, 0, 1.0]) < 0.01
    s = np.linspace(-1.0, 1.0, 12)
    line = np.column_stack([s, 0.5 * s, 5.0 + 0.3 * s]) + rng.normal(0.0, 1e-4, (12, 3))  # 0.1 mm off a line
    with pytest.raises(ValueError, match="PnP pose is not determined"):
        pnp.solve_pnp(_pixels(line, rng, 0.5), line, K, pixel_sigma=0.5)
