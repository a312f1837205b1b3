"""Make the small real-data cuts in ``tests/data/`` from the full recordings in ``<repo>/../shared/data``.

Run ``.venv/bin/python tests/data/make_cuts.py [--shared DIR] [--force]``; the sources, licences and what each cut
holds are in ``tests/data/README.md``.  Text files are cut by whole lines (every kept line byte-identical to the
source line); BROAD trials are cut by sample range and written with ``scipy.io.savemat`` (float64 values unchanged,
zlib-compressed MATLAB v5).  Deterministic: the same sources give the same files.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SHARED = HERE.parents[1] / ".." / "shared" / "data"

#: BROAD trials cut: the last REST_S seconds of the static start and the first MOVE_S seconds after it
BROAD_TRIALS = ("01_undisturbed_slow_rotation_A", "06_undisturbed_fast_rotation_A", "24_disturbed_tapping_A")
REST_S, MOVE_S = 4.0, 12.0
#: hand-eye stream pairs (camera, body) and the seconds kept from the camera's first pose; the body stream keeps
#: PAD_S more on each side (the two clocks differ)
HANDEYE_PAIRS = (
    ("prime_sense_1_camera_in_target.csv", "prime_sense_1_marker_in_vicon.csv"),
    ("robot_arm_real_camera_in_target.csv", "robot_arm_real_hand_in_base.csv"),
)
HANDEYE_S, PAD_S = 25.0, 1.0
#: EuRoC imu_april: seconds kept, starting START_S after the first camera frame
APRIL_START_S, APRIL_S = 10.0, 5.0
APRIL_FILES = ("imu0.csv", "cam0_aprilgrid.csv", "cam1_aprilgrid.csv")


def _lines_between(src: Path, lo: float, hi: float, scale: float) -> list[str]:
    """The comment lines and the data lines of ``src`` whose first field / ``scale`` is in [lo, hi]."""
    out = []
    for line in src.read_text().splitlines(keepends=True):
        s = line.strip()
        if not s or s.startswith("#"):
            out.append(line)
            continue
        t = float(s.split(",")[0]) / scale
        if lo <= t <= hi:
            out.append(line)
    return out


def _first_stamp(src: Path, scale: float) -> float:
    for line in src.read_text().splitlines():
        s = line.strip()
        if s and not s.startswith("#"):
            return float(s.split(",")[0]) / scale
    raise ValueError(f"{src}: no data lines")


def _write(path: Path, data: bytes | str, force: bool) -> None:
    if path.exists() and not force:
        raise FileExistsError(f"{path}: exists; --force to replace it")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data if isinstance(data, bytes) else data.encode())


def cut_broad(shared: Path, out: Path, force: bool) -> None:
    from scipy.io import loadmat, savemat

    meta = json.loads((shared / "broad" / "trials.json").read_text())
    kept = {"groups": meta["groups"], "trials": {}}
    for name in BROAD_TRIALS:
        raw = loadmat(shared / "broad" / f"{name}.mat")
        rate = float(np.asarray(raw["sampling_rate"]).ravel()[0])
        movement = np.asarray(raw["movement"]).ravel().astype(bool)
        start = int(np.argmax(movement))
        lo, hi = max(start - round(REST_S * rate), 0), start + round(MOVE_S * rate)
        fields = {k: v[lo:hi] for k, v in raw.items() if isinstance(v, np.ndarray) and v.ndim == 2 and
                  v.shape[0] == movement.shape[0]}  # fmt: skip
        fields["sampling_rate"] = raw["sampling_rate"]
        info = str(np.asarray(raw["info"]).ravel()[0]) if "info" in raw else ""
        fields["info"] = f"{info}\n[dualpose test cut: samples {lo}:{hi} of the original trial]"
        path = out / "broad" / f"{name}.mat"
        if path.exists() and not force:
            raise FileExistsError(f"{path}: exists; --force to replace it")
        path.parent.mkdir(parents=True, exist_ok=True)
        savemat(path, fields, do_compression=True)
        kept["trials"][name] = meta["trials"][name]
    _write(out / "broad" / "trials.json", json.dumps(kept, indent=2) + "\n", force)


def cut_handeye(shared: Path, out: Path, force: bool) -> None:
    for cam, body in HANDEYE_PAIRS:
        t0 = _first_stamp(shared / "handeye" / cam, 1.0)
        _write(out / "handeye" / cam, "".join(_lines_between(shared / "handeye" / cam, t0, t0 + HANDEYE_S, 1.0)),
               force)  # fmt: skip
        lines = _lines_between(shared / "handeye" / body, t0 - PAD_S, t0 + HANDEYE_S + PAD_S, 1.0)
        _write(out / "handeye" / body, "".join(lines), force)


def cut_imu_april(shared: Path, out: Path, force: bool) -> None:
    src = shared / "euroc" / "imu_april"
    t0 = _first_stamp(src / "cam0_aprilgrid.csv", 1e9) + APRIL_START_S
    for name in APRIL_FILES:
        _write(out / "euroc" / "imu_april" / name, "".join(_lines_between(src / name, t0, t0 + APRIL_S, 1e9)), force)
    _write(out / "euroc" / "imu_april" / "sensors.yaml", (src / "sensors.yaml").read_bytes(), force)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shared", type=Path, default=SHARED, help="the full recordings (default <repo>/../shared/data)")
    ap.add_argument("--out", type=Path, default=HERE, help="where the cuts go (default tests/data)")
    ap.add_argument("--force", action="store_true", help="replace existing cuts")
    args = ap.parse_args(argv)
    if not args.shared.is_dir():
        print(f"{args.shared}: no such directory (the full recordings)", file=sys.stderr)
        return 1
    cut_broad(args.shared, args.out, args.force)
    cut_handeye(args.shared, args.out, args.force)
    cut_imu_april(args.shared, args.out, args.force)
    total = sum(p.stat().st_size for p in args.out.rglob("*") if p.is_file())
    for p in sorted(args.out.rglob("*")):
        if p.is_file():
            print(f"{p.stat().st_size / 1024:9.1f} KiB  {p.relative_to(args.out)}")
    print(f"{total / 2**20:9.2f} MiB  in all")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
