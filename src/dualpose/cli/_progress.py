"""Progress reporting for long CLI commands, shared by every subcommand (``eval``, ``fuse``, ``calibrate``, ...).

On a terminal a `tqdm <https://tqdm.github.io>`_ bar is drawn on stderr; off a terminal (pipes, log files, CI)
plain lines are written instead, and only for stages that take at least ``delay`` seconds, so short runs stay
silent and stderr keeps carrying only the one-line error messages.  ``--quiet`` (``enabled=False``) switches it
off; ``enabled=True`` writes a plain line at the start and the end of every stage whatever the stream is.

Usage in a subcommand's ``run`` (the computation itself stays in :mod:`dualpose.pipelines` and below; it only
receives the optional ``callback`` of a stage)::

    from dualpose.cli._progress import Progress

    with Progress("fuse", ["read recording", "filter", "write"], enabled=False if args.quiet else None) as prog:
        with prog.stage("read recording"):
            rec = read_recording(path)
        with prog.stage("filter") as step:          # step(done, total): fraction within the stage
            result = fuse(rec, progress=step)
        with prog.stage("write"):
            write(...)

For a count of like steps (poses, Monte-Carlo runs) rather than named stages, :func:`progress_bar` gives
``with progress_bar(total, desc) as bar: bar.update(n)`` with the same rule: a tqdm bar on a terminal, one plain
line per update otherwise.

``stage(name)`` must be called in the order of the names given (a name not in the list is appended, growing the
total).  Output looks like ``dualpose fuse: [2/3] filter ... 63%`` on a terminal and
``dualpose fuse: [2/3] filter done in 12.4 s`` in a log.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Protocol, TextIO

__all__ = ["FractionSteps", "Progress", "ProgressBar", "add_quiet_argument", "progress_bar"]

StepCallback = Callable[[int, int], None]


class ProgressBar(Protocol):
    """What :func:`progress_bar` yields (a tqdm bar or plain lines): ``update(n)`` steps and a stage postfix."""

    def update(self, n: int = 1) -> object: ...
    def set_postfix_str(self, s: str) -> object: ...


def add_quiet_argument(parser: argparse.ArgumentParser) -> None:
    """Add the common ``--quiet`` flag (no progress output on stderr) to a subcommand parser."""
    parser.add_argument("--quiet", action="store_true", help="no progress output on stderr")


class Progress:
    """Named stages of one command, reported on ``stream`` (stderr).

    Parameters
    ----------
    command : str
        Subcommand name, the prefix of every plain line (``dualpose <command>: ...``).
    stages : sequence of str
        The stage names in order (their count is the ``n`` of ``[k/n]``).
    stream : text stream, optional
        Defaults to ``sys.stderr`` (looked up when the object is made, so pytest's capture works).
    enabled : bool or None
        None: a tqdm bar on a terminal, plain lines for slow stages otherwise; True: plain lines for every stage;
        False: silent.
    delay : float
        Seconds a stage must take before it is reported off a terminal with ``enabled=None`` (also tqdm's
        ``delay`` on a terminal).
    """

    def __init__(
        self,
        command: str,
        stages: Sequence[str],
        *,
        stream: TextIO | None = None,
        enabled: bool | None = None,
        delay: float = 1.0,
    ) -> None:
        self.command = command
        self.stages = list(stages)
        self.stream = sys.stderr if stream is None else stream
        self.delay = float(delay)
        self._k = 0
        self._bar = None
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            tty = bool(isatty and isatty())
            self._mode = "bar" if tty else "slow"
        else:
            self._mode = "all" if enabled else "off"
        if self._mode == "bar":
            try:
                from tqdm import tqdm
            except ImportError:  # pragma: no cover - tqdm is a dependency
                self._mode = "slow"
            else:
                self._bar = tqdm(
                    total=len(self.stages),
                    file=self.stream,
                    desc=f"dualpose {command}",
                    delay=self.delay,
                    leave=False,
                    bar_format="{desc} [{elapsed}]",
                )

    def _line(self, text: str) -> None:
        try:
            print(f"dualpose {self.command}: {text}", file=self.stream, flush=True)
        except (OSError, ValueError):  # closed or broken stderr: progress is never worth a traceback
            self._mode = "off"

    @contextmanager
    def stage(self, name: str) -> Iterator[StepCallback]:
        """Run one stage; yields ``step(done, total)`` for progress inside it (may be ignored)."""
        if name not in self.stages[self._k :]:
            self.stages.insert(self._k, name)
            if self._bar is not None:
                self._bar.total = len(self.stages)
        else:
            self.stages.remove(name)
            self.stages.insert(self._k, name)
        self._k += 1
        head = f"[{self._k}/{len(self.stages)}] {name}"
        t0 = time.perf_counter()
        if self._mode == "all":
            self._line(f"{head} ...")
        if self._bar is not None:
            self._bar.set_description_str(f"dualpose {self.command}: {head}", refresh=True)

        def step(done: int, total: int) -> None:
            if self._bar is not None and total > 0:
                self._bar.set_description_str(f"dualpose {self.command}: {head} {100.0 * done / total:.0f}%")

        yield step
        dt = time.perf_counter() - t0
        if self._bar is not None:
            self._bar.update(1)
        if self._mode == "all" or (self._mode == "slow" and dt >= self.delay):
            self._line(f"{head} done in {dt:.1f} s")

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _PlainBar:
    """One line per update on stderr: ``desc: done/total [stage]``."""

    def __init__(self, total: int, desc: str) -> None:
        self.total, self.desc, self.n, self.stage = int(total), desc, 0, ""

    def update(self, n: int = 1) -> None:
        self.n += n
        suffix = f" {self.stage}" if self.stage else ""
        print(f"{self.desc}: {self.n}/{self.total}{suffix}", file=sys.stderr, flush=True)

    def set_postfix_str(self, s: str) -> None:
        self.stage = s


@contextmanager
def progress_bar(total: int, desc: str) -> Iterator[ProgressBar]:
    """A progress bar of ``total`` steps labelled ``desc``; the object has ``update(n=1)`` and ``set_postfix_str``.

    tqdm on a terminal, plain lines otherwise (see the module docstring).
    """
    if sys.stderr.isatty():
        from tqdm import tqdm

        bar = tqdm(total=total, desc=desc, file=sys.stderr, leave=True)
        try:
            yield bar
        finally:
            bar.close()
        return
    yield _PlainBar(total, desc)


class FractionSteps:
    """A ``progress(frac[, stage])`` callback (the completed fraction, 0..1, of a pipeline job) that advances
    ``bar`` (from :func:`progress_bar`, or None for no output) in ``steps`` equal steps; ``stage`` becomes the
    bar's postfix."""

    def __init__(self, bar: ProgressBar | None, steps: int) -> None:
        self.bar, self.steps, self.done = bar, int(steps), 0

    def __call__(self, frac: float, stage: str | None = None) -> None:
        k = min(int(self.steps * min(max(frac, 0.0), 1.0) + 1e-9), self.steps)
        if self.bar is not None and k > self.done:
            if stage is not None:
                self.bar.set_postfix_str(stage)
            self.bar.update(k - self.done)
            self.done = k
