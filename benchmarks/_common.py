"""Shared pieces of the benchmark scripts: best-of-k wall time, and printing / writing the Markdown report."""

from __future__ import annotations

import gc
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path


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


def write_marked_block(path: Path, table: str, begin: str, end: str) -> None:
    """Replace the generated block between the markers ``begin`` and ``end`` in ``path`` (the hand-written text
    around it is kept); without the markers the block is appended."""
    text = path.read_text() if path.exists() else ""
    block = f"{begin}\n{table}\n{end}"
    if begin in text and end in text:
        text = text[: text.index(begin)] + block + text[text.index(end) + len(end):]
    else:
        text += ("\n" if text else "") + block + "\n"
    path.write_text(text)


def print_and_mark(text: str, markdown: str | None, begin: str, end: str) -> int:
    """Print ``text`` and, with ``markdown``, write it into that page's generated block.  Returns the exit code."""
    print(text)
    if markdown:
        write_marked_block(Path(markdown), text, begin, end)
    return 0


def best_of(fn: Callable[[], object], k: int = 7) -> float:
    """Smallest wall time (s) of ``k`` calls of ``fn``, garbage collection paused."""
    return best_of_interleaved({"fn": fn}, k)["fn"]


def best_of_interleaved(fns: dict[str, Callable[[], object]], k: int = 9) -> dict[str, float]:
    """Smallest wall time (s) of each function over ``k`` rounds, each round calling every function once.

    Interleaving puts every contender under the same machine load, so their ratios hold on a shared machine.
    """
    best = dict.fromkeys(fns, float("inf"))
    gc.disable()
    try:
        for _ in range(k):
            for name, fn in fns.items():
                t0 = time.perf_counter()
                fn()
                best[name] = min(best[name], time.perf_counter() - t0)
        return best
    finally:
        gc.enable()
