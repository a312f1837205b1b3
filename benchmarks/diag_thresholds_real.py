"""Diagnostic: the alignment-conditioning and hand–eye credibility thresholds on many real cases (docs/refusals.md,
"The thresholds on real data").

Run ``.venv/bin/python benchmarks/diag_thresholds_real.py [--data ../shared/data] [--part align|handeye|both]``.

(1) **Alignment, known truth.**  Windows of 0.5-20 s of the real ground-truth paths (EuRoC V1_02, TUM fr2/desk),
sampled at 10 Hz, against a copy moved by a known rigid transform (a random yaw about z and a translation) with
1 cm or 5 cm of Gaussian noise (seeded): the alignment's actual rotation error is known, and each verdict of
:func:`dualpose.evaluation.align.align_positions` (refused above 0.5 rad / 30 %, warned above 0.05 rad / 5 %) is
compared with it.  A *false refusal* is a refused alignment whose actual rotation error is at most 0.05 rad (and
scale error at most 5 %); a *false acceptance* is one not refused whose actual error exceeds 0.5 rad (or 30 %);
an *unwarned poor* one is kept without a warning while its actual error exceeds 0.05 rad (or 5 %).

(2) **Alignment, real estimates.**  Windows of 1-40 s of the real estimates (``V102.txt``, ``fr2_desk_ORB.txt``)
against their ground truth.  No exact truth: each window's rotation is compared with the alignment of the whole
trajectory by the same method (drift makes long windows differ legitimately).

(3) **Hand–eye.**  The shared recordings (``handeye/``) whole, in halves and in thirds of the camera stream, against
the body stream of the same recording (true pairs), of the same recording but another window of it (the same rig,
different motion) and of the other recording (unrelated): verdict of
:func:`dualpose.calibration.calibrate_hand_eye_streams` (refused above a residual ratio of 5, doubtful above 2.5 or
below a rate correlation of 0.6).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from dualpose.calibration import calibrate_hand_eye_streams, clean_pose_stream
from dualpose.calibration.hand_eye_streams import PoseStream
from dualpose.evaluation.align import align_positions
from dualpose.evaluation.metrics import associate
from dualpose.io import read_trajectory
from dualpose.io.pose_csv import read_pose_csv

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
TUM = {  # estimate, ground truth
    "EuRoC V1_02": ("tum/V102.txt", "tum/V102_groundtruth.csv"),
    "TUM fr2/desk": ("tum/fr2_desk_ORB.txt", "tum/fr2_desk_groundtruth.txt"),
}
HANDEYE = {
    "prime_sense_1": ("prime_sense_1_camera_in_target.csv", "prime_sense_1_marker_in_vicon.csv"),
    "robot_arm_real": ("robot_arm_real_camera_in_target.csv", "robot_arm_real_hand_in_base.csv"),
}
METHODS = ("se3", "sim3", "posyaw")
WARN_RAD, REFUSE_RAD, WARN_SCALE, REFUSE_SCALE = 0.05, 0.5, 0.05, 0.30


def _verdict(reason: str) -> str:
    return "refused" if "not determined" in reason else ("warned" if reason else "kept")


def _angle(r: np.ndarray) -> float:
    """Rotation angle of a 3x3 rotation matrix (rad), by atan2."""
    c = 0.5 * (np.trace(r) - 1.0)
    s = 0.5 * np.linalg.norm([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return float(np.arctan2(s, c))


def _yaw(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _fit(ref: np.ndarray, est: np.ndarray, method: str) -> tuple[np.ndarray, float, str, float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            a = align_positions(ref, est, method, undetermined="warn")  # type: ignore[arg-type]
        except ValueError:  # the exact rank test: (nearly) collinear or coincident points
            return np.full((3, 3), np.nan), np.nan, "refused", np.inf
    assert a.conditioning is not None
    c = a.conditioning
    return a.rotation, a.scale, _verdict(c.reason), max(c.rotation_std_rad, c.scale_std if method == "sim3" else 0)


def _windows(t: np.ndarray, duration: float, count: int) -> list[np.ndarray]:
    """Up to ``count`` windows of ``duration`` s, start times evenly spread over ``t``."""
    starts = np.linspace(t[0], t[-1] - duration, count) if t[-1] - t[0] > duration else np.array([t[0]])
    return [np.flatnonzero((t >= s) & (t < s + duration)) for s in starts]


def _table_row(label: str, verdicts: list[tuple[str, str]]) -> str:
    """``verdicts``: (verdict, actual class good|poor|bad) per window."""
    n = len(verdicts)
    count = {v: sum(1 for x, _ in verdicts if x == v) for v in ("refused", "warned", "kept")}
    false_ref = sum(1 for v, c in verdicts if v == "refused" and c == "good")
    false_acc = sum(1 for v, c in verdicts if v != "refused" and c == "bad")
    unwarned = sum(1 for v, c in verdicts if v == "kept" and c != "good")
    classes = {c: sum(1 for _, x in verdicts if x == c) for c in ("good", "poor", "bad")}
    return (f"| {label} | {n} | {classes['good']}/{classes['poor']}/{classes['bad']} | {count['refused']} | "
            f"{count['warned']} | {count['kept']} | {false_ref} | {false_acc} | {unwarned} |")  # fmt: skip


ALIGN_HEADER = ("| windows | n | actual good/poor/bad | refused | warned | kept | false refusals | false acceptances | "
                "kept but actually poor |\n|---|---|---|---|---|---|---|---|---|")  # fmt: skip


def alignment_known_truth(data: Path) -> list[str]:
    rng = np.random.default_rng(24)
    rows = [ALIGN_HEADER]
    misses: list[str] = []
    for name, (_, gt_file) in TUM.items():
        gt = read_trajectory(data / gt_file)
        keep = np.concatenate(([0], np.flatnonzero(np.diff(np.floor(gt.stamps * 10.0)) > 0) + 1))  # ~10 Hz
        t, p = gt.stamps[keep], gt.positions[keep]
        for sigma in (0.01, 0.05):
            by_method: dict[str, list[tuple[str, str]]] = {m: [] for m in METHODS}
            for duration in (0.5, 1.0, 2.0, 5.0, 10.0, 20.0):
                for idx in _windows(t, duration, 25):
                    if len(idx) < 3:
                        continue
                    ref = p[idx]
                    r0, t0 = _yaw(rng.uniform(-np.pi, np.pi)), rng.normal(0.0, 5.0, 3)
                    est = ref @ r0.T + t0 + rng.normal(0.0, sigma, ref.shape)
                    for m in METHODS:
                        r, s, verdict, sd = _fit(ref, est, m)
                        err = _angle(r @ r0) if np.isfinite(r).all() else np.inf  # exact: r = r0^T
                        serr = abs(s - 1.0) if m == "sim3" else 0.0
                        cls = ("bad" if err > REFUSE_RAD or serr > REFUSE_SCALE else
                               "poor" if err > WARN_RAD or serr > WARN_SCALE else "good")  # fmt: skip
                        by_method[m].append((verdict, cls))
                        wrong = {("refused", "good"), ("warned", "bad"), ("kept", "bad"), ("kept", "poor")}
                        if (verdict, cls) in wrong:
                            misses.append(f"{name}, {sigma * 100:.0f} cm, {m}, {duration:g} s ({len(idx)} poses):"
                                              f" {verdict}, sigma {sd:.3g}, actual rotation error {err:.3g} rad, "
                                              f"scale error {serr:.3g}")  # fmt: skip
            for m in METHODS:
                rows.append(_table_row(f"{name}, {sigma * 100:.0f} cm noise, {m}", by_method[m]))
    return rows + ["", "Each false verdict:", *(f"- {x}" for x in misses)]


def alignment_real_estimates(data: Path) -> list[str]:
    rows = ["| windows | n | refused | warned | kept | kept, > 0.5 rad off the whole-run alignment | refused, "
            "< 0.05 rad off it | median angle off it (kept / warned / refused) [rad] |",
            "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for name, (est_file, gt_file) in TUM.items():
        est, gt = read_trajectory(data / est_file), read_trajectory(data / gt_file)
        i_ref, i_est = associate(gt.stamps, est.stamps, 0.02)
        ref_p, est_p, t = gt.positions[i_ref], est.positions[i_est], est.stamps[i_est]
        order = np.argsort(t)
        ref_p, est_p, t = ref_p[order], est_p[order], t[order]
        for m in METHODS:
            r_all = _fit(ref_p, est_p, m)[0]
            res: list[tuple[str, float]] = []
            for duration in (1.0, 2.0, 5.0, 10.0, 20.0, 40.0):
                for idx in _windows(t, duration, 20):
                    if len(idx) < 3:
                        continue
                    r, _, verdict, _ = _fit(ref_p[idx], est_p[idx], m)
                    res.append((verdict, _angle(r @ r_all.T)))
            by = {v: [a for x, a in res if x == v] for v in ("kept", "warned", "refused")}
            finite = {v: [a for a in by[v] if np.isfinite(a)] for v in by}  # NaN: refused by the exact rank test
            med = " / ".join(f"{np.median(finite[v]):.3g}" if finite[v] else "–" for v in ("kept", "warned", "refused"))
            rank = len(by["refused"]) - len(finite["refused"])
            rows.append(f"| {name}, {m} | {len(res)} | {len(by['refused'])} ({rank} by the rank test) | "
                        f"{len(by['warned'])} | {len(by['kept'])} "
                        f"| {sum(a > REFUSE_RAD for a in by['kept'])} | {sum(a < WARN_RAD for a in by['refused'])} "
                        f"| {med} |")  # fmt: skip
    return rows


def _cut(s: PoseStream, lo: float, hi: float) -> PoseStream:
    k = (s.stamps >= lo) & (s.stamps <= hi)
    return PoseStream(s.stamps[k], s.positions[k], s.quats[k], s.name)


def _pieces(s: PoseStream, parts: int) -> list[tuple[float, float]]:
    edges = np.linspace(s.stamps[0], s.stamps[-1], parts + 1)
    return [(float(a), float(b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]


def _hand_eye(label: str, kind: str, cam: PoseStream, body: PoseStream) -> tuple[str, str, str]:
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            r = calibrate_hand_eye_streams(cam, body)
        except ValueError as exc:
            line = f"| {label} | {kind} | – | – | – | – | refused before solving: {str(exc)[:80]} |"
            return line, kind, "error"
    verdict = r.credibility.split(":")[0]
    line = (f"| {label} | {kind} | {r.rotation_rmse_deg:.3f} | {r.expected_rotation_rmse_deg:.3f} | "
            f"{r.residual_to_noise:.2f} | {r.coarse_correlation:.2f} | {verdict} ({time.perf_counter() - t0:.0f} s) |")
    return line, kind, verdict


def hand_eye(data: Path) -> list[str]:
    streams = {k: tuple(clean_pose_stream(*read_pose_csv(data / "handeye" / f), f)[0] for f in v)
               for k, v in HANDEYE.items()}  # fmt: skip
    rows = ["| camera stream | pairing | residual [deg] | expected [deg] | ratio | rate correlation | verdict |",
            "|---|---|---|---|---|---|---|"]
    results: list[tuple[str, str]] = []

    def run(label: str, kind: str, cam: PoseStream, body: PoseStream) -> None:
        line, k, v = _hand_eye(label, kind, cam, body)
        rows.append(line)
        results.append((k, v))
        print(line, flush=True)

    for name, (cam, body) in streams.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tau = calibrate_hand_eye_streams(cam, body).time_offset  # body time = camera time + tau
        other = streams[next(k for k in streams if k != name)][1]
        for parts in (1, 2, 3):
            pieces = _pieces(cam, parts)
            for i, (lo, hi) in enumerate(pieces):
                label = f"{name} {'whole' if parts == 1 else f'{i + 1}/{parts}'}"
                c = _cut(cam, lo, hi)
                run(label, "true pair", c, body)
                if parts > 1:
                    j = (i + 1) % parts
                    blo, bhi = pieces[j]
                    run(label, f"same rig, window {j + 1}/{parts} of the body", c, _cut(body, blo + tau, bhi + tau))
                run(label, "other recording's body", c, other)
    tally = ["", "| pairing | n | credible | doubtful | not credible (refused) | refused before solving |",
             "|---|---|---|---|---|---|"]
    for kind in ("true pair", "same rig", "other recording's body"):
        vs = [v for k, v in results if k.startswith(kind)]
        tally.append(f"| {kind} | {len(vs)} | {vs.count('credible')} | {vs.count('doubtful')} | "
                     f"{vs.count('not credible')} | {vs.count('error')} |")
    return rows + tally


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--data", default=str(DATA), help="the shared data directory (tum/, handeye/)")
    ap.add_argument("--part", choices=("align", "handeye", "both"), default="both")
    args = ap.parse_args(argv)
    data = Path(args.data)
    if args.part in ("align", "both"):
        print("\n".join(alignment_known_truth(data)) + "\n", flush=True)
        print("\n".join(alignment_real_estimates(data)) + "\n", flush=True)
    if args.part in ("handeye", "both"):
        print("\n".join(hand_eye(data)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
