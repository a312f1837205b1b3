"""Output of the commands: the aligned two-column tables they print (:func:`aligned_rows`), and the output locations
checked before a command computes anything: ``--out DIR`` must be a directory, or creatable, and writable, and
its files are not replaced without ``--force`` (:func:`output_files_problem`).

Permission bits do not tell the whole story (root writes to a mode 0o555 directory; ``/proc`` and read-only mounts
refuse everyone), so besides :func:`os.access` a temporary file is created and deleted in the directory (or in its
nearest existing parent when the directory does not exist yet).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from pathlib import Path

__all__ = ["aligned_rows", "output_dir_problem", "output_files_problem"]


def aligned_rows(rows: list[tuple[str, str]], indent: str = "") -> str:
    """``rows`` of (label, value) as lines ``{indent}{label}  {value}``, the labels padded to the longest one."""
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{indent}{name:<{width}}  {value}" for name, value in rows)


def _trial_write(directory: Path) -> str | None:
    if not os.access(directory, os.W_OK | os.X_OK):
        return "not writable"
    try:
        fd, name = tempfile.mkstemp(prefix=".dualpose-write-test-", dir=directory)
    except OSError as exc:
        return f"not writable ({exc.strerror or exc})"
    os.close(fd)
    try:
        os.unlink(name)
    except OSError:
        pass
    return None


def output_dir_problem(path: str | os.PathLike[str]) -> str | None:
    """None when ``path`` is a writable directory or can be created as one; otherwise a one-line message naming it."""
    out = Path(path)
    if out.exists():
        if not out.is_dir():
            return f"{out}: not a directory"
        problem = _trial_write(out)
        return None if problem is None else f"{out}: {problem}"
    parent = out.absolute().parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        return f"{out}: cannot create the directory: {parent} is not a directory"
    problem = _trial_write(parent)
    return None if problem is None else f"{out}: cannot create the directory: {parent} is {problem}"


def output_files_problem(path: str | os.PathLike[str], names: Iterable[str], force: bool) -> str | None:
    """None when ``--out path`` can take the files ``names``: :func:`output_dir_problem` finds nothing and, unless
    ``force``, none of them exists; otherwise the one-line message (``--out ...`` or ``FILE: file exists; ...``)."""
    problem = output_dir_problem(path)
    if problem is not None:
        return f"--out {problem}"
    if not force:
        for name in names:
            if (Path(path) / name).exists():
                return f"{Path(path) / name}: file exists; use --force to replace it"
    return None
