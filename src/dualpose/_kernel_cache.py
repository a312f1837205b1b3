"""Keep numba's on-disk kernel cache consistent with the sources it was compiled from.

numba keys a cached kernel on the modification stamp of the file that defines it, not on the helpers it inlines
(``algebra/_kutil.py``, ``algebra/series.py``).  After an edit or a ``git pull`` that changes only a helper, numba
would load stale machine code.  Before the first kernel is loaded in a process, :func:`ensure_fresh` hashes every
dualpose source file that uses numba and, where the digest differs from the one recorded in a ``__pycache__``
directory, deletes that directory's numba cache files (``*.nbi``, ``*.nbc``) so they are rebuilt.  Costs about a
millisecond once per process; read-only installs are left alone.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

_STAMP = "dualpose-kernels.sha256"
_done = False


def source_digest(root: Path) -> str:
    """SHA-256 over the names and bytes of every ``.py`` file below ``root`` that mentions numba."""
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        data = path.read_bytes()
        if b"numba" in data:
            h.update(str(path.relative_to(root)).encode())
            h.update(data)
    return h.hexdigest()


def ensure_fresh(root: Path | None = None) -> None:
    """Invalidate numba cache files under ``root`` (default: the dualpose package) if any kernel source changed."""
    global _done
    if _done and root is None:
        return
    root = Path(__file__).parent if root is None else root
    digest = source_digest(root)
    for cache in root.rglob("__pycache__"):
        stamp = cache / _STAMP
        try:
            if stamp.exists() and stamp.read_text() == digest:
                continue
            for f in list(cache.glob("*.nbi")) + list(cache.glob("*.nbc")):
                f.unlink(missing_ok=True)
            stamp.write_text(digest)
        except OSError:
            continue
    _done = True
