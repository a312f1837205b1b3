"""Shared output step of the benchmark scripts: print the report and write it as Markdown if asked."""

from __future__ import annotations

import os
import sys


def emit(text: str, markdown: str | None) -> int:
    """Print ``text``; write it to ``markdown`` unless that file exists (never overwritten).  Returns the exit code."""
    print(text)
    if markdown:
        if os.path.exists(markdown):
            print(f"{markdown} exists; not overwritten", file=sys.stderr)
            return 1
        with open(markdown, "w") as fh:
            fh.write(text + "\n")
    return 0
