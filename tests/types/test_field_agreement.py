"""Containers whose fields repeat one fact refuse them when they disagree (:func:`dualpose.types._inputs.check_agree`
and the checks built on it; docs/refusals.md, "Fields that repeat one fact"): each refusal names both fields, the
difference and the tolerance, and what agrees to the stored precision is accepted."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import dualpose as dp
from dualpose.evaluation.align import Alignment
from dualpose.io.euroc import ImuData
from dualpose.registration import calibrate_hand_eye
from dualpose.types import _inputs
from dualpose.types.camera_models import RadTanCamera
from dualpose.types.target import TargetDetections
from dualpose.types.trajectory import Trajectory, seconds_from_ns

EPOCH_NS = 1_403_715_524_907_143_168  # a EuRoC stamp: float64 seconds resolve ~0.24 us there


def _both_named(exc: pytest.ExceptionInfo[ValueError], a: str, b: str) -> None:
    text = str(exc.value)
    assert a in text and b in text and "disagree" in text, text


# ------------------------------------------------------------------------------------------------ the helper


@given(
    st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=8),
    st.floats(1e-12, 1.0),
    st.floats(1.5, 1e3),
    st.data(),
)
def test_check_agree_accepts_within_and_refuses_beyond_the_tolerance(values, tol, factor, data):
    a = np.array(values)
    k = data.draw(st.integers(0, len(a) - 1))
    near = a.copy()
    near[k] += 0.5 * tol
    _inputs.check_agree("first", a, "second", near, tol)  # within: accepted
    far = a.copy()
    far[k] += factor * tol * max(1.0, abs(a[k]))  # beyond, also after rounding at |a| up to 1e6
    with pytest.raises(ValueError) as exc:
        _inputs.check_agree("first", a, "second", far, tol, what="one fact", unit="m")
    _both_named(exc, "first", "second")
    assert "(one fact)" in str(exc.value) and f"tolerance {tol:.3g} m" in str(exc.value)


def test_check_agree_refuses_nan_and_other_shapes():
    with pytest.raises(ValueError, match=r"x and y disagree: at index 1 x gives nan"):
        _inputs.check_agree("x", [1.0, np.nan], "y", [1.0, 2.0], 1.0)
    with pytest.raises(ValueError, match=r"x and y disagree: shapes \(2,\) and \(3,\)"):
        _inputs.check_agree("x", [1.0, 2.0], "y", [1.0, 2.0, 3.0], 1.0)


# ------------------------------------------------------------------------------------------------ stamps twice


@given(st.lists(st.integers(0, 2**62), min_size=1, max_size=20, unique=True), st.data())
def test_seconds_repeating_integer_nanoseconds_must_be_them(ns_list, data):
    ns = np.array(sorted(ns_list), dtype=np.int64)
    n = len(ns)
    poses = (np.zeros((n, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)))
    Trajectory(seconds_from_ns(ns), *poses, ns)  # exact
    Trajectory(ns / 1e9, *poses, ns)  # the usual division: within the float's rounding
    k = data.draw(st.integers(0, n - 1))
    t = seconds_from_ns(ns)
    t[k] += max(2e-9, 8 * float(np.spacing(t[k])))  # beyond half a nanosecond and the float's rounding
    with pytest.raises(ValueError) as exc:
        Trajectory(t, *poses, ns)
    _both_named(exc, "stamps", "stamps_ns")


def test_imu_data_and_target_detections_refuse_seconds_that_are_not_their_nanoseconds():
    ns = EPOCH_NS + np.arange(4, dtype=np.int64) * 5_000_000
    t = seconds_from_ns(ns)
    ImuData(ns, t, np.zeros((4, 3)), np.zeros((4, 3)))
    with pytest.raises(ValueError) as exc:
        ImuData(ns, t + 1e-3, np.zeros((4, 3)), np.zeros((4, 3)))  # a 1 ms shift of the seconds only
    _both_named(exc, "stamps", "stamps_ns")
    with pytest.raises(ValueError, match=r"gyro must have shape \(4, 3\)"):
        ImuData(ns, t, np.zeros((3, 3)), np.zeros((4, 3)))
    empty = (np.zeros(5, np.int64), np.zeros((0, 2)), np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64))
    TargetDetections(ns, t, *empty)
    with pytest.raises(ValueError) as exc:
        TargetDetections(ns, t[::-1].copy(), *empty)
    _both_named(exc, "t", "stamps_ns")


@pytest.fixture(scope="module")
def sim_recording():
    from dualpose.sim.camera_imu import recording_from_simulation, simulate_eight

    return recording_from_simulation(simulate_eight(seed=1))


def test_recording_refuses_stamps_ns_that_are_not_its_times(sim_recording):
    rec = sim_recording
    ns = np.round(rec.t * 1e9).astype(np.int64)
    assert dataclasses.replace(rec, stamps_ns=ns).stamps_ns is ns  # rounded to the nanosecond: the same times
    with pytest.raises(ValueError) as exc:
        dataclasses.replace(rec, stamps_ns=ns + 1_000_000)  # 1 ms apart
    _both_named(exc, "t", "stamps_ns")
    with pytest.raises(ValueError, match="stamps_ns must be an integer array"):
        dataclasses.replace(rec, stamps_ns=rec.t)


# ------------------------------------------------------------------------------------------------ cameras, rotations


def test_a_camera_principal_point_must_lie_in_its_image():
    RadTanCamera(450.0, 450.0, 367.0, 248.0, 0.0, 0.0, 0.0, 0.0, 752, 480)
    with pytest.raises(ValueError, match=r"principal point \(900, 248\) px is outside the 752 x 480 image"):
        RadTanCamera(450.0, 450.0, 900.0, 248.0, 0.0, 0.0, 0.0, 0.0, 752, 480)


@given(st.floats(-np.pi, np.pi), st.floats(1e-5, 0.1))
def test_alignment_rotation_must_be_orthonormal_and_proper(angle, stretch):
    r = dp.matrix_from_quat([0.0, 0.0, np.sin(angle / 2), np.cos(angle / 2)])
    Alignment(r, np.zeros(3), 1.0, "se3")
    with pytest.raises(ValueError) as exc:
        Alignment(r @ np.diag([1.0 + stretch, 1.0, 1.0]), np.zeros(3), 1.0, "se3")
    _both_named(exc, "rotationᵀrotation", "the identity")
    with pytest.raises(ValueError, match="proper rotation.*reflection"):
        Alignment(r @ np.diag([1.0, 1.0, -1.0]), np.zeros(3), 1.0, "se3")


# ------------------------------------------------------------------------------------------------ one pose, four forms


@pytest.fixture(scope="module")
def hand_eye_result():
    rng = np.random.default_rng(3)
    X = dp.dualquat_from_qt(dp.quat_normalize(rng.normal(size=4)), [0.1, -0.2, 0.3])
    B = dp.dualquat_from_qt(dp.quat_normalize(rng.normal(size=(6, 4))), rng.normal(size=(6, 3)))
    A = dp.dualquat_mul(dp.dualquat_mul(X, B), dp.dualquat_conj(X))
    return calibrate_hand_eye(A, B)


@pytest.mark.parametrize(
    ("field", "change", "names"),
    [
        ("translation", lambda r: r.translation + [1e-6, 0, 0], ("dualquat dual part", "½ translation ⊗ quat")),
        ("quat", lambda r: dp.quat_normalize(r.quat + [1e-6, 0, 0, 0]), ("dualquat real part", "quat")),
        ("matrix", lambda r: r.matrix + np.diag([0, 0, 0, 1e-3]), ("matrix last row", "0 0 0 1")),
        ("dualquat", lambda r: np.concatenate([r.dualquat[:4], r.dualquat[4:] + 1e-3 * r.dualquat[:4]]),
         ("dualquat dual part", "½ translation ⊗ quat")),
    ],
)  # fmt: skip
def test_hand_eye_result_forms_must_be_one_pose(hand_eye_result, field, change, names):
    dataclasses.replace(hand_eye_result)  # as computed: they agree
    with pytest.raises(ValueError) as exc:
        dataclasses.replace(hand_eye_result, **{field: change(hand_eye_result)})
    _both_named(exc, *names)


def test_a_dual_part_not_orthogonal_to_the_real_part_is_refused():
    q, t = dp.quat_normalize([0.1, 0.2, 0.3, 0.9]), np.array([1.0, 2.0, 3.0])
    d = dp.dualquat_from_qt(q, t)
    _inputs.check_pose_agrees(q, t, d, None)
    d[4:] += 1e-6 * d[:4]  # a component along the real part: no unit dual quaternion
    with pytest.raises(ValueError) as exc:
        _inputs.check_pose_agrees(q, t, d, None)
    _both_named(exc, "dualquat dual part", "½ translation ⊗ quat")
