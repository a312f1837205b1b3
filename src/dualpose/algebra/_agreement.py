"""The one check of fields that repeat one fact (docs/refusals.md, "Fields that repeat one fact"), in the lowest
layer so that every container can use it; :mod:`dualpose.types._inputs` re-exports it with the checks built on it.

A container or file that states one fact twice (a time in seconds and in nanoseconds, a pose as a quaternion and as a
matrix, a rate under two keys) refuses the two when they disagree beyond the precision they are stored with:
``FIELD_A and FIELD_B disagree (WHAT): ...`` with the difference and the tolerance.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dualpose.algebra.dualquat import dualquat_from_qt
from dualpose.algebra.quat import matrix_from_quat

__all__ = ["COMPUTED_TOLERANCE", "check_agree", "check_pose_agrees", "disagreement"]


def disagreement(field_a: str, field_b: str, what: str, detail: str) -> ValueError:
    """The refusal of two fields of one container that state the same information (``what``) differently:
    ``FIELD_A and FIELD_B disagree (WHAT): DETAIL`` (the one wording of :func:`check_agree` and of the checks that
    compare more than numbers)."""
    return ValueError(f"{field_a} and {field_b} disagree{f' ({what})' if what else ''}: {detail}")


def check_agree(field_a: str, value_a: Any, field_b: str, value_b: Any, tolerance: Any, *, what: str = "",
                unit: str = "") -> None:  # fmt: skip
    """Refuse two fields of one container that state the same information and disagree.

    ``value_a`` and ``value_b`` (numbers or arrays of one shape, compared element by element as float64) must differ
    by at most ``tolerance`` (a number, or an array broadcasting against them, e.g. a tolerance relative to each
    element); a NaN disagrees with everything.  ``what`` says what the two fields both state ("the IMU rate",
    "time of each pose"); ``unit`` is appended to the numbers.

    Raises
    ------
    ValueError
        ``FIELD_A and FIELD_B disagree (WHAT): at index K FIELD_A gives A, FIELD_B gives B, a difference of D UNIT
        (tolerance T UNIT)``; or their shapes differ.
    """
    a = np.asarray(value_a, dtype=np.float64)
    b = np.asarray(value_b, dtype=np.float64)
    if a.shape != b.shape:
        raise disagreement(field_a, field_b, what, f"shapes {a.shape} and {b.shape}")
    tol = np.broadcast_to(np.asarray(tolerance, dtype=np.float64), a.shape)
    with np.errstate(invalid="ignore", over="ignore"):
        diff = np.abs(a - b)
        bad = ~(diff <= tol)  # NaN compares False
    if not bad.any():
        return
    k = int(np.argmax(bad.reshape(-1)))
    at = f"at index {np.unravel_index(k, a.shape) if a.ndim > 1 else k} " if a.ndim else ""
    u = f" {unit}" if unit else ""
    raise disagreement(field_a, field_b, what, f"{at}{field_a} gives {float(a.reshape(-1)[k])!r}, {field_b} gives "
                       f"{float(b.reshape(-1)[k])!r}, a difference of {diff.reshape(-1)[k]:.3g}{u} (tolerance "
                       f"{tol.reshape(-1)[k]:.3g}{u})")  # fmt: skip


#: two fields of a result computed from one another in float64 agree to this, relative to ``max(1, |t|)`` for
#: translations (a thousand units in the last place: each conversion rounds a few times)
COMPUTED_TOLERANCE = 1.0e3 * float(np.finfo(np.float64).eps)


def check_pose_agrees(quat: Any, translation: Any, dualquat: Any = None, matrix: Any = None,
                      tolerance: float = COMPUTED_TOLERANCE) -> None:  # fmt: skip
    """Refuse a pose stated several ways that disagree: ``quat`` (4,) xyzw unit and ``translation`` (3,), the unit
    dual quaternion ``dualquat`` (8,) ``[real xyzw, dual xyzw]`` (its real part ``±quat``, its dual part
    ``½ t ⊗ real``, so orthogonal to the real part) and the homogeneous ``matrix`` (4, 4) (rotation block
    ``R(quat)``, last column ``translation``, last row 0 0 0 1), each to ``tolerance`` (translations relative to
    ``max(1, |t|)``)."""
    q = np.asarray(quat, dtype=np.float64)
    t = np.asarray(translation, dtype=np.float64)
    check_agree("|quat|", np.linalg.norm(q), "1", 1.0, tolerance, what="a rotation is a unit quaternion")
    scale = tolerance * max(1.0, float(np.abs(t).max()))
    if dualquat is not None:
        d = np.asarray(dualquat, dtype=np.float64)
        sign = 1.0 if float(d[:4] @ q) >= 0.0 else -1.0  # q and -q are one rotation
        want = sign * dualquat_from_qt(q, t)
        check_agree("dualquat real part", d[:4], "quat", want[:4], tolerance, what="the rotation")
        check_agree("dualquat dual part", d[4:], "½ translation ⊗ quat", want[4:], scale, what="the translation")
    if matrix is not None:
        m = np.asarray(matrix, dtype=np.float64)
        check_agree("matrix rotation block", m[:3, :3], "R(quat)", matrix_from_quat(q), tolerance, what="the rotation")
        check_agree("matrix last column", m[:3, 3], "translation", t, scale, what="the translation")
        check_agree("matrix last row", m[3], "0 0 0 1", [0.0, 0.0, 0.0, 1.0], tolerance,
                    what="the last row of a rigid transform")  # fmt: skip
