"""Writing a streaming job's output lines (``dualpose ahrs --stream``, ``dualpose fuse --stream``).

Each string is written to standard output and flushed at once, so a reader sees a line as soon as it is known.  A
``ValueError`` from the job (a malformed input line, named by its line number) ends the stream with one line
``dualpose CMD: error: ...`` on stderr and exit status 1, after everything before it was written; a doubt about the
input (a gap in the stamps, a camera never used) is a ``dualpose CMD: warning: ...`` line when it is seen and exit
status 3 at the end (:data:`EXIT_DOUBTFUL`).  A reader that goes
away (``| head -5``) raises ``BrokenPipeError``, which :func:`dualpose.cli.main.main` turns into a quiet exit 141.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Iterable

__all__ = ["EXIT_DOUBTFUL", "write_flushed"]


#: the exit status of a run that completed on an input it doubts (each doubt a ``warning:`` line on stderr, and in
#: the result's ``input_doubts`` where there is a result file; docs/refusals.md)
EXIT_DOUBTFUL = 3


def write_flushed(lines: Iterable[str], command: str) -> int:
    """Write and flush every string of ``lines``; the exit status: 0, 1 after a ValueError (reported on stderr as
    ``dualpose {command}: error: ...``), or :data:`EXIT_DOUBTFUL` when the job warned about its input
    (:class:`~dualpose.types.recording.RecordingWarning`, each reported at once as ``dualpose {command}: warning:
    ...``)."""
    from dualpose.types.recording import RecordingWarning

    out = sys.stdout
    doubts = 0

    def show(message, category, *args, **kwargs) -> None:  # type: ignore[no-untyped-def]
        nonlocal doubts
        doubts += issubclass(category, RecordingWarning)
        print(f"dualpose {command}: warning: {' '.join(str(message).split())}", file=sys.stderr, flush=True)

    with warnings.catch_warnings():
        warnings.simplefilter("always", UserWarning)
        warnings.showwarning = show
        try:
            for line in lines:
                out.write(line)
                out.flush()
        except ValueError as exc:
            print(f"dualpose {command}: error: {exc}", file=sys.stderr)
            return 1
    return EXIT_DOUBTFUL if doubts else 0
