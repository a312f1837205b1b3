"""Writing a streaming job's output lines (``dualpose ahrs --stream``, ``dualpose fuse --stream``).

Each string is written to standard output and flushed at once, so a reader sees a line as soon as it is known.  A
``ValueError`` from the job (a malformed input line, named by its line number) ends the stream with one line
``dualpose CMD: error: ...`` on stderr and exit status 1, after everything before it was written.  A reader that goes
away (``| head -5``) raises ``BrokenPipeError``, which :func:`dualpose.cli.main.main` turns into a quiet exit 141.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable

__all__ = ["write_flushed"]


def write_flushed(lines: Iterable[str], command: str) -> int:
    """Write and flush every string of ``lines``; the exit status (0, or 1 after a ValueError, reported on stderr
    as ``dualpose {command}: error: ...``)."""
    out = sys.stdout
    try:
        for line in lines:
            out.write(line)
            out.flush()
    except ValueError as exc:
        print(f"dualpose {command}: error: {exc}", file=sys.stderr)
        return 1
    return 0
