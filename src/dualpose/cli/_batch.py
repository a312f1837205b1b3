"""The shared part of the many-run commands (``eval --batch``, ``ahrs --batch``, ``fuse --monte-carlo``): the
scheduler options, progress over tasks, the failed rows on stderr, the summary on stdout and the output folder
(:mod:`dualpose.jobs`; docs/scaling.md, "Many runs").

Exit status of a job: 0 when every row succeeded, 1 when some failed (each reported on stderr with its reason, the
count last; every other row completed and is in the outputs), 2 for usage errors.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from dualpose.cli._args import int_in

if TYPE_CHECKING:
    from dualpose.io._output import OutputDirectory
    from dualpose.jobs.table import Cell, JobResult, ResultsTable

__all__ = ["add_scheduler_arguments", "finish_job", "job_progress", "scheduler_of", "summary_text"]


def add_scheduler_arguments(p: argparse.ArgumentParser) -> None:
    """``--scheduler`` and ``--workers``."""
    p.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="with --batch / --monte-carlo: where the tasks run: 'processes' (default: a local pool of "
                   "worker processes, dask), 'serial' (this process), or the address of a running dask.distributed "
                   "scheduler (tcp://HOST:PORT)")  # fmt: skip
    p.add_argument("--workers", type=int_in(1, 4096), metavar="N", default=None,
                   help="worker processes of the local pool (default: the CPU count)")


def scheduler_of(args: argparse.Namespace, command: str) -> str:
    """The scheduler to use: ``--scheduler``, else ``processes`` with dask installed, else ``serial`` (said on
    stderr)."""
    from dualpose.jobs.scheduler import default_scheduler

    if args.scheduler is not None:
        return str(args.scheduler)
    kind = default_scheduler()
    if kind == "serial":
        print(f"dualpose {command}: dask is not installed (pip install 'dualpose[dask]'): running the tasks serially",
              file=sys.stderr)  # fmt: skip
    return kind


class job_progress:
    """``with job_progress(total, command, quiet) as step:`` -- ``step(done, total)`` advances a tqdm bar on a
    terminal, or writes a plain line every 5 % of the tasks (and at the last) off it."""

    def __init__(self, total: int, command: str, quiet: bool = False) -> None:
        self.total, self.command, self.quiet = int(total), command, quiet
        self._bar: object | None = None
        self._shown = 0

    def __enter__(self) -> Callable[[int, int], None]:
        if not self.quiet and sys.stderr.isatty():
            from tqdm import tqdm

            self._bar = tqdm(total=self.total, desc=f"dualpose {self.command}", file=sys.stderr, unit="task")
        every = max(1, math.ceil(self.total / 20))

        def step(done: int, total: int) -> None:
            if self.quiet:
                return
            if self._bar is not None:
                self._bar.update(done - self._shown)  # type: ignore[attr-defined]
                self._shown = done
            elif done == total or done - self._shown >= every:
                self._shown = done
                try:
                    print(f"dualpose {self.command}: {done}/{total} tasks done", file=sys.stderr, flush=True)
                except (OSError, ValueError):
                    self.quiet = True

        return step

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.close()  # type: ignore[attr-defined]


def _fmt(v: object) -> str:
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.6g}"
    return str(v)


def summary_text(summary: ResultsTable) -> str:
    """The summary table as aligned text columns."""
    columns = summary.columns
    rows = [[_fmt(r[c]) for c in columns] for r in summary.rows]
    widths = [max(len(c), *(len(r[i]) for r in rows)) if rows else len(c) for i, c in enumerate(columns)]
    n_text = sum(1 for c in columns if c in ("dataset", "algorithm", "mode", "filter", "metric"))

    def line(cells: list[str]) -> str:
        return "  ".join(v.ljust(w) if i < n_text else v.rjust(w) for i, (v, w) in enumerate(zip(cells, widths,
                                                                                                  strict=True)))

    return "\n".join([line(list(columns))] + [line(r) for r in rows])


def finish_job(
    command: str, result: JobResult, label: Callable[[dict[str, Cell]], str], out: OutputDirectory | None,
    figures: dict[str, Callable[[Path], None]],
) -> int:  # fmt: skip
    """Report the failed rows (stderr), print the summary (stdout), write the outputs into ``out`` (checked
    before the job ran; written as one set with its manifest, :mod:`dualpose.cli._output`); the exit status (0,
    or 1 with failed rows or an output that could not be written)."""
    from dualpose.jobs.figures import write_job_outputs

    table = result.table
    for row in table.rows:
        if row["status"] != "ok":
            print(f"dualpose {command}: row {row['row' if 'row' in row else 'run']} ({label(row)}): {row['error']}",
                  file=sys.stderr)  # fmt: skip
    print(summary_text(result.summary))
    code = 0
    if out is not None:
        try:
            with out.writing() as stage:
                paths = write_job_outputs(stage, table, result.summary, figures, overwrite=True)
        except (OSError, ImportError, ValueError) as exc:
            print(f"dualpose {command}: error: {exc}", file=sys.stderr)
            code = 1
        else:
            print(f"\nwritten to {out.path}: {', '.join(p.name for p in paths)}")
    if result.failed:
        print(f"dualpose {command}: {result.failed} of {len(table.rows)} rows failed "
              "(reasons above; every other row completed)", file=sys.stderr)  # fmt: skip
        return 1
    return code
