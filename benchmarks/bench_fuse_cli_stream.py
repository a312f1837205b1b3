"""Throughput and per-line latency of ``dualpose fuse --stream`` through real pipes.

Run ``.venv/bin/python benchmarks/bench_fuse_cli_stream.py`` (defaults: ESKF, the simulated eight with a 10 kHz IMU
and a 30 Hz camera, 20 correspondences per frame: 6.9 s, 69 000 ``imu`` lines and 207 ``cam`` lines; the calibration
file holds the run's sensors and the static-alignment + PnP start).  The lines
(:func:`dualpose.pipelines.fuse_stream.recording_lines`) go to the standard input of ``python -m dualpose.cli.main
fuse --stream --calibration FILE`` in two modes, each a fresh process (the harness: ``_stream_bench.py``):

* ``paced``: each line is written (one ``write`` per line) at its time stamp after the first, as the sensors would,
  the first ``--lead`` (3) s after the process started (it imports numpy and scipy meanwhile); latency of an
  ``imu`` line = read time of its pose line - write time of the line;
* the imu lines that follow a cam line are also timed apart: the frame is filtered when that line arrives;
* ``flood``: all lines written as fast as the pipe takes them; throughput = pose lines / time between reading the
  first and the last of them.

``cat`` in place of dualpose, paced with the same lines, measures the harness and the pipes alone.  The table
(Markdown) is printed, and written to ``--markdown FILE`` if given (never overwritten).
"""

from __future__ import annotations

import argparse
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import _stream_bench
from _common import emit
from dualpose import sim
from dualpose.estimation import initialization
from dualpose.estimation.state import ESKF_STATE
from dualpose.io.recording import write_sensor_setup
from dualpose.pipelines.fuse_stream import recording_lines
from dualpose.types import FilterStart, ImuNoise, SensorSetup


def recording(imu_rate: float, camera_rate: float, calibration: Path) -> tuple[list[bytes], np.ndarray, np.ndarray]:
    """The input lines, their send times (s from the first) and the indices of the imu lines; writes the
    calibration file."""
    run = sim.recording_from_simulation(
        sim.simulate_eight(0, imu_noise=ImuNoise(update_rate=imu_rate), camera_rate=camera_rate), rest_seconds=0.9
    )
    x, _ = initialization.initial_state_from_run(run, 0.9)
    start = FilterStart(**{k: ESKF_STATE.get(x, k) for k in ESKF_STATE.names})
    write_sensor_setup(calibration, SensorSetup.of(run, start))
    text = recording_lines(run)
    times = np.array([float(line.split(",")[1]) for line in text])
    times[[line.startswith("cam") for line in text]] += run.time_offset
    imu = np.flatnonzero([line.startswith("imu") for line in text])
    return [line.encode() for line in text], times - times[0], imu


def start(calibration: Path, kind: str, baseline: bool = False) -> subprocess.Popen:
    cmd = ["dualpose", "fuse", "--stream", "--calibration", str(calibration), "--filter", kind]
    return _stream_bench.spawn(_stream_bench.BASELINE if baseline else cmd)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--imu-rate", type=float, default=10000.0, help="IMU rate, Hz (default 10000)")
    ap.add_argument("--camera-rate", type=float, default=30.0, help="camera rate, Hz (default 30)")
    ap.add_argument("--filter", choices=("eskf", "hol22"), default="eskf", help="filter (default eskf)")
    ap.add_argument("--lead", type=float, default=3.0,
                    help="seconds between starting the process and the first line (default 3: imports)")
    ap.add_argument("--markdown", help="also write the table to this file (never overwritten)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        cal = Path(tmp) / "calibration.json"
        lines, send_at, imu = recording(args.imu_rate, args.camera_rate, cal)
        n_imu = len(imu)
        sent, got, behind = _stream_bench.paced(start(cal, args.filter), lines, send_at, lead=args.lead)
        if len(got) != n_imu:
            raise RuntimeError(f"dualpose fuse --stream wrote {len(got)} of {n_imu} pose lines")
        steady = int(np.searchsorted(send_at[imu], 0.5))
        p = {"lines_per_s": (n_imu - 1) / (got[-1] - got[0])}
        p.update(_stream_bench.latency(sent[imu], got, behind[imu], "all"))
        p.update(_stream_bench.latency(sent[imu][steady:], got[steady:], behind[imu][steady:], "steady"))
        after_cam = np.flatnonzero([lines[i - 1].startswith(b"cam") for i in imu[1:]]) + 1  # the frame's update
        p.update(_stream_bench.latency(sent[imu][after_cam], got[after_cam], behind[imu][after_cam], "cam"))
        flood = _stream_bench.flood(start(cal, args.filter), lines, 0, n_imu)
        sent_c, got_c, behind_c = _stream_bench.paced(start(cal, args.filter, baseline=True), lines, send_at)
        c = {"lines_per_s": (len(got_c) - 1) / (got_c[-1] - got_c[0])}
        c.update(_stream_bench.latency(sent_c[imu][steady:], got_c[imu][steady:], behind_c[imu][steady:], "steady"))
    out = [
        f"`dualpose fuse --stream --filter {args.filter}`: {n_imu} imu lines at {args.imu_rate:g} Hz and "
        f"{len(lines) - n_imu} cam lines at {args.camera_rate:g} Hz (20 correspondences each); "
        f"Python {platform.python_version()}, {platform.machine()}",
        "",
        "| mode | imu lines timed | pose lines/s | latency median µs | p99 µs | max µs | writes behind | over 1 ms |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    rows = [(p, "all", "paced, all imu lines"), (p, "steady", "paced, from 0.5 s"),
            (p, "cam", "paced, the imu lines right after a cam line (the frame is filtered there)"),
            (c, "steady", "paced, `cat` instead (harness and pipes alone), from 0.5 s")]  # fmt: skip
    for r, name, what in rows:
        out.append(
            f"| {what} | {r[name + '_lines']} | {r['lines_per_s']:.0f} | {r[name + '_median_us']:.0f} | "
            f"{r[name + '_p99_us']:.0f} | {r[name + '_max_us']:.0f} | ≤ {r[name + '_behind_ms']:.2f} ms | "
            f"{r[name + '_over_1ms']} |"
        )
    out.append(f"| flood (as fast as the pipe takes it) | {n_imu} | {flood:.0f} | – | – | – | – | – |")
    return emit("\n".join(out), args.markdown)


if __name__ == "__main__":
    sys.exit(main())
