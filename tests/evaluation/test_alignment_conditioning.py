"""How well an alignment is determined (evaluation.align.alignment_conditioning): standard deviations that match a
Monte Carlo of the noise, refusal of alignments fitted to noise (a reference standing still with jitter, a few poses
of a nearly straight path, an estimate unrelated to the reference), warning and flag when poorly determined."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dualpose as dp
from dualpose.evaluation.align import align_positions, alignment_conditioning, umeyama_alignment


def _path(n: int, seed: int) -> np.ndarray:
    s = np.linspace(0.0, 8.0, n)
    return np.column_stack([np.cos(s), np.sin(1.3 * s), 0.3 * s]) + np.random.default_rng(seed).normal(0, 0.2, (n, 3))


@pytest.mark.parametrize("method", ["se3", "sim3"])
def test_standard_deviations_match_a_monte_carlo_of_the_noise(method):
    """Noise on the reference only: the rotation, translation (at the centroid) and scale spreads of repeated fits
    agree with the predicted ones (the prediction bounds the unknown split of the noise, so it is not below)."""
    rng = np.random.default_rng(1)
    x = _path(60, 2)
    r = dp.matrix_from_quat(dp.quat_normalize([0.2, -0.1, 0.3, 0.9]))
    y0 = 1.3 * x @ r.T + [1.0, 2.0, 3.0] if method == "sim3" else x @ r.T + [1.0, 2.0, 3.0]
    sigma = 0.02
    angles, trans, scales, pred = [], [], [], []
    for _ in range(300):
        y = y0 + rng.normal(0.0, sigma, y0.shape)
        a = umeyama_alignment(x, y, with_scale=method == "sim3")
        angles.append(dp.rotvec_from_quat(dp.quat_from_matrix(a.rotation @ r.T)))
        trans.append(a.scale * a.rotation @ x.mean(axis=0) + a.translation)  # where the centroid lands
        scales.append(a.scale)
        pred.append(a.conditioning)
    c = pred[0]
    worst = float(np.sqrt(np.max(np.linalg.eigvalsh(np.cov(np.array(angles).T)))))
    assert c.noise_m == pytest.approx(sigma, rel=0.3)
    assert worst <= c.rotation_std_rad * 1.3 and c.rotation_std_rad <= 1.6 * worst
    assert np.std(np.array(trans), axis=0).max() == pytest.approx(c.translation_std_m, rel=0.35)
    if method == "sim3":
        assert np.std(scales) <= c.scale_std * 1.3 and c.scale_std <= 1.6 * np.std(scales)
    assert c.well_determined and c.reason == ""


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 1000), st.floats(1e-6, 1e6), st.sampled_from(["se3", "sim3", "posyaw"]))
def test_conditioning_is_scale_invariant(seed, k, method):
    """Scaling both point sets scales the noise and translation standard deviations and keeps the rotation's."""
    x = _path(40, seed)
    y = x + np.random.default_rng(seed).normal(0.0, 0.01, x.shape)
    r = np.eye(3)
    a = alignment_conditioning(x, y, r, 1.0, method)
    b = alignment_conditioning(k * x, k * y, r, 1.0, method)
    assert b.rotation_std_rad == pytest.approx(a.rotation_std_rad, rel=1e-9)
    assert b.noise_m == pytest.approx(k * a.noise_m, rel=1e-9)
    assert b.translation_std_m == pytest.approx(k * a.translation_std_m, rel=1e-9)


@st.composite
def _noise_fitted(draw):
    """Point sets whose alignment is fitted to noise: a reference standing still with jitter against a moving
    estimate, a few poses of a nearly straight path, or two unrelated noise clouds."""
    seed = draw(st.integers(0, 10_000))
    rng = np.random.default_rng(seed)
    kind = draw(st.sampled_from(["still", "line", "unrelated"]))
    if kind == "still":
        n = draw(st.integers(20, 400))
        ref = rng.normal(size=3) + rng.normal(0.0, draw(st.floats(1e-6, 1e-3)), (n, 3))
        est = _path(n, seed) * draw(st.floats(0.1, 10.0))
    elif kind == "line":
        n = draw(st.integers(3, 12))
        t = np.linspace(0.0, 10.0, n)
        ref = np.outer(t, rng.normal(size=3)) + 0.001 * rng.normal(size=(n, 3))
        est = ref + rng.normal(0.0, 0.05, (n, 3))
    else:
        n = draw(st.integers(30, 300))
        ref, est = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    return ref, est, kind


@settings(max_examples=60, deadline=None)
@given(_noise_fitted(), st.sampled_from(["se3", "sim3", "scale"]))
def test_alignments_fitted_to_noise_are_refused_with_the_reason(case, method):
    ref, est, kind = case
    with pytest.raises(ValueError, match="not determined|degenerate|do not move|lie on a line"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            align_positions(ref, est, method)
    if kind != "line":
        with warnings.catch_warnings(record=True) as caught:  # the pipelines' mode: kept, warned about, flagged
            warnings.simplefilter("always")
            try:
                a = align_positions(ref, est, method, undetermined="warn")
            except ValueError:
                return  # degenerate to the coordinates' precision: always refused
        assert a.conditioning is not None and not a.conditioning.well_determined
        assert any("not determined" in str(w.message) for w in caught)


def test_the_issue_cases_and_the_dict():
    rng = np.random.default_rng(0)
    n = 500
    ref = np.array([1.0, 2.0, 3.0]) + rng.normal(0.0, 1e-4, (n, 3))  # 0.1 mm jitter
    est = _path(n, 1) * 0.5
    for method in ("se3", "sim3", "scale", "posyaw"):
        with pytest.raises(ValueError, match=rf"alignment \({method}\) is not determined by the data"):
            align_positions(ref, est, method)
    good = align_positions(_path(200, 3), _path(200, 3) + rng.normal(0.0, 0.01, (200, 3)), "sim3")
    d = good.as_dict()["conditioning"]
    assert d["well_determined"] and d["rotation_std_deg"] < 0.5 and 0 < d["scale_std"] < 1e-2
    assert align_positions(ref, est, "none").conditioning is None


def test_alignment_fields_must_describe_one_transform():
    from dualpose.evaluation.align import Alignment

    Alignment(np.eye(3), np.zeros(3), 1.0, "none")
    for rotation, translation, scale in (
        (2.0 * np.eye(3), np.zeros(3), 1.0),  # scaled: not a rotation (the scale has its own field)
        (np.diag([1.0, 1.0, -1.0]), np.zeros(3), 1.0),  # a reflection
        (np.eye(3), np.array([0.0, np.nan, 0.0]), 1.0),
        (np.eye(3), np.zeros(3), 0.0),
    ):
        with pytest.raises(ValueError):
            Alignment(rotation, translation, scale, "se3")
