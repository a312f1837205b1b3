"""Figure of a trajectory evaluation: both trajectories (top and side view) and the errors over time.

Needs matplotlib (``pip install dualpose[plot]``); it is imported only when :func:`plot_evaluation` runs, with the
non-interactive Agg backend.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from dualpose.evaluation.metrics import Evaluation

__all__ = ["plot_evaluation"]


def _gapped(t: np.ndarray, *series: np.ndarray) -> list[np.ndarray]:
    """``series`` with NaN inserted where the time step exceeds max(10 x median, 1 s): lines break at tracking gaps."""
    if t.shape[0] < 3:
        return list(series)
    dt = np.diff(t)
    cut = np.flatnonzero(dt > max(10.0 * np.median(dt), 1.0)) + 1
    return [np.insert(np.asarray(y, dtype=np.float64), cut, np.nan) for y in series]


def plot_evaluation(evaluation: Evaluation, path: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
    """Draw ``evaluation`` into a figure file and return its path.

    The format follows the extension of ``path`` (``.png``, ``.pdf``, ``.svg``, ... -- whatever matplotlib
    writes); an unknown extension raises ``ValueError`` before anything is drawn.

    Panels: top view (x-y) and side view (x-z) of the reference and the aligned estimate; translation error (ATE),
    orientation error and relative pose error (translation, at each pair's second pose) vs time, each with its
    RMSE.  Lines break where the matched poses have a time gap (lost tracking).

    Raises
    ------
    FileExistsError
        When ``path`` exists and ``overwrite`` is false (nothing is drawn).
    ImportError
        When matplotlib is not installed.
    """
    p = Path(path)
    fmt = p.suffix.lower().lstrip(".")
    if p.exists() and not overwrite:
        raise FileExistsError(f"{p}: file exists; pass overwrite=True (CLI: --force) to replace it")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - exercised only without matplotlib
        raise ImportError("plotting needs matplotlib: pip install 'dualpose[plot]'") from exc
    from matplotlib.figure import Figure

    supported = Figure().canvas.get_supported_filetypes()
    if fmt not in supported:
        raise ValueError(f"{p}: unknown figure format {fmt!r}; the extension must be one of .{', .'.join(supported)}")

    ev = evaluation
    t = ev.stamps - ev.stamps[0]
    ate, ori, rpe = ev.ate_stats, ev.orientation_stats, ev.rpe_translation_stats
    s = ev.settings
    fig, ax = plt.subplot_mosaic(
        [["top", "top", "top", "side", "side", "side"], ["ate", "ate", "ori", "ori", "rpe", "rpe"]],
        figsize=(13, 8.5),
        layout="constrained",
        height_ratios=[1.4, 1.0],
    )
    for key, (a, b) in (("top", (0, 1)), ("side", (0, 2))):
        ax[key].plot(*_gapped(t, ev.positions_ref[:, a], ev.positions_ref[:, b]), "k-", lw=1.2, label="reference")
        ax[key].plot(
            *_gapped(t, ev.positions_est[:, a], ev.positions_est[:, b]),
            "-",
            color="tab:orange",
            lw=1.0,
            label="estimate (aligned)",
        )
        ax[key].set_xlabel(f"{'xyz'[a]} [m]")
        ax[key].set_ylabel(f"{'xyz'[b]} [m]")
        ax[key].grid(alpha=0.3)
    ax["top"].set_aspect("equal", adjustable="datalim")
    ax["top"].set_title(f"top view (alignment {ev.alignment.method}, scale {ev.alignment.scale:.4f})")
    ax["side"].set_title("side view")
    ax["top"].legend(loc="best")
    panels = (
        ("ate", t, ev.ate * 100.0, ate.rmse * 100.0, "tab:blue", "translation error [cm]", "ATE", "cm"),
        ("ori", t, ev.orientation_deg, ori.rmse, "tab:red", "orientation error [deg]", "orientation error", "deg"),
        (
            "rpe",
            t[ev.rpe_pairs[:, 1]],
            ev.rpe_translation * 100.0,
            rpe.rmse * 100.0,
            "tab:green",
            "translation error [cm]",
            f"RPE, delta {s.get('rpe_delta')} {s.get('rpe_unit')}",
            "cm",
        ),
    )
    for key, x, y, rmse, color, ylabel, title, unit in panels:
        ax[key].plot(*_gapped(x, x, y), "-", color=color, lw=0.8)
        ax[key].axhline(rmse, color=color, ls="--", lw=0.8, label=f"RMSE {rmse:.3g} {unit}")
        ax[key].set_xlabel("time [s]")
        ax[key].set_ylabel(ylabel)
        ax[key].set_title(title)
        ax[key].grid(alpha=0.3)
        ax[key].legend(loc="upper left")
    fig.suptitle(f"{Path(str(s.get('estimate', ''))).name} vs {Path(str(s.get('reference', ''))).name}")
    with open(p, "wb" if overwrite else "xb") as f:
        fig.savefig(f, format=fmt, dpi=110)
    plt.close(fig)
    return p
