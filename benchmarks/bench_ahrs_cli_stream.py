"""Throughput and per-line latency of ``dualpose ahrs --stream`` through real pipes.

Run ``.venv/bin/python benchmarks/bench_ahrs_cli_stream.py`` (defaults: 9D, 10 kHz, 10 s of samples after a 1 s rest
period).  A seeded synthetic recording (rest, then a smooth rotation) is written as text lines to the standard
input of ``python -m dualpose.cli.main ahrs --stream --rate HZ`` in two modes, each a fresh process:

* ``paced``: line ``k`` is written (one ``write`` per line) at ``k / HZ`` after the first, as a sensor at HZ would;
  one loop (no threads) writes on schedule and, in between, waits on the output pipe with ``select`` and time-stamps
  every output line as it is read.  Latency of a line = read time of its output line - write time of its input
  line, for the samples after the rest period and, separately, for the rest period's from 0.5 s on (every line comes
  at its own sample; the last rest sample initialises the filter and runs it over the rest samples; the first 0.5 s
  are left out because they can include the child's start-up);
* ``flood``: all lines written as fast as the pipe takes them (a writer thread); throughput = output lines after the
  rest period / time between reading the first and the last of them.

The table (Markdown) is printed, and written to ``--markdown FILE`` if given (never overwritten).
"""

from __future__ import annotations

import argparse
import platform
import subprocess
import sys

import numpy as np

import _stream_bench
import dualpose as dp
from _common import emit


def recording(rate: float, rest_s: float, move_s: float, use_mag: bool, seed: int = 7) -> tuple[list[bytes], int]:
    """Input lines (bytes, exact reprs) of a seeded rest + rotation recording, and the rest period in samples."""
    rng = np.random.default_rng(seed)
    n_rest, n = round(rest_s * rate), round((rest_s + move_s) * rate)
    t = np.arange(n) / rate
    tm = np.clip(t - rest_s, 0.0, None)
    q = dp.quat_from_rotvec(np.stack([0.8 * np.sin(0.9 * tm), 0.6 * np.sin(1.3 * tm), 2.0 * np.sin(0.4 * tm)], 1))
    w = np.vstack([dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(q[:-1]), q[1:])) * rate, np.zeros((1, 3))])
    conj = dp.quat_conj(q)
    cols = [t, w + rng.normal(scale=0.002, size=(n, 3)), dp.quat_rotate(conj, np.tile([0.0, 0.0, 9.81], (n, 1)))]
    cols[2] = cols[2] + rng.normal(scale=0.05, size=(n, 3))
    if use_mag:
        cols.append(dp.quat_rotate(conj, np.tile([0.0, 19.0, -45.0], (n, 1))) + rng.normal(scale=0.5, size=(n, 3)))
    data = np.column_stack(cols).tolist()
    return [(", ".join(repr(x) for x in row) + "\n").encode() for row in data], n_rest


def start(rate: float, use_mag: bool, rest_s: float, baseline: bool = False) -> subprocess.Popen:
    cmd = ["dualpose", "ahrs", "--stream", "--rate", repr(rate), "--rest-seconds", repr(rest_s)]
    return _stream_bench.spawn(_stream_bench.BASELINE if baseline else cmd + ([] if use_mag else ["--no-mag"]))


def paced(
    lines: list[bytes], rate: float, n_rest: int, use_mag: bool, rest_s: float, baseline: bool = False
) -> dict[str, float]:
    """Write line k at k / rate; return latency statistics (µs) over the samples after the rest period."""
    n = len(lines)
    sent, got, behind = _stream_bench.paced(start(rate, use_mag, rest_s, baseline), lines, np.arange(n) / rate)
    if len(got) != n:
        raise RuntimeError(f"dualpose ahrs --stream wrote {len(got)} of {n} lines")
    out = {"lines_per_s": (n - n_rest - 1) / (got[-1] - got[n_rest])}
    ranges = (("all", n_rest, n), ("steady", n_rest + round(0.5 * rate), n),
              ("rest", min(round(0.5 * rate), n_rest - 1), n_rest))  # fmt: skip
    for name, first, last in ranges:
        out.update(_stream_bench.latency(sent[first:last], got[first:last], behind[first:last], name))
    out["over_1ms"] = out["all_over_1ms"]
    return out


def flood(lines: list[bytes], rate: float, n_rest: int, use_mag: bool, rest_s: float) -> dict[str, float]:
    """Write all lines as fast as the pipe takes them; return the throughput after the rest period."""
    return {"lines_per_s": _stream_bench.flood(start(rate, use_mag, rest_s), lines, n_rest, len(lines))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=10000.0, help="input rate, Hz (default 10000)")
    ap.add_argument("--seconds", type=float, default=10.0, help="seconds of samples after the rest (default 10)")
    ap.add_argument("--rest-seconds", type=float, default=1.0, help="rest period, s (default 1)")
    ap.add_argument("--no-mag", dest="mag", action="store_false", help="6D lines (default 9D)")
    ap.add_argument("--markdown", help="also write the table to this file (never overwritten)")
    args = ap.parse_args(argv)
    lines, n_rest = recording(args.rate, args.rest_seconds, args.seconds, args.mag)
    p = paced(lines, args.rate, n_rest, args.mag, args.rest_seconds)
    f = flood(lines, args.rate, n_rest, args.mag, args.rest_seconds)
    c = paced(lines, args.rate, n_rest, args.mag, args.rest_seconds, baseline=True)
    mode = "9D" if args.mag else "6D"
    out = [
        f"`dualpose ahrs --stream`, {mode}, {len(lines) - n_rest} lines after a {n_rest}-line rest period; "
        f"Python {platform.python_version()}, {platform.machine()}",
        "",
        "| mode | input | lines timed | output lines/s | latency median µs | p99 µs | max µs | writes behind |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    rows = [(p, "all", "paced, all lines after the rest period"), (p, "steady", "paced, from 0.5 s after the rest"),
            (p, "rest", "paced, rest-period lines from 0.5 s on (incl. the one that initialises the filter)")]
    rows.append((c, "steady", "paced, `cat` instead (harness and pipes alone), same lines"))
    for r, name, what in rows:
        out.append(
            f"| {what} | {args.rate:g} Hz, one write per line | {r[name + '_lines']} | {r['lines_per_s']:.0f} | "
            f"{r[name + '_median_us']:.0f} | {r[name + '_p99_us']:.0f} | {r[name + '_max_us']:.0f} | "
            f"≤ {r[name + '_behind_ms']:.2f} ms |"
        )
    n_after = len(lines) - n_rest
    out.append(f"| flood | as fast as the pipe takes it | {n_after} | {f['lines_per_s']:.0f} | – | – | – | – |")
    out += ["", f"Paced: {p['over_1ms']} of {n_after} lines after the rest period took over 1 ms."]
    return emit("\n".join(out), args.markdown)


if __name__ == "__main__":
    sys.exit(main())
