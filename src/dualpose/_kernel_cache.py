"""Keep numba's on-disk kernel cache consistent with the sources it was compiled from.

numba keys a cached kernel on the modification stamp of the file that defines it, not on the helpers it inlines
(``algebra/_kutil.py``, ``algebra/series.py``).  After an edit or a ``git pull`` that changes only a helper, numba
would load stale machine code (wrong results or a crash).  Before the first kernel is loaded in a process,
:func:`ensure_fresh` hashes every dualpose source file that uses numba and, in every cache directory whose recorded
digest differs, deletes the numba cache files (``*.nbi``, ``*.nbc``) of dualpose's modules so they are rebuilt.  Both
the default location (``__pycache__`` beside the sources) and a cache redirected with ``NUMBA_CACHE_DIR`` are
covered.  :func:`mark_fresh` records the digest right after kernels are compiled, so that later processes (e.g.
parallel test workers) load them instead of wiping and recompiling them concurrently.  Costs about a millisecond
once per process; read-only installs are left alone.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

_STAMP = "dualpose-kernels.sha256"
_done = False
_digest: str | None = None


def _numba_sources(root: Path) -> list[Path]:
    return [p for p in sorted(root.rglob("*.py")) if b"numba" in p.read_bytes()]


def source_digest(root: Path) -> str:
    """SHA-256 over the names and bytes of every ``.py`` file below ``root`` that mentions numba."""
    h = hashlib.sha256()
    for path in _numba_sources(root):
        h.update(str(path.relative_to(root)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def _cache_dirs(root: Path) -> list[Path]:
    dirs = list(root.rglob("__pycache__"))
    user_dir = os.environ.get("NUMBA_CACHE_DIR")
    if user_dir and Path(user_dir).is_dir():
        dirs += [d for d in Path(user_dir).rglob("*") if d.is_dir()]
    return dirs


def _current_digest(root: Path) -> str:
    global _digest
    if _digest is None or root != Path(__file__).parent:
        _digest = source_digest(root)
    return _digest


def _our_files(cache: Path, stems: tuple[str, ...]) -> list[Path]:
    # guvectorize kernels cache their wrapper under "guf-<module>.<name>-..."; a stale wrapper around a rebuilt
    # kernel segfaults, so those files count as ours too
    return [
        f
        for f in cache.iterdir()
        if f.suffix in (".nbi", ".nbc") and f.name.removeprefix("guf-").startswith(stems)
    ]


def ensure_fresh(root: Path | None = None) -> None:
    """Delete dualpose's numba cache files where the recorded source digest is missing or differs."""
    global _done
    if _done and root is None:
        return
    root = Path(__file__).parent if root is None else root
    digest = _current_digest(root)
    stems = tuple(f"{p.stem}." for p in _numba_sources(root))
    for cache in _cache_dirs(root):
        stamp = cache / _STAMP
        try:
            files = _our_files(cache, stems)
            if not files or (stamp.exists() and stamp.read_text() == digest):
                continue
            for f in files:
                f.unlink(missing_ok=True)
            stamp.unlink(missing_ok=True)
        except OSError:
            continue
    _done = True


def mark_fresh(root: Path | None = None) -> None:
    """Record the current digest in every cache directory holding dualpose kernels (call after compiling)."""
    root = Path(__file__).parent if root is None else root
    digest = _current_digest(root)
    stems = tuple(f"{p.stem}." for p in _numba_sources(root))
    for cache in _cache_dirs(root):
        stamp = cache / _STAMP
        try:
            if _our_files(cache, stems) and not (stamp.exists() and stamp.read_text() == digest):
                stamp.write_text(digest)
        except OSError:
            continue
