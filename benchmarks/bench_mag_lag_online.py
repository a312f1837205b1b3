"""Accuracy and convergence of the AHRS's online (causal) magnetometer–gyroscope time offset.

Run ``.venv/bin/python benchmarks/bench_mag_lag_online.py`` (docs/broad.md, "Magnetometer–gyroscope time offset").

* Synthetic: :func:`dualpose.sim.magnetometer_lag.lagged_recording` (analytic tumbling motion, 200 Hz, 2 s rest +
  30 s motion, magnetometer sampled ``lag`` earlier; the motion starting abruptly, and smoothly over 1 s) for lags
  ±5, ±10, ±20 ms (seed ``lag_ms + 300``, as ``tests/calibration/test_sensor_time_offset.py``): the online τ̂
  after every 0.1 s block of an :class:`~dualpose.estimation.ahrs.stream.AhrsStream` (equal to the batch
  estimator's state at the same sample), its final error, the motion time after which it stays within 1.5 ms /
  1 ms of the truth, the offline (whole-recording, not causal) estimate on the same data, and the heading RMSE of
  the filter with the online, no (τ = 0) and the offline compensation.
* Cut-off: RMS error of the final online τ̂ and of the offline estimate over 6 lags × 3 seeds (``lag_ms + 100, 300,
  500``) for a 5 Hz and a 10 Hz low-pass (``dualpose.estimation.ahrs.config.MAG_LAG_CUTOFF`` and the offline
  ``cutoff``).
* BROAD: per trial, the online τ̂ after the last sample, the time of the first non-zero τ̂ (after the first sample),
  the time after which it stays within 0.5 ms of its final value, and the offline estimate.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import dualpose as dp
import dualpose.estimation.ahrs.config as ahrs_config
from dualpose.calibration.sensor_time_offset import estimate_sensor_time_offset
from dualpose.estimation.ahrs import estimate_orientation
from dualpose.estimation.ahrs.stream import AhrsStream
from dualpose.io import load_broad
from dualpose.sim.magnetometer_lag import lagged_recording

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"
LAGS_MS = (-20.0, -10.0, -5.0, 5.0, 10.0, 20.0)


def _online_track(gyr, acc, mag, rate: float, n_rest: int, block_s: float = 0.1) -> np.ndarray:
    """τ̂ (ms) after each block of ``block_s`` seconds of an AhrsStream (NaN before initialisation)."""
    s = AhrsStream(rate, n_rest=n_rest)
    k = max(1, round(block_s * rate))
    out = []
    for i in range(0, len(gyr), k):
        j = min(i + k, len(gyr))
        s.update_batch(np.arange(i, j) / rate, gyr[i:j], acc[i:j], mag[i:j])
        out.append(1e3 * s.mag_time_offset)
    return np.array(out)


def _settled_after(track: np.ndarray, target: float, tol: float, block_s: float = 0.1) -> float:
    """Time (s, end of the block) from which |track − target| < tol for good."""
    ok = np.abs(track - target) < tol
    if ok.all():
        return 0.0
    return block_s * (len(ok) - int(np.argmin(ok[::-1]))) if ok[-1] else float("nan")


def _heading_rmse_deg(quat, q_true, sel) -> float:
    e = dp.quat_mul(quat, dp.quat_conj(q_true))
    return float(np.sqrt(np.mean(np.degrees(2 * np.arctan2(np.abs(e[sel, 2]), np.abs(e[sel, 3]))) ** 2)))


def synthetic_table(ramp: float) -> list[str]:
    out = [
        "| injected lag (ms) | online τ̂ at the end (ms) | error (ms) | offline estimate (ms) | within 1.5 ms for good "
        "after (s of motion) | within 1 ms for good after (s of motion) | heading RMSE online / τ = 0 / offline (°) |",
        "|---:|---:|---:|---:|---:|---:|---|",
    ]
    for lag_ms in LAGS_MS:
        r = lagged_recording(lag_ms * 1e-3, ramp_seconds=ramp, seed=int(lag_ms) + 300)
        track = _online_track(r.gyr, r.acc, r.mag, r.rate, r.n_rest)
        rest_s = r.n_rest / r.rate
        off = estimate_sensor_time_offset(r.gyr, r.mag, r.rate, gyroscope_bias=np.median(r.gyr[: r.n_rest], axis=0))
        head = [_heading_rmse_deg(estimate_orientation(r.gyr, r.acc, r.mag, r.rate, n_rest=r.n_rest,
                                                       mag_time_offset=m).quat, r.quat, r.moving)
                for m in ("online", 0.0, "estimate")]  # fmt: skip
        settled = [_settled_after(track, lag_ms, tol) - rest_s for tol in (1.5, 1.0)]
        settled_txt = " | ".join("not at the end" if np.isnan(x) else f"{x:.1f}" for x in settled)
        out.append(f"| {lag_ms:+.0f} | {track[-1]:.2f} | {track[-1] - lag_ms:+.2f} | {off.offset_ms:.2f} | "
                   f"{settled_txt} | {head[0]:.3f} / {head[1]:.3f} / {head[2]:.3f} |")
    return out


def cutoff_table() -> list[str]:
    out = ["| low-pass cut-off | online: RMS error of the final τ̂ (ms) | offline: RMS error (ms) |", "|---:|---:|---:|"]
    keep = ahrs_config.MAG_LAG_CUTOFF
    try:
        for cut in (5.0, 10.0):
            ahrs_config.MAG_LAG_CUTOFF = cut
            on, off = [], []
            for lag_ms in LAGS_MS:
                for s in (100, 300, 500):
                    r = lagged_recording(lag_ms * 1e-3, seed=int(lag_ms) + s)
                    on.append(estimate_orientation(r.gyr, r.acc, r.mag, r.rate, n_rest=r.n_rest).mag_time_offset_ms)
                    bias = np.median(r.gyr[: r.n_rest], axis=0)
                    off.append(estimate_sensor_time_offset(r.gyr, r.mag, r.rate, gyroscope_bias=bias,
                                                           cutoff=cut).offset_ms)  # fmt: skip
            truth = np.repeat(LAGS_MS, 3)
            out.append(f"| {cut:g} Hz | {np.sqrt(np.mean((np.array(on) - truth) ** 2)):.2f} | "
                       f"{np.sqrt(np.mean((np.array(off) - truth) ** 2)):.2f} |")
    finally:
        ahrs_config.MAG_LAG_CUTOFF = keep
    return out


def broad_table() -> list[str]:
    out = ["| trial | online τ̂ at the end (ms) | movement from (s) | first τ̂ ≠ 0 at (s) | within 1 ms of the final τ̂ "
           "for good after (s) | within 0.5 ms, after (s) | length (s) | offline estimate (ms) |",
           "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for path in sorted(DATA.glob("*.mat")):
        t = load_broad(path)
        track = _online_track(t.gyr, t.acc, t.mag, t.rate, t.static_start)
        first = 0.1 * (int(np.argmax(np.nan_to_num(track) != 0.0)) + 1)
        bias = np.median(t.gyr[: t.static_start], axis=0)
        off = estimate_sensor_time_offset(t.gyr, t.mag, t.rate, gyroscope_bias=bias)
        move = int(np.argmax(t.movement)) / t.rate
        out.append(f"| {t.name} | {track[-1]:.2f} | {move:.1f} | {first:.1f} | "
                   f"{_settled_after(track, track[-1], 1.0):.1f} | {_settled_after(track, track[-1], 0.5):.1f} | "
                   f"{len(t.gyr) / t.rate:.0f} | {off.offset_ms:.2f} |")
    return out


def main() -> int:
    lines = ["Synthetic (200 Hz, 2 s rest + 30 s tumbling motion), the motion starting abruptly:", "",
             *synthetic_table(0.0), "", "The same, the motion starting smoothly (1 s ramp):", "",
             *synthetic_table(1.0), "",
             "Low-pass cut-off (6 lags × 3 seeds):", "", *cutoff_table()]
    if DATA.is_dir():
        lines += ["", "BROAD (online τ̂ read after every 0.1 s):", "", *broad_table()]
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
