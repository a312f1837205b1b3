"""The five classical hand–eye closed forms against OpenCV's ``calibrateHandEye`` on the same poses."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.registration import HAND_EYE_CLOSED_FORMS, hand_eye_motions, hand_eye_translation

cv2 = pytest.importorskip("cv2")

OPENCV = {"tsai_lenz": "TSAI", "park_martin": "PARK", "horaud_dornaika": "HORAUD", "andreff": "ANDREFF",
          "daniilidis": "DANIILIDIS"}  # fmt: skip


def _poses(seed: int, n: int, rot_deg: float, trans_m: float):
    """Gripper-to-base and target-to-camera matrices (n, 4, 4) of a random set-up, camera poses with noise."""
    rng = np.random.default_rng(seed)
    qx, tx = dp.quat_from_rotvec(rng.normal(size=3)), rng.normal(size=3) * 0.1
    qg, tg = dp.quat_from_rotvec(rng.normal(size=(n, 3))), rng.normal(size=(n, 3)) * 0.3
    qt, tt = dp.quat_from_rotvec(rng.normal(size=3)), rng.normal(size=3)
    qc, tc = dp.qt_mul(*dp.qt_conj(qt, tt), *dp.qt_mul(qg, tg, qx, tx))  # camera in target
    qc = dp.quat_mul(qc, dp.quat_from_rotvec(rng.normal(scale=np.deg2rad(rot_deg), size=(n, 3))))
    tc = tc + rng.normal(scale=trans_m, size=(n, 3))
    g = np.tile(np.eye(4), (n, 1, 1))
    g[:, :3, :3], g[:, :3, 3] = dp.matrix_from_quat(qg), tg
    c = np.tile(np.eye(4), (n, 1, 1))
    qi, ti = dp.qt_conj(qc, tc)
    c[:, :3, :3], c[:, :3, 3] = dp.matrix_from_quat(qi), ti
    return g, c, qx, tx


def _opencv(g, c, name):
    r, t = cv2.calibrateHandEye(list(g[:, :3, :3]), list(g[:, :3, 3:]), list(c[:, :3, :3]), list(c[:, :3, 3:]),
                                method=getattr(cv2, f"CALIB_HAND_EYE_{OPENCV[name]}"))  # fmt: skip
    return dp.quat_from_matrix(r), t.ravel()


@pytest.mark.parametrize("name", list(HAND_EYE_CLOSED_FORMS))
def test_exact_data_recovers_x_like_opencv(name):
    g, c, qx, tx = _poses(1, 8, 0.0, 0.0)
    q, t = HAND_EYE_CLOSED_FORMS[name](*hand_eye_motions(g, c))
    qc, tc = _opencv(g, c, name)
    assert np.degrees(dp.quat_angle(q, qx)) < 1e-9 and np.linalg.norm(t - tx) < 1e-12
    assert np.degrees(dp.quat_angle(q, qc)) < 1e-9 and np.linalg.norm(t - tc) < 1e-12


@pytest.mark.parametrize("name", list(HAND_EYE_CLOSED_FORMS))
def test_noisy_data_matches_opencv(name):
    """OpenCV pairs every two poses as ``(j, i)`` motions: the inverses of :func:`hand_eye_motions` ``"all"``.  On the
    same motions four methods agree with OpenCV to rounding; Tsai–Lenz's rotation differs from OpenCV's by a fraction of
    the estimation error (the same paper, a different but equivalent arrangement of its least squares)."""
    g, c, qx, tx = _poses(2, 12, 0.3, 2e-3)
    a, b = hand_eye_motions(g, c)
    q, t = HAND_EYE_CLOSED_FORMS[name](dp.dualquat_conj(a), dp.dualquat_conj(b))
    qc, tc = _opencv(g, c, name)
    err_deg = np.degrees(dp.quat_angle(qc, qx))
    if name == "tsai_lenz":
        assert np.degrees(dp.quat_angle(q, qc)) < 0.8 * err_deg
        assert np.degrees(dp.quat_angle(q, qx)) < 1.5 * err_deg
        np.testing.assert_allclose(t, hand_eye_translation(dp.dualquat_conj(a), dp.dualquat_conj(b), q))
    else:
        assert np.degrees(dp.quat_angle(q, qc)) < 1e-9 and np.linalg.norm(t - tc) < 1e-12


def test_translation_step_minimises_the_loop_translation():
    g, c, _, _ = _poses(3, 10, 0.3, 2e-3)
    a, b = hand_eye_motions(g, c)
    q, _ = HAND_EYE_CLOSED_FORMS["park_martin"](a, b)
    t = hand_eye_translation(a, b, q)

    def loop_rms(tt):
        x = dp.dualquat_from_qt(q, tt)
        e = dp.dualquat_mul(dp.dualquat_conj(dp.dualquat_mul(a, x)), dp.dualquat_mul(x, b))
        return np.sqrt(np.mean(np.sum(dp.qt_from_dualquat(e)[1] ** 2, 1)))

    rng = np.random.default_rng(4)
    assert all(loop_rms(t) < loop_rms(t + d) for d in rng.normal(scale=1e-3, size=(20, 3)))


@pytest.mark.parametrize("name", ["tsai_lenz", "park_martin", "horaud_dornaika", "andreff"])
def test_bad_input(name):
    g, c, _, _ = _poses(5, 6, 0.0, 0.0)
    a, b = hand_eye_motions(g, c)
    with pytest.raises(ValueError, match="same count"):
        HAND_EYE_CLOSED_FORMS[name](a, b[:-1])
    with pytest.raises(ValueError, match=r"\(n, 4, 4\)"):
        HAND_EYE_CLOSED_FORMS[name](a[:, :4], b[:, :4])
    with pytest.raises(ValueError, match="at least 2"):
        HAND_EYE_CLOSED_FORMS[name](a[:1], b[:1])
