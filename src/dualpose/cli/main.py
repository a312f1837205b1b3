"""``dualpose`` console script.

Each subcommand lives in its own module under :mod:`dualpose.cli` and exposes two functions:
``add_parser(subparsers) -> argparse.ArgumentParser`` and ``run(args) -> int``.  Registering a new subcommand is one
line in :data:`SUBCOMMANDS`; the modules import nothing heavy at module level: their computations are imported in
``run`` from :mod:`dualpose.pipelines` and the layers below.

Exit status: 0 success, 1 bad data (a file that cannot be read or evaluated), 2 usage errors (argparse), 130
(128 + SIGINT) on Ctrl-C, the normal way to stop ``--stream``: quietly, with every line already written kept, and 141
(128 + SIGPIPE, what a C tool killed by SIGPIPE reports) when the reader of stdout goes away, as in
``dualpose eval R E --json | head -3``: the output is cut short quietly, without a ``BrokenPipeError`` traceback.

The standard streams are made safe before a command runs (:func:`guard_standard_streams`): a closed standard input
reads as empty, a closed standard output or error writes nowhere, and characters the output's encoding cannot carry
(``σ``, ``≈`` or a file name on a ``cp1252`` / ``ascii`` terminal) are written as backslash escapes (``σ`` as
``\\u03c3``) instead of raising ``UnicodeEncodeError``.

Messages are one line each (:func:`one_line_warnings`): a warning that reaches the entry point (a NumPy
``RuntimeWarning`` a command did not turn into its own message) is printed as ``dualpose CMD: warning: TEXT``, without
the source line Python shows by default, and an exception no command expected as
``dualpose CMD: error: internal error (TYPE: TEXT)`` with exit status 1 (``DUALPOSE_TRACEBACK=1`` shows the
traceback instead, for a bug report).
"""

from __future__ import annotations

import argparse
import io
import os
import sys
import warnings
from types import ModuleType
from typing import TextIO

from dualpose.cli import ahrs, calibrate, demo, eval, fuse, register, reproduce

#: subcommand modules, in the order ``dualpose --help`` lists them
SUBCOMMANDS: tuple[ModuleType, ...] = (demo, register, reproduce, eval, fuse, ahrs, calibrate)


def build_parser() -> argparse.ArgumentParser:
    from dualpose import __version__

    parser = argparse.ArgumentParser(prog="dualpose", description="Rigid-body pose with (dual) quaternions.")
    parser.add_argument("--version", action="version", version=f"dualpose {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for module in SUBCOMMANDS:
        module.add_parser(sub).set_defaults(_run=module.run)
    return parser


#: exit status when stdout is a closed pipe (128 + SIGPIPE)
EXIT_BROKEN_PIPE = 141
#: exit status on Ctrl-C (128 + SIGINT)
EXIT_INTERRUPTED = 130


def guard_standard_streams() -> None:
    """Make the standard streams safe to use: a stream the process was started without (``<&-``, ``>&-``: Python
    sets it to ``None``) is replaced by an empty input or a sink, and text the output encoding cannot carry is
    written with backslash escapes."""
    if sys.stdin is None:
        sys.stdin = io.StringIO("")
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if stream is None:
            setattr(sys, name, open(os.devnull, "w", encoding="utf-8"))  # a sink for the life of the process
        elif isinstance(stream, io.TextIOWrapper) and stream.errors == "strict":
            stream.reconfigure(errors="backslashreplace")


def _command(argv: list[str] | None) -> str:
    """``dualpose`` and the subcommand named in ``argv`` (or ``sys.argv``), for messages."""
    words = sys.argv[1:] if argv is None else argv
    names = {m.__name__.rsplit(".", 1)[-1] for m in SUBCOMMANDS}
    sub = next((w for w in words if w in names), None)
    return "dualpose" if sub is None else f"dualpose {sub}"


def one_line_warnings(prog: str) -> None:
    """Print every warning that reaches the default handler as one line ``PROG: warning: TEXT`` on stderr (the
    handler stays until :func:`main` returns)."""

    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: TextIO | None = None, line: str | None = None) -> None:  # fmt: skip
        text = " ".join(str(message).split())
        kind = "" if category is UserWarning else f" ({category.__name__})"
        try:
            print(f"{prog}: warning: {text}{kind}", file=sys.stderr if file is None else file)
        except (OSError, ValueError):
            pass

    warnings.showwarning = show


def main(argv: list[str] | None = None) -> int:
    guard_standard_streams()
    prog = _command(argv)
    shown = warnings.showwarning
    one_line_warnings(prog)
    try:
        return _main(argv, prog)
    finally:
        warnings.showwarning = shown


def _main(argv: list[str] | None, prog: str) -> int:
    try:
        args = build_parser().parse_args(argv)
        code = int(args._run(args))
        sys.stdout.flush()  # a broken pipe shows up here for buffered output
        return code
    except BrokenPipeError:
        # Point stdout at /dev/null so that the interpreter's final flush does not raise again
        # (https://docs.python.org/3/library/signal.html#note-on-sigpipe).
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError):  # pragma: no cover - stdout without a file descriptor
            pass
        return EXIT_BROKEN_PIPE
    except KeyboardInterrupt:
        # Ctrl-C: everything already written stays (each streamed line was flushed when written); no traceback
        try:
            sys.stdout.flush()
        except (OSError, ValueError):
            pass
        return EXIT_INTERRUPTED
    except Exception as exc:  # the last resort: one line, never a traceback (unless asked for)
        if os.environ.get("DUALPOSE_TRACEBACK"):
            raise
        text = " ".join(str(exc).split())
        print(f"{prog}: error: internal error ({type(exc).__name__}: {text}); DUALPOSE_TRACEBACK=1 shows where",
              file=sys.stderr)  # fmt: skip
        return 1


if __name__ == "__main__":
    sys.exit(main())
