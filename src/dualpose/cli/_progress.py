"""Progress reporting of the long-running subcommands, on stderr.

``with progress_bar(total, desc) as bar: bar.update(n)``.  On a terminal (stderr is a TTY) with ``tqdm`` installed
it draws a tqdm bar; otherwise (a log file, a pipe, CI) it writes one plain line per update, ``desc: done/total``,
never a carriage return, so logs read line by line.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["progress_bar"]


class _PlainBar:
    """One line per update on stderr: ``desc: done/total [stage]``."""

    def __init__(self, total: int, desc: str) -> None:
        self.total, self.desc, self.n = int(total), desc, 0

    def update(self, n: int = 1) -> None:
        self.n += n
        stage = getattr(self, "stage", "")
        print(f"{self.desc}: {self.n}/{self.total}" + (f" {stage}" if stage else ""), file=sys.stderr, flush=True)

    def set_postfix_str(self, s: str) -> None:
        self.stage = s


@contextmanager
def progress_bar(total: int, desc: str) -> Iterator[object]:
    """A progress bar of ``total`` steps labelled ``desc``; the object has ``update(n=1)`` (and ``set_postfix_str``).

    tqdm on a terminal, plain lines otherwise (see the module docstring).
    """
    if sys.stderr.isatty():
        try:
            from tqdm import tqdm
        except ImportError:
            pass
        else:
            bar = tqdm(total=total, desc=desc, file=sys.stderr, leave=True)
            try:
                yield bar
            finally:
                bar.close()
            return
    yield _PlainBar(total, desc)
