"""Figures and the output folder of a many-run job: box plots per dataset and algorithm, the Monte-Carlo NEES over
time with its χ² band, the distributions of per-run numbers; :func:`write_job_outputs` writes the tables and figures
of one job into a folder, each file atomically (:func:`dualpose.jobs.table.atomic_path`).  matplotlib is needed for
the figures only (``pip install 'dualpose[plot]'``)."""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose.jobs.table import Cell, ResultsTable, atomic_path, has_parquet

__all__ = ["box_plot", "distribution_plot", "job_output_names", "nees_plot", "write_job_outputs"]

Plot = Callable[[Path], None]


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def box_plot(
    table: ResultsTable, metric: str, path: str | os.PathLike[str], *, group: str = "dataset",
    hue: str = "algorithm", ok: Callable[[dict[str, Cell]], bool] | None = None, ylabel: str | None = None,
) -> None:  # fmt: skip
    """Box plots of ``metric`` over the runs: one cluster per ``group`` value, one box per ``hue`` value in it
    (colours and legend by ``hue``), values of the rows ``ok`` accepts; written to ``path`` (format from the
    suffix)."""
    plt = _pyplot()
    groups = list(dict.fromkeys(str(r[group]) for r in table.rows))
    hues = list(dict.fromkeys(str(r[hue]) for r in table.rows))
    width = 0.8 / max(len(hues), 1)
    fig, ax = plt.subplots(figsize=(max(5.0, 1.2 * len(groups) * max(len(hues), 1) ** 0.5 + 2.0), 4.0))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for j, h in enumerate(hues):
        data, pos = [], []
        for i, g in enumerate(groups):
            v = [float(r[metric]) for r in table.rows
                 if str(r[group]) == g and str(r[hue]) == h and (ok is None or ok(r))]  # fmt: skip
            v = [x for x in v if math.isfinite(x)]
            if v:
                data.append(v)
                pos.append(i - 0.4 + width * (j + 0.5))
        if data:
            color = colors[j % len(colors)]
            ax.boxplot(data, positions=pos, widths=width * 0.85, patch_artist=True, manage_ticks=False,
                       boxprops={"facecolor": color, "alpha": 0.6}, medianprops={"color": "black"})  # fmt: skip
            ax.plot([], [], "s", color=color, alpha=0.6, label=h)
    ax.set_xticks(range(len(groups)), groups, rotation=30 if len(groups) > 4 else 0, ha="right" if len(groups) > 4
                  else "center")  # fmt: skip
    ax.set_xlim(-0.6, len(groups) - 0.4)
    ax.set_ylabel(ylabel or metric)
    ax.set_xlabel(group)
    ax.grid(axis="y", alpha=0.3)
    if hues:
        ax.legend(title=hue, fontsize="small")
    ax.set_title(f"{ylabel or metric} over runs")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def nees_plot(
    t: ArrayLike, average_nees: ArrayLike, band: tuple[float, float], runs: int, dim: int,
    path: str | os.PathLike[str],
) -> None:  # fmt: skip
    """The Monte-Carlo average NEES (``runs`` runs, ``dim``-dimensional state) over time ``t`` (s) with its
    two-sided 95 % band and the expected value ``dim``; log scale.  ``t`` and ``average_nees``: shape (N,)."""
    t = np.asarray(t, dtype=np.float64)
    average_nees = np.asarray(average_nees, dtype=np.float64)
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8.0, 4.0))
    inside = float(np.mean((average_nees >= band[0]) & (average_nees <= band[1]))) if average_nees.size else math.nan
    ax.semilogy(t, average_nees, lw=1.0, label=f"average NEES over {runs} runs ({100 * inside:.0f} % inside)")
    ax.axhspan(band[0], band[1], color="tab:green", alpha=0.15, label=f"95 % band [{band[0]:.2f}, {band[1]:.2f}]")
    ax.axhline(dim, color="tab:green", lw=0.8, ls="--", label=f"expected ({dim})")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"NEES ({dim} dof)")
    from matplotlib.ticker import LogFormatter

    ax.yaxis.set_major_formatter(LogFormatter(labelOnlyBase=False))
    ax.yaxis.set_minor_formatter(LogFormatter(labelOnlyBase=False, minor_thresholds=(2, 0.5)))
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize="small")
    ax.set_title("Monte-Carlo NEES of the error-state filter")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def distribution_plot(
    table: ResultsTable, metrics: Sequence[tuple[str, str]], path: str | os.PathLike[str],
    ok: Callable[[dict[str, Cell]], bool] | None = None,
) -> None:  # fmt: skip
    """Histograms of per-run numbers side by side: ``metrics`` is ``(column, axis label)`` pairs."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(metrics), figsize=(3.2 * len(metrics), 3.2), squeeze=False)
    for ax, (col, label) in zip(axes[0], metrics, strict=True):
        every = np.asarray([float(r[col]) for r in table.rows if ok is None or ok(r)], dtype=np.float64)
        v: NDArray[np.float64] = every[np.isfinite(every)]
        if v.size:
            ax.hist(v, bins=min(30, max(5, int(np.sqrt(v.size)) + 1)), color="tab:blue", alpha=0.7)
            ax.axvline(float(np.median(v)), color="black", lw=1.0, label=f"median {np.median(v):.4g}")
            ax.legend(fontsize="x-small")
        ax.set_xlabel(label)
        ax.tick_params(axis="x", labelrotation=30)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("runs")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def job_output_names(figures: Sequence[str], *, parquet: bool | None = None) -> tuple[str, ...]:
    """The files :func:`write_job_outputs` writes: ``results.csv`` (+ ``results.parquet`` with pyarrow),
    ``summary.csv`` (+ ``summary.parquet``) and the figure names."""
    pq = has_parquet() if parquet is None else parquet
    names = ["results.csv", "summary.csv"] + (["results.parquet", "summary.parquet"] if pq else [])
    return (*names, *figures)


def write_job_outputs(
    out_dir: str | os.PathLike[str], table: ResultsTable, summary: ResultsTable, figures: dict[str, Plot], *,
    overwrite: bool = False,
) -> list[Path]:  # fmt: skip
    """Write the results table, the summary and the figures (``name -> plot(path)``) into ``out_dir`` (created),
    each through a temporary sibling renamed into place; returns the paths written.

    Raises
    ------
    FileExistsError
        A target exists and ``overwrite`` is False (checked for every file before anything is written).
    ImportError
        Figures asked without matplotlib (the tables are written first).
    """
    out = Path(out_dir)
    names = job_output_names(tuple(figures))
    if not overwrite:
        existing = [n for n in names if (out / n).exists()]
        if existing:
            raise FileExistsError(f"{out}: {', '.join(existing)} exist(s) (replace with overwrite=True / --force)")
    out.mkdir(parents=True, exist_ok=True)
    written = [table.write_csv(out / "results.csv", overwrite=overwrite),
               summary.write_csv(out / "summary.csv", overwrite=overwrite)]  # fmt: skip
    if "results.parquet" in names:
        written.append(table.write_parquet(out / "results.parquet", overwrite=overwrite))
        written.append(summary.write_parquet(out / "summary.parquet", overwrite=overwrite))
    for name, plot in figures.items():
        with atomic_path(out / name, overwrite=overwrite) as tmp:
            plot(tmp)
        written.append(out / name)
    return written
