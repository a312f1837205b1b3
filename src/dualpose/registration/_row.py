"""Layout of the result row the registration kernels write (``ROW_SIZE`` floats per problem), defined once.

=====================  ====================================================================================
``QUAT`` (0:4)         rotation quaternion xyzw (``w >= 0``)
``TRANSLATION`` (4:7)  translation
``SCALE`` (7)          scale (1 unless ``want_scale``)
``COST`` (8)           cost ``E`` (the documented weighted sum of squares)
``EIGENVALUES`` (9:13) eigenvalues (descending) of the 4x4 matrix that decided the rotation: Walker's ``A``
                       (eq. (47)) for ``dq``, Horn's ``N`` for ``horn`` and ``svd``
``EIGEN_GAP`` (13)     the gap that decided uniqueness: ``λ1 - λ2`` (``dq``, ``horn``) or ``2 (s2 + d s3)`` (``svd``)
``SINGULAR`` (14:17)   singular values of the cross-covariance ``H`` (``svd`` only, else 0)
``REFLECTION`` (17)    ``d = sign det(...)`` of the reflection guard (``svd`` only, else 0)
``UNIQUE`` (18)        1 if the optimal rotation is unique (gap above tolerance), else 0
``CLOSED_FORM`` (19)   1 if the closed-form eigen-solve was accepted, 0 if the Jacobi iteration decided
``POINT_EXPONENT`` (20) ``e``: the kernel solved on the centred points scaled exactly by ``2**e`` (0 for spreads
                       whose squared moments are ordinary; else the power of two that brings the largest centred
                       coordinate near 1, so points at 1e-200 or 1e200 solve as at 1).  Reported values are in the
                       input's units.
``GAP_TOLERANCE`` (22) the gap tolerance used (21 unused)
``POINT_COST`` (23)    the point part of the cost, ``Σβ‖r_i‖²``
``BAD_INPUT`` (24)     0, or ``1 + index`` into ``BAD_INPUT_NAMES`` of the first input holding NaN or infinity, or
                       ``len(BAD_INPUT_NAMES) + 1`` when finite inputs overflow the moments (nothing else is set)
=====================  ====================================================================================

The ``*_AT`` integers are the first index of each block; the native solver's copy of these offsets
(``src/native/registration/row.hpp``, exported as ``dualpose._native.REGISTRATION_*``) is checked against them by
``tests/registration/test_native_layout.py``.  The Python wrappers use the slices.
"""

from __future__ import annotations

ROW_SIZE = 25
QUAT_AT, TRANSLATION_AT, EIGENVALUES_AT, SINGULAR_AT = 0, 4, 9, 14
SCALE, COST, EIGEN_GAP, REFLECTION, UNIQUE, CLOSED_FORM, POINT_EXPONENT, GAP_TOLERANCE, POINT_COST, BAD_INPUT = (
    7, 8, 13, 17, 18, 19, 20, 22, 23, 24,
)  # fmt: skip
QUAT = slice(QUAT_AT, QUAT_AT + 4)
TRANSLATION = slice(TRANSLATION_AT, TRANSLATION_AT + 3)
EIGENVALUES = slice(EIGENVALUES_AT, EIGENVALUES_AT + 4)
SINGULAR = slice(SINGULAR_AT, SINGULAR_AT + 3)

#: names of the arrays a non-zero ``row[BAD_INPUT]`` points at (1-based code of the first non-finite input)
BAD_INPUT_NAMES = ("model_points", "measured_points", "model_directions", "measured_directions")
