"""How well a rest period determines the gravity direction (``rest_gravity_sigma``, ``gravity_sigma_doubt`` of
``dualpose.types._inputs``; ``static_alignment``; the ``fuse --data`` and MSCKF starts): the predicted σ agrees with
the scatter of the direction over noise draws, a rest that is not at rest or a zero specific force is refused with
the reason, a poorly determined one is doubted and flagged, and a quiet one passes (docs/refusals.md, "Gravity
direction")."""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from dualpose import sim
from dualpose.estimation.initialization import static_alignment
from dualpose.pipelines.fuse import run_fuse
from dualpose.types._inputs import GRAVITY_SIGMA_DOUBT, gravity_sigma_doubt, rest_gravity_sigma
from dualpose.types.recording import RecordingWarning

F = np.array([0.3, -0.2, 9.79])


def _direction_scatter(noise: float, n: int, trials: int, rng: np.random.Generator) -> float:
    """RMS angle (rad) between the mean of ``n`` noisy samples and ``F``, over ``trials`` draws."""
    a = F + noise * rng.standard_normal((trials, n, 3))
    m = a.mean(axis=1)
    cos = m @ F / (np.linalg.norm(m, axis=1) * np.linalg.norm(F))
    sin = np.linalg.norm(np.cross(m, F), axis=1) / (np.linalg.norm(m, axis=1) * np.linalg.norm(F))
    return float(np.sqrt(np.mean(np.arctan2(sin, cos) ** 2)))


@pytest.mark.parametrize(("noise", "n"), [(0.05, 400), (2.0, 50), (8.0, 10)])
def test_the_predicted_sigma_matches_the_scatter_of_the_direction(noise, n, rng):
    """Root of the tangent-plane trace against the RMS angle of 2000 draws: within 10 % on average."""
    pred = np.mean([rest_gravity_sigma(F + noise * rng.standard_normal((n, 3))) for _ in range(200)])
    assert pred == pytest.approx(_direction_scatter(noise, n, 2000, rng), rel=0.1)


def test_the_white_noise_floors_a_spread_the_samples_do_not_show():
    """A single sample, or samples rounded to the same value, still carry the accelerometer's white noise."""
    same = np.repeat(F[None], 20, axis=0)
    assert rest_gravity_sigma(same) < 1e-15  # rounding of the mean only
    nd, rate = 2e-3, 200.0
    want = math.sqrt(2 * nd**2 * rate / 20) / np.linalg.norm(F)
    assert rest_gravity_sigma(same, nd, rate) == pytest.approx(want, rel=1e-12)
    assert rest_gravity_sigma(F[None], nd, rate) == pytest.approx(want * math.sqrt(20), rel=1e-12)
    assert rest_gravity_sigma(np.zeros((5, 3)), nd, rate) == math.inf  # free fall: no direction


def test_the_one_rule_refuses_doubts_or_passes(rng):
    quiet = static_alignment(F + 0.02 * rng.standard_normal((200, 3)), np.zeros((200, 3)),
                             accelerometer_noise_density=2e-3, rate=200.0)  # fmt: skip
    floor = math.sqrt(2 * 2e-3**2 * 200.0 / 200) / np.linalg.norm(quiet.specific_force)  # 0.028 m/s² > 0.02 spread
    assert quiet.gravity_sigma == pytest.approx(floor, rel=1e-12) and quiet.gravity_doubt("rest") is None
    shaken = static_alignment(F + 3.0 * rng.standard_normal((40, 3)), np.zeros((40, 3)))
    assert GRAVITY_SIGMA_DOUBT < shaken.gravity_sigma < math.radians(5.0)
    d = shaken.gravity_doubt("rest")
    assert d is not None and d.code == "gravity_sigma" and "the 40 accelerometer samples at rest" in d.message
    falling = static_alignment(0.5 * rng.standard_normal((40, 3)), np.zeros((40, 3)))
    with pytest.raises(ValueError, match=r"rest: the gravity direction is not determined by the 40 accelerometer "
                                         r"samples at rest: its standard deviation is"):  # fmt: skip
        falling.gravity_doubt("rest")
    with pytest.raises(ValueError, match="not determined"):
        gravity_sigma_doubt(math.nan, "x", "y")  # NaN is not a determined direction


RUN = sim.recording_from_simulation(sim.simulate_eight(0), rest_seconds=0.9)


def _with_rest_accel(noise: float, seed: int = 3) -> object:
    rest = RUN.t <= RUN.t[0] + RUN.rest_seconds
    accel = RUN.accel.copy()
    rng = np.random.default_rng(seed)
    accel[rest] += noise * rng.standard_normal((int(rest.sum()), 3))
    return dataclasses.replace(RUN, accel=accel)


def test_fuse_reports_the_rest_gravity_sigma_and_flags_or_refuses_a_shaken_rest():
    """``run_fuse`` on the simulated eight: the σ of its rest period is in the metrics and below the doubt; with a
    rest period shaken by 1.5 m/s² (white) it is doubted (``gravity_sigma`` in ``input_doubts``), with 12 m/s²
    refused naming the rest period."""
    m = run_fuse(RUN, "eskf").metrics
    assert 0.0 < m["gravity_sigma_deg"] < 0.1 and not any(d["code"] == "gravity_sigma" for d in m["input_doubts"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = run_fuse(_with_rest_accel(1.5), "eskf").metrics
    assert 1.0 < m["gravity_sigma_deg"] < 5.0
    assert [d["code"] for d in m["input_doubts"]].count("gravity_sigma") == 1
    assert any(issubclass(w.category, RecordingWarning) and "gravity direction" in str(w.message) for w in caught)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match="sim: rest period: the gravity direction is not determined"):
            run_fuse(_with_rest_accel(12.0), "eskf")


def test_scene_gravity_goes_through_the_same_rule():
    """``calibration.scene_gravity`` (a static period's specific force and camera attitude): its σ from the stated
    covariances; doubted above 1°, refused above 5°."""
    from dualpose.calibration import scene_gravity

    q = np.array([0.0, 0.0, 0.0, 1.0])
    f = np.array([0.0, 0.0, 9.81])
    ok = scene_gravity(f, q, q, specific_force_covariance=np.eye(3) * 1e-6, attitude_covariance=np.eye(3) * 1e-8)
    assert ok.sigma_deg < 0.02 and ok.doubt is None
    s = math.radians(2.0) / math.sqrt(2)  # 2° over the two tangent axes
    poor = scene_gravity(f, q, q, attitude_covariance=np.eye(3) * s**2)
    assert poor.sigma_deg == pytest.approx(2.0, rel=1e-6) and poor.doubt is not None
    with pytest.raises(ValueError, match="scene gravity: the gravity direction is not determined"):
        scene_gravity(f, q, q, attitude_covariance=np.eye(3) * (3 * s) ** 2)
