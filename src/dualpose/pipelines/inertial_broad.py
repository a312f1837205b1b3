"""Gyro-only attitude integration on real data (BROAD) with every algorithm (docs/inertial.md §7).

:func:`broad_table` makes the markdown table of ``docs/inertial.md`` from a directory of BROAD trials
(``benchmarks/inertial_broad.py`` runs it on the shared data).

Per trial: the gyro bias is the mean rate over the static start (samples before the first ``movement`` sample);
the movement phase is cut into consecutive windows of ``window`` seconds (rounded down to a multiple of 12 samples
so that N = 1, 2, 3, 4 all end on the same sample); each window is integrated from the optical reference attitude
at its start, with increments ``Δθ_j = (ω_j − b) h`` (the rate samples held over each sample interval), and the
orientation error is the angle between the integrated and the reference attitude at the window's end.  Windows
whose reference is missing (NaN) at either end are skipped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import dualpose as dp
from dualpose.inertial.integrate import Family, integrate_attitude
from dualpose.io.broad import BroadTrial, load_broad

__all__ = ["ALGORITHMS", "window_errors", "broad_table"]

#: (label, samples, coefficients)
ALGORITHMS: tuple[tuple[str, int, Family], ...] = (
    ("1-sample", 1, "coning-optimal"),
    ("one-plus-previous", 1, "one-plus-previous"),
    ("2-sample", 2, "coning-optimal"),
    ("3-sample polynomial", 3, "polynomial"),
    ("3-sample coning-optimal", 3, "coning-optimal"),
    ("4-sample coning-optimal", 4, "coning-optimal"),
)


def window_errors(trial: BroadTrial, window: float = 10.0, remove_bias: bool = True) -> dict[str, np.ndarray]:
    """End-of-window orientation errors (degrees) per algorithm label, plus ``"spread"``: the largest angle
    between any algorithm's end attitude and the 1-sample one (degrees), one value per window."""
    n = int(window * trial.rate) // 12 * 12
    start = trial.static_start
    bias = trial.gyr[:start].mean(axis=0) if (remove_bias and start > 0) else np.zeros(3)
    h = 1.0 / trial.rate
    mov = np.flatnonzero(trial.movement)
    stop = mov[-1] + 1 if mov.size else 0
    starts = [s for s in range(start, stop - n + 1, n) if np.isfinite(trial.quat[[s, s + n]]).all()]
    out: dict[str, np.ndarray] = {label: np.zeros(0) for label, _, _ in ALGORITHMS} | {"spread": np.zeros(0)}
    if not starts:
        return {k: np.array(v) for k, v in out.items()}
    q0 = trial.quat[starts]
    inc = np.stack([(trial.gyr[s : s + n] - bias) * h for s in starts])  # (W, n, 3)
    ref = trial.quat[[s + n for s in starts]]
    ends = {}
    for label, samples, fam in ALGORITHMS:
        ends[label] = integrate_attitude(q0, inc, samples, fam)[:, -1]
        out[label] = np.degrees(dp.quat_angle(ends[label], ref))
    base = ends[ALGORITHMS[0][0]]
    out["spread"] = np.degrees(np.max([dp.quat_angle(e, base) for e in ends.values()], axis=0))
    return {k: np.asarray(v) for k, v in out.items()}


def broad_table(directory: str | Path, window: float = 10.0) -> str:
    """Markdown table: mean end-of-window error (deg) per trial and algorithm, with and without bias removal."""
    files = sorted(Path(directory).glob("*.mat"))
    if not files:
        raise FileNotFoundError(f"no BROAD .mat files in {directory}")
    labels = [a[0] for a in ALGORITHMS]
    lines = [
        "| trial | windows | bias removed | " + " | ".join(labels) + " | max spread between algorithms |",
        "|---" * (len(labels) + 4) + "|",
    ]
    for f in files:
        trial = load_broad(f)
        for remove in (True, False):
            e = window_errors(trial, window, remove)
            k = e["spread"].size
            if k == 0:
                continue
            cells = " | ".join(f"{e[lab].mean():.3f}" for lab in labels)
            lines.append(f"| {trial.name} | {k} | {'yes' if remove else 'no'} | {cells} | {e['spread'].max():.2e} |")
    return "\n".join(lines)

