"""Output of the commands: the aligned two-column tables they print (:func:`aligned_rows`), and the output sets they
write (:func:`output_directory`, :func:`output_file`): the checks (writable, not an input, not an earlier output
without ``--force``) happen when these are called, before the command computes anything; the writing itself is
:mod:`dualpose.io._output`'s (a temporary sibling renamed into place when complete, a directory with its
``manifest.json``).
"""

from __future__ import annotations

import os
import shlex
import sys
from collections.abc import Iterable

from dualpose.io._output import OutputDirectory, OutputError, OutputFile

__all__ = ["aligned_rows", "command_line", "output_directory", "output_file", "OutputError"]


def aligned_rows(rows: list[tuple[str, str]], indent: str = "") -> str:
    """``rows`` of (label, value) as lines ``{indent}{label}  {value}``, the labels padded to the longest one."""
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{indent}{name:<{width}}  {value}" for name, value in rows)


def command_line() -> str:
    """The command line of this process as a shell would read it (``dualpose fuse --out run``), for manifests."""
    return shlex.join(["dualpose", *sys.argv[1:]])


def output_directory(
    path: str | os.PathLike[str], names: Iterable[str], force: bool, inputs: Iterable[str | None]
) -> OutputDirectory:
    """The ``--out`` directory of a command that can write ``names``; :class:`OutputError` with the reason when it
    cannot take them (see :class:`dualpose.io._output.OutputDirectory`)."""
    return OutputDirectory(path, names=names, command=command_line(), force=force, inputs=inputs, option="--out")


def output_file(path: str | os.PathLike[str], option: str, force: bool, inputs: Iterable[str | None]) -> OutputFile:
    """The output file of ``option`` (``--plot``); :class:`OutputError` with the reason when it cannot be written."""
    return OutputFile(path, force=force, inputs=inputs, option=option)
