"""The native solver's result-row layout (src/native/registration/row.hpp) is the one of dualpose.registration._row."""

from __future__ import annotations

from dualpose import _native
from dualpose.registration import _row as R

NAMES = (
    "ROW_SIZE", "QUAT_AT", "TRANSLATION_AT", "SCALE", "COST", "EIGENVALUES_AT", "EIGEN_GAP", "SINGULAR_AT",
    "REFLECTION", "UNIQUE", "CLOSED_FORM", "POINT_EXPONENT", "GAP_TOLERANCE", "POINT_COST", "BAD_INPUT",
)  # fmt: skip


def test_row_offsets_match_python_layout():
    for name in NAMES:
        assert getattr(_native, f"REGISTRATION_{name}") == getattr(R, name), name
    assert _native.REGISTRATION_N_BAD_INPUT_NAMES == len(R.BAD_INPUT_NAMES)


def test_every_python_offset_is_exported():
    offsets = {k for k, v in vars(R).items() if k.isupper() and isinstance(v, int)}
    assert offsets == set(NAMES)
