"""Diagnosis of the BROAD magnetic field as the optical reference sees it (why 9D trial 06 misses Madgwick's number).

Run ``.venv/bin/python benchmarks/diag_broad_field.py [--markdown FILE]`` (FILE is never overwritten).  Diagnostic
only: it uses the optical reference, which the filter never does.

* Field in the reference earth frame: each magnetometer sample (re-sampled by the lag that
  :func:`dualpose.calibration.sensor_time_offset.estimate_sensor_time_offset` finds from the IMU alone) rotated into
  ENU with
  the optical orientation ``opt_quat``.  For a homogeneous field and an ideal sensor this is one constant vector; its
  heading ``atan2(east, north)`` is 0 if BROAD's optical frame is aligned with magnetic north *at that place*.
  Reported at rest (before the first movement sample) and during the movement, and during the movement binned by the
  height of the IMU (``opt_pos`` z): the translation trials 10 and 15, whose orientation hardly changes (so a body-fixed
  calibration error is nearly constant), show how the field heading changes with place.
* Trial 06 over time (10 s blocks): the signed heading error (rotation of the estimate about the vertical relative to
  the reference, deg; BROAD's heading error is its absolute value) of dualpose 9D and 6D (6D after the constant
  offset of the scoring), the field heading of the reference frame, |m| and |ω|.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import dualpose as dp
from dualpose.estimation.ahrs import estimate_orientation
from dualpose.evaluation.orientation_errors import earth_error_quat, orientation_rmse
from dualpose.io import load_broad

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import emit

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"
HEIGHTS = [(0.0, 1.3), (1.3, 1.45), (1.45, 1.6), (1.6, 1.75), (1.75, 3.0)]


def field_in_reference_frame(trial, lag: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Heading (deg, 0 = north of the optical ENU frame, positive towards east), magnitude (µT) and dip (deg, below
    the horizon) of every magnetometer sample, shifted by ``lag`` s and rotated with the optical reference."""
    from dualpose.calibration.sensor_time_offset import shift_samples

    mag = shift_samples(trial.mag, trial.rate, lag) if lag else trial.mag
    m_e = dp.quat_rotate(trial.quat, mag)  # NaN where the reference is missing
    heading = np.degrees(np.arctan2(m_e[:, 0], m_e[:, 1]))
    dip = np.degrees(np.arctan2(-m_e[:, 2], np.hypot(m_e[:, 0], m_e[:, 1])))
    return heading, np.linalg.norm(mag, axis=1), dip


def signed_heading_error(q_est: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """Signed rotation (deg) about the vertical of the earth-frame error ``q_est ⊗ q_ref*`` (xyzw, (n, 4))."""
    e = earth_error_quat(q_est, q_ref)
    return np.degrees(2.0 * np.arctan2(e[:, 2], e[:, 3]))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--markdown", help="also write the tables to this new file")
    args = ap.parse_args()
    files = sorted(DATA.glob("*.mat"))
    if not files:
        print(f"no BROAD trials in {DATA}", file=sys.stderr)
        return 1
    out = ["Field of the magnetometer in BROAD's optical ENU frame (heading °, |m| µT, dip °); rest = before the first "
           "movement sample, move = movement samples:", "",
           "| trial | rest heading | rest abs(m) | rest dip | move heading (mean ± sd) | move abs(m) | move dip | "
           + " | ".join(f"heading at z {lo:.2f}–{hi:.2f} m" for lo, hi in HEIGHTS) + " |",
           "|---|" + "---:|" * (6 + len(HEIGHTS))]
    trial06 = None
    for path in files:
        t = load_broad(path)
        r9 = estimate_orientation(t.gyr, t.acc, t.mag, t.rate, use_mag=True, n_rest=t.static_start)
        heading, norm, dip = field_in_reference_frame(t, r9.mag_time_offset)
        ok = np.isfinite(heading)
        rest = ok & (np.arange(len(heading)) < t.static_start)
        move = ok & t.movement
        cells = []
        for lo, hi in HEIGHTS:
            sel = move & (t.pos[:, 2] >= lo) & (t.pos[:, 2] < hi)
            cells.append(f"{np.mean(heading[sel]):.2f} (n={sel.sum()})" if sel.sum() >= 200 else "–")
        out.append(f"| {t.name} | {np.median(heading[rest]):.2f} | {np.median(norm[rest]):.2f} | "
                   f"{np.median(dip[rest]):.2f} | {np.mean(heading[move]):.2f} ± {np.std(heading[move]):.2f} | "
                   f"{np.mean(norm[move]):.2f} | {np.mean(dip[move]):.2f} | {' | '.join(cells)} |")
        if t.name.startswith("06"):
            trial06 = (t, r9, heading, norm)
    if trial06 is not None:
        t, r9, heading, norm = trial06
        r6 = estimate_orientation(t.gyr, t.acc, None, t.rate, use_mag=False, n_rest=t.static_start)
        off = orientation_rmse(r6.quat, t.quat, t.movement, fit_heading_offset=True).heading_offset_deg
        h9 = signed_heading_error(r9.quat, t.quat)
        h6 = signed_heading_error(dp.quat_mul(dp.quat_from_rotvec([0.0, 0.0, np.radians(off)]), r6.quat), t.quat)
        rate = np.linalg.norm(t.gyr, axis=1)
        out += ["", f"Trial {t.name} in 10 s blocks (signed heading errors, °; 6D after its constant offset "
                f"{off:+.1f}°; field heading and abs(m) as above):", "",
                "| t (s) | movement | mean abs(ω) (rad/s) | 9D heading error | 6D heading error | field heading | "
                "abs(m) (µT) |", "|---:|---:|---:|---:|---:|---:|---:|"]
        block = int(round(10 * t.rate))
        for k in range(0, len(h9) - block // 2, block):
            s = slice(k, k + block)
            out.append(f"| {k / t.rate:.0f} | {t.movement[s].mean():.2f} | {rate[s].mean():.2f} | "
                       f"{np.nanmean(h9[s]):.2f} | {np.nanmean(h6[s]):.2f} | {np.nanmean(heading[s]):.2f} | "
                       f"{norm[s].mean():.2f} |")
    return emit("\n".join(out), args.markdown)


if __name__ == "__main__":
    sys.exit(main())
