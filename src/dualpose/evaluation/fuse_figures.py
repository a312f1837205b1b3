"""The figures of ``dualpose fuse --out DIR``: the path, the errors with the filter's 3σ bounds, the NIS.

Every figure has a title, units on its axes and its legend outside the data (right of the axes, saved with a tight
bounding box); the path is drawn with equal aspect in the world plane the motion spans (the two axes of largest
extent: x–z for Hol's eight in front of the wall, x–y for a walk on the floor).  Needs matplotlib.
"""

from __future__ import annotations

import os
from typing import Any, Protocol

import numpy as np

from dualpose.types.trajectory import Trajectory

__all__ = ["fuse_figures", "motion_plane"]

_OUTSIDE = {"loc": "upper left", "bbox_to_anchor": (1.02, 1.0), "borderaxespad": 0.0}


def motion_plane(positions: np.ndarray) -> tuple[int, int]:
    """The two world axes (indices, ascending) along which ``positions`` (N, 3) extend the most."""
    extent = np.ptp(np.asarray(positions, dtype=np.float64), axis=0)
    a, b = sorted(int(i) for i in np.argsort(extent)[-2:])
    return a, b


class _FuseFigureResult(Protocol):
    """The fields of a :class:`dualpose.pipelines.fuse.FuseResult` that :func:`fuse_figures` draws."""

    @property
    def estimate(self) -> Trajectory: ...
    @property
    def truth(self) -> Trajectory | None: ...
    @property
    def metrics(self) -> dict[str, Any]: ...
    @property
    def position_error(self) -> np.ndarray | None: ...
    @property
    def orientation_error_deg(self) -> np.ndarray | None: ...
    @property
    def position_sigma(self) -> np.ndarray: ...
    @property
    def orientation_sigma_deg(self) -> np.ndarray | None: ...
    @property
    def nis(self) -> np.ndarray: ...
    @property
    def nis_accepted(self) -> np.ndarray: ...
    @property
    def nis_bounds(self) -> tuple[float, float]: ...
    @property
    def smoothed(self) -> Trajectory | None: ...
    @property
    def smoothed_position_error(self) -> np.ndarray | None: ...
    @property
    def smoothed_orientation_error_deg(self) -> np.ndarray | None: ...
    @property
    def error_index(self) -> np.ndarray | None: ...


def fuse_figures(result: _FuseFigureResult, top_view: str | os.PathLike[str], errors: str | os.PathLike[str],
                 nis: str | os.PathLike[str]) -> None:  # fmt: skip
    """Write the three PNG figures of a :class:`dualpose.pipelines.fuse.FuseResult` (any object with its fields)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    truth = result.truth
    has_truth = truth is not None
    truth_label = "reference" if result.metrics.get("reference") else "truth"  # target tracking: another camera
    name = result.metrics["filter"]
    # a result with a truth has its matched per-pose errors (FuseResult)
    idx = result.error_index if result.error_index is not None else np.arange(len(result.estimate))
    t = truth.stamps if truth is not None else result.estimate.stamps
    t = t - t[0]

    ref = truth.positions if truth is not None else result.estimate.positions
    i, j = motion_plane(ref)
    axes = "xyz"
    fig, ax = plt.subplots(figsize=(7, 5))
    if truth is not None:
        ax.plot(truth.positions[:, i], truth.positions[:, j], "k-", lw=1.5, label=truth_label)
    ax.plot(result.estimate.positions[:, i], result.estimate.positions[:, j], "r--", lw=1.0, label="estimate")
    if result.smoothed is not None:
        ax.plot(result.smoothed.positions[:, i], result.smoothed.positions[:, j], "g:", lw=1.0, label="smoothed")
    ax.plot(ref[0, i], ref[0, j], "ko", ms=5, label="start")
    ax.set(xlabel=f"{axes[i]} [m]", ylabel=f"{axes[j]} [m]", aspect="equal",
           title=f"path in the world {axes[i]}-{axes[j]} plane ({name})")  # fmt: skip
    ax.grid(alpha=0.3)
    ax.legend(**_OUTSIDE)
    fig.savefig(top_view, dpi=100, bbox_inches="tight")
    plt.close(fig)

    fig, axs = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    for k, comp in enumerate("xyz"):
        s3 = 3e3 * result.position_sigma[idx, k]
        if result.position_error is not None:
            axs[k].plot(t, 1e3 * result.position_error[:, k], "b-", lw=0.8, label="error")
            if result.smoothed_position_error is not None:
                axs[k].plot(t, 1e3 * result.smoothed_position_error[:, k], "g-", lw=0.8, label="smoothed")
        axs[k].fill_between(t, -s3, s3, color="0.8", label="±3σ (filter)")
        axs[k].set_ylabel(f"{comp} error [mm]")
    axs[0].legend(**_OUTSIDE)
    if result.orientation_error_deg is not None:
        axs[3].plot(t, result.orientation_error_deg, "b-", lw=0.8, label="attitude error")
        if result.smoothed_orientation_error_deg is not None:
            axs[3].plot(t, result.smoothed_orientation_error_deg, "g-", lw=0.8, label="smoothed")
    if result.orientation_sigma_deg is not None:
        axs[3].plot(t, 3 * result.orientation_sigma_deg[idx], "k--", lw=0.8, label="3σ (filter)")
    axs[3].set(ylabel="attitude error [deg]", xlabel="time since the first sample [s]")
    if axs[3].get_legend_handles_labels()[0]:
        axs[3].legend(**_OUTSIDE)
    title = "position and attitude errors" if has_truth else "no ground truth: the filter's 3σ bounds only"
    axs[0].set_title(f"{title} ({name})")
    fig.savefig(errors, dpi=100, bbox_inches="tight")
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(9, 4))
    kn = np.arange(len(result.nis))
    acc = result.nis_accepted
    ax.semilogy(kn[acc], result.nis[acc], ".", ms=2, label="NIS (accepted)")
    if np.any(~acc):
        ax.semilogy(kn[~acc], result.nis[~acc], "rx", ms=4, label="NIS (rejected)")
    lo, hi = result.nis_bounds
    ax.axhline(lo, color="k", ls="--", label="95% χ²(2) bounds")
    ax.axhline(hi, color="k", ls="--")
    inside = result.metrics["nis_fraction_inside"]
    ax.set(xlabel="correspondence update [count]", ylabel="NIS [dimensionless]",
           title=f"normalised innovation squared ({name}), {inside:.1%} inside")  # fmt: skip
    ax.legend(**_OUTSIDE)
    fig.savefig(nis, dpi=100, bbox_inches="tight")
    plt.close(fig)
