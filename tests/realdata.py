"""Where the real-data tests find their recordings: the full ones beside the checkout, or the small cuts shipped in
``tests/data/`` (sources, licences and how they were cut: ``tests/data/README.md``).

``<repo>/../shared/data`` holds the full recordings (the environment variable ``DUALPOSE_SHARED_DATA`` names
another directory).  A test that runs on any stretch of a recording (readers, frames, stream = batch, CLI output)
takes ``data_dir(name)``: the full directory when present, otherwise the cut, so it runs in a plain clone.  A test
of an accuracy target on a whole recording takes ``data_dir(name, full=True)``: the full directory only (it does
not exist in a plain clone, and the test skips with its reason).
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["CUTS", "SHARED", "data_dir", "require_full"]

#: the full recordings
SHARED = Path(os.environ.get("DUALPOSE_SHARED_DATA") or Path(__file__).resolve().parents[1] / ".." / "shared" / "data")
#: the cuts shipped with the tests
CUTS = Path(__file__).resolve().parent / "data"


def data_dir(name: str, *, full: bool = False) -> Path:
    """The directory of the recordings ``name`` (``"broad"``, ``"handeye"``, ``"euroc/imu_april"``, ``"tum"``):
    ``SHARED / name`` when it exists or ``full`` is true, else ``CUTS / name`` when the cut exists (else
    ``SHARED / name``, absent: the caller skips)."""
    shared = SHARED / name
    if full or shared.is_dir() or not (CUTS / name).is_dir():
        return shared
    return CUTS / name


def require_full(name: str, why: str) -> Path:
    """``data_dir(name, full=True)``, or ``pytest.skip`` saying that ``why`` needs the full recordings."""
    import pytest

    path = data_dir(name, full=True)
    if not path.is_dir():
        pytest.skip(f"{why}: needs the full recordings in {path} (tests/data has only cuts)")
    return path
