"""Speed of dualpose's algebra against numpy-quaternion, quaternionic, scipy and pytransform3d, in one process.

Run ``make bench`` (= ``.venv/bin/python benchmarks/bench_algebra.py``); ``--quick`` uses N = 100,000 for a smoke
run and ``--markdown PATH`` also writes the tables as Markdown.

Method
------
* Every batched operation runs on N elements (default 1,000,000) of float64 data in dualpose's layout.  Peer
  inputs are converted to the peer's layout and objects (wxyz arrays, ``Rotation``/``RigidTransform`` instances)
  OUTSIDE the timed region; peer results are converted back outside it too.
* Before anything is timed, each peer's result is checked against dualpose's (elementwise
  ``|a - b| <= 1e-10 (1 + |a|)``, after fixing the overall sign of quaternions / dual quaternions where the
  operation is only defined up to the double cover).  A peer that disagrees is reported and not ranked.
* Each function is called once to warm up (numba compile or cache load), then timed with ``perf_counter`` as the
  best of k calls (k >= 5, more while the time budget allows).  ``gc`` is disabled while timing.  Calls during
  which the process was descheduled (process CPU time < 95% of wall time; the machine may be shared) are
  discarded when enough undisturbed calls exist.  Peers are timed alternately with dualpose's own call, and the
  speed ratio comes from that loop.
* The floor is a fused numpy loop ``np.add(a, b, out=c)`` moving the same number of bytes as the operation's
  inputs plus its output (a, b, c each a third of them), timed interleaved with dualpose's call.
* A peer whose single call would take > 20 s at N is timed at a smaller N and scaled (marked in the table).
"""

from __future__ import annotations

import argparse
import gc
import os
import platform
import subprocess
import sys
import time
import timeit
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import dualpose as dp
import peers as pz

TOL = 1e-10
#: --markdown keeps the target file's text from this line on (notes maintained by hand)
KEEP_MARKER = "<!-- kept when the tables above are regenerated -->"
PEER_MAX_SECONDS = 20.0


# ------------------------------------------------------------------------------------------------------ inputs
def unit_quats(n: int, rng: np.random.Generator, amin: float = 0.05, amax: float = 3.0) -> np.ndarray:
    """Unit quaternions (xyzw, w > 0) with rotation angles uniform in [amin, amax] about uniform axes."""
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    th = rng.uniform(amin, amax, n)
    return np.concatenate([np.sin(th / 2)[:, None] * u, np.cos(th / 2)[:, None]], axis=1)


def rotvecs(n: int, rng: np.random.Generator, amin: float = 0.05, amax: float = 3.0) -> np.ndarray:
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u * rng.uniform(amin, amax, n)[:, None]


def _qmul_np(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    px, py, pz_, pw = p.T
    qx, qy, qz, qw = q.T
    return np.stack(
        [
            pw * qx + px * qw + py * qz - pz_ * qy,
            pw * qy - px * qz + py * qw + pz_ * qx,
            pw * qz + px * qy - py * qx + pz_ * qw,
            pw * qw - px * qx - py * qy - pz_ * qz,
        ],
        axis=1,
    )


def unit_dqs(n: int, rng: np.random.Generator, r: np.ndarray | None = None) -> np.ndarray:
    """Unit dual quaternions [real xyzw, dual xyzw], dual = ½ t (x) real, |t| ~ N(0, 1) per axis."""
    if r is None:
        r = unit_quats(n, rng)
    t = np.concatenate([rng.normal(size=(n, 3)), np.zeros((n, 1))], axis=1)
    return np.ascontiguousarray(np.concatenate([r, 0.5 * _qmul_np(t, r)], axis=1))


def twists(n: int, rng: np.random.Generator) -> np.ndarray:
    return np.ascontiguousarray(np.concatenate([rotvecs(n, rng), rng.normal(size=(n, 3))], axis=1))


def _near_identity(n: int, rng: np.random.Generator) -> np.ndarray:
    # rotations within 1.2 rad of the identity: any two are < 2.4 rad apart (shortest arc unambiguous, dot > 0)
    v = rotvecs(n, rng, 0.0, 1.2)
    th = np.linalg.norm(v, axis=1)
    return np.concatenate([np.sinc(th / (2 * np.pi))[:, None] * v / 2, np.cos(th / 2)[:, None]], axis=1)


def make_inputs(kind: str, n: int, seed: int = 12345) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    if kind == "qq":
        return {"p": unit_quats(n, rng), "q": unit_quats(n, rng)}
    if kind == "qv":
        return {"q": unit_quats(n, rng), "v": rng.normal(size=(n, 3))}
    if kind == "qgen":
        return {"q": 0.8 * rng.normal(size=(n, 4))}
    if kind == "q":
        return {"q": unit_quats(n, rng)}
    if kind == "v":
        return {"v": rotvecs(n, rng)}
    if kind == "m":
        return {"m": np.asarray(dp.matrix_from_quat(unit_quats(n, rng)))}
    if kind == "slerp":
        keys = _near_identity(n + 1, rng)
        return {"q0": keys[:-1].copy(), "q1": keys[1:].copy(), "t": rng.uniform(0.01, 0.99, n)}
    if kind == "dqdq":
        return {"a": unit_dqs(n, rng), "b": unit_dqs(n, rng)}
    if kind == "dqx":
        return {"a": unit_dqs(n, rng), "x": 2.0 * rng.normal(size=(n, 3))}
    if kind == "tw":
        return {"tw": twists(n, rng)}
    if kind == "pure":
        return {"pure": pz.twist_to_pure(twists(n, rng))}
    if kind == "dq":
        return {"a": unit_dqs(n, rng)}
    if kind == "sclerp":
        return {
            "a": unit_dqs(n, rng, _near_identity(n, rng)),
            "b": unit_dqs(n, rng, _near_identity(n, rng)),
            "t": rng.uniform(0.0, 1.0, n),
        }
    raise KeyError(kind)


def sliced(d: dict[str, np.ndarray], n: int) -> dict[str, np.ndarray]:
    return {k: np.ascontiguousarray(v[:n]) for k, v in d.items()}


# ------------------------------------------------------------------------------------------------------ timing
CLEAN = 0.95  # a sample counts only when the process had the CPU for >= 95% of its wall time


def _pick(samples: list[tuple[float, float]]) -> float:
    """Best wall time among samples during which the process was not descheduled (all samples if none was)."""
    clean = [w for w, c in samples if c >= CLEAN * w]
    return min(clean) if clean else min(w for w, _ in samples)


def best_of_pair(f: Callable[[], Any], g: Callable[[], Any] | None, min_reps: int, max_reps: int,
                 budget: float) -> tuple[float, float | None]:
    """Best-of-k ``perf_counter`` times of ``f`` (and ``g``), called alternately so both see the same machine state.

    The machine may be shared: each call's process CPU time is read too, and calls during which this process
    was descheduled (CPU < 95% of wall time) are not used when clean ones exist.  Repeats continue until
    ``min_reps`` clean samples of each exist and ``budget`` seconds have passed (at most ``max_reps`` calls or
    4x the budget).
    """
    sf: list[tuple[float, float]] = []
    sg: list[tuple[float, float]] = []
    wall, cpu = time.perf_counter, time.process_time
    start = wall()
    gc.disable()
    try:
        while len(sf) < max_reps:
            c0, t0 = cpu(), wall()
            f()
            t1, c1 = wall(), cpu()
            sf.append((t1 - t0, c1 - c0))
            if g is not None:
                c0, t0 = cpu(), wall()
                g()
                t1, c1 = wall(), cpu()
                sg.append((t1 - t0, c1 - c0))
            if len(sf) < min_reps:
                continue
            elapsed = wall() - start
            n_clean = min(sum(c >= CLEAN * w for w, c in x) for x in ((sf, sg) if g is not None else (sf,)))
            if (elapsed > budget and n_clean >= min_reps) or elapsed > 4 * budget:
                break
    finally:
        gc.enable()
    return _pick(sf), (_pick(sg) if g is not None else None)


def max_err(ours: np.ndarray, theirs: np.ndarray, sign: bool) -> float:
    a = np.asarray(ours, dtype=float)
    b = np.asarray(theirs, dtype=float).reshape(a.shape)
    if sign:  # double cover: align the peer's sign with ours (on the real quaternion part, first 4 components)
        s = np.where(np.einsum("...i,...i->...", a[..., :4], b[..., :4]) < 0, -1.0, 1.0)
        b = b * s[..., None]
    with np.errstate(invalid="ignore"):
        e = np.abs(a - b) / (1.0 + np.abs(a))
    return float(np.nanmax(np.where(np.isnan(a) & np.isnan(b), 0.0, np.where(np.isnan(e), np.inf, e))))


# ------------------------------------------------------------------------------------------------------ cases
@dataclass
class Case:
    op: str
    key: str  # peer-table key
    fn_name: str  # attribute of dualpose or of dualpose.algebra.dualquat
    args: tuple[str, ...]
    kind: str
    doubles: int  # float64 values read + written per element (the floor moves the same bytes)
    target: tuple[str, float] | None = None
    sign: bool = False
    module: str = "dualpose"


@dataclass
class PeerResult:
    name: str
    ns: float | None
    n: int
    err: float
    ok: bool
    scaled: bool
    note: str = ""
    ratio: float | None = None  # peer time / dualpose time, both from the same interleaved timing loop


@dataclass
class Row:
    op: str
    ours_ns: float | None
    floor_ns: float | None
    target: tuple[str, float] | None
    peers: list[PeerResult] = field(default_factory=list)
    note: str = ""
    unit: str = "ns"

    @property
    def ratio_floor(self) -> float | None:
        if self.ours_ns is None or self.floor_ns is None:
            return None
        return self.ours_ns / self.floor_ns

    @property
    def best(self) -> PeerResult | None:
        ok = [p for p in self.peers if p.ok and p.ns is not None]
        return min(ok, key=lambda p: p.ns) if ok else None

    @property
    def speedup(self) -> float | None:
        b = self.best
        if b is None or self.ours_ns is None:
            return None
        return b.ratio if b.ratio is not None else b.ns / self.ours_ns

    def met(self) -> str:
        if self.target is None:
            return "—"
        kind, x = self.target
        if self.ours_ns is None:
            return "n/a"
        if kind == "floor":
            v = self.ratio_floor
            return "n/a" if v is None else ("met" if v <= x else "NOT met")
        if kind == "peer":
            s = self.speedup
            return "n/a" if s is None else ("met" if 1.0 / s <= x else "NOT met")
        if kind == "speedup":
            s = self.speedup
            return "n/a" if s is None else ("met" if s >= x else "NOT met")
        if kind == "abs":
            return "met" if self.ours_ns <= x else "NOT met"
        raise ValueError(kind)

    def target_str(self) -> str:
        if self.target is None:
            return "—"
        kind, x = self.target
        if kind == "floor":
            return f"≤ {x:g}× floor"
        if kind == "peer":
            return f"≤ {x:g}× best peer"
        if kind == "speedup":
            return f"≥ {x:g}× faster than best peer"
        return f"≤ {fmt_t(x, self.unit)}"


QUAT_CASES = [
    Case("quat_mul", "quat_mul", "quat_mul", ("p", "q"), "qq", 12, ("floor", 1.2), sign=True),
    Case("quat_rotate", "quat_rotate", "quat_rotate", ("q", "v"), "qv", 10, ("floor", 1.5)),
    Case("quat_exp", "quat_exp", "quat_exp", ("q",), "qgen", 8, ("peer", 1.3)),
    Case("quat_log", "quat_log", "quat_log", ("q",), "qgen", 8, ("peer", 1.3)),
    Case("quat_from_rotvec", "quat_from_rotvec", "quat_from_rotvec", ("v",), "v", 7, None, sign=True),
    Case("rotvec_from_quat", "rotvec_from_quat", "rotvec_from_quat", ("q",), "q", 7, None),
    Case("matrix_from_quat", "matrix_from_quat", "matrix_from_quat", ("q",), "q", 13, None),
    Case("quat_from_matrix", "quat_from_matrix", "quat_from_matrix", ("m",), "m", 13, None, sign=True),
    Case("quat_slerp", "quat_slerp", "quat_slerp", ("q0", "q1", "t"), "slerp", 13, None, sign=True),
]
_DQ = "dualpose.algebra.dualquat"
DQ_CASES = [
    Case("dualquat_mul", "dualquat_mul", "dualquat_mul", ("a", "b"), "dqdq", 24, ("floor", 1.5), True, _DQ),
    Case("dualquat_transform", "dualquat_transform", "dualquat_transform", ("a", "x"), "dqx", 14, ("floor", 1.5),
         False, _DQ),
    Case("dualquat_from_twist (exp)", "dualquat_from_twist", "dualquat_from_twist", ("tw",), "tw", 14,
         ("peer", 1.3), True, _DQ),
    Case("twist_from_dualquat (log)", "twist_from_dualquat", "twist_from_dualquat", ("a",), "dq", 14,
         ("peer", 1.3), False, _DQ),
    Case("dualquat_exp (pure DQ)", "dualquat_exp", "dualquat_exp", ("pure",), "pure", 16, ("peer", 1.3), True, _DQ),
    Case("dualquat_log (pure DQ)", "dualquat_log", "dualquat_log", ("a",), "dq", 16, ("peer", 1.3), False, _DQ),
    Case("dualquat_sclerp", "dualquat_sclerp", "dualquat_sclerp", ("a", "b", "t"), "sclerp", 25,
         ("speedup", 5.0), True, _DQ),
]


def dq_module_status() -> tuple[Any, str]:
    try:
        import importlib

        mod = importlib.import_module(_DQ)
    except Exception as exc:
        return None, f"{type(exc).__name__}: {exc}"
    missing = [c.fn_name for c in DQ_CASES if not hasattr(mod, c.fn_name)]
    return mod, (f"missing {', '.join(missing)}" if missing else "")


def time_peer(peer: pz.Peer, inputs: dict[str, np.ndarray], ref: np.ndarray, ours: Callable, case: Case,
              n_full: int, budget: float, log: Callable[[str], None]) -> tuple[PeerResult, float | None]:
    """Verify ``peer`` against dualpose's result, then time it interleaved with dualpose's call on the same N.

    Returns the peer's result and dualpose's best time per element in that same loop (None when not timed).
    """
    ours_ns = None
    try:
        # tiny call first: compiles numba-based peers (quaternionic) so the pilot below measures steady state
        peer.run(*peer.prepare(sliced(inputs, 16)))
        n_pilot = max(1000, n_full // 100)
        args = peer.prepare(sliced(inputs, n_pilot))
        t0 = time.perf_counter()
        peer.run(*args)
        est = (time.perf_counter() - t0) * n_full / n_pilot
        n = n_full if est <= PEER_MAX_SECONDS else max(n_pilot, int(n_full * 2.0 / est))
        args = peer.prepare(sliced(inputs, n)) if n != n_pilot else args
        res = peer.run(*args)  # warm-up at full size, also the result that is verified
        err = max_err(ref[:n], peer.back(res), case.sign)
        del res
        ok = err <= TOL
        our_args = tuple(np.ascontiguousarray(inputs[a][:n]) for a in case.args)
        t_peer, t_ours = best_of_pair(lambda: peer.run(*args), lambda: ours(*our_args), 5 if est < 2 else 3, 50,
                                      budget)
        ours_ns = t_ours / n * 1e9
        r = PeerResult(peer.name, t_peer / n * 1e9, n, err, ok, n != n_full, peer.note, t_peer / t_ours)
    except Exception as exc:
        r = PeerResult(peer.name, None, 0, float("nan"), False, False, f"failed: {type(exc).__name__}: {exc}")
    log(f"    {r.name:<58} {fmt_ns(r.ns):>10}  err {r.err:.1e}{'' if r.ok else '  (NOT RANKED)'}"
        f"{f'  scaled from N={r.n}' if r.scaled else ''}  (dualpose alongside: {fmt_ns(ours_ns)})")
    return r, ours_ns


def run_case(case: Case, fn: Callable, n: int, budget: float, log: Callable[[str], None]) -> Row:
    log(f"  {case.op}")
    inputs = make_inputs(case.kind, n)
    args = tuple(inputs[a] for a in case.args)
    ref = fn(*args)  # warm-up (numba compile / cache load) and the reference result
    if isinstance(ref, tuple):
        ref = ref[0]
    ref = np.asarray(ref)
    length = round(n * case.doubles / 3)
    rng = np.random.default_rng(1)
    a, b = rng.random(length), rng.random(length)
    c = np.zeros(length)
    np.add(a, b, out=c)
    if case.target is not None and case.target[0] == "floor":
        # The floor writes into a preallocated array, so dualpose is timed the same way (out=); the allocating
        # call, which also pays the page faults of a fresh output, is logged alongside.
        buf = np.empty_like(ref)
        t_ours, t_floor = best_of_pair(lambda: fn(*args, out=buf), lambda: np.add(a, b, out=c), 5, 60, budget)
        t_alloc, _ = best_of_pair(lambda: fn(*args), None, 5, 60, budget)
        log(f"    {'dualpose (allocating its output)':<58} {fmt_ns(t_alloc / n * 1e9):>10}")
    else:
        t_ours, t_floor = best_of_pair(lambda: fn(*args), lambda: np.add(a, b, out=c), 5, 60, budget)
    row = Row(case.op, t_ours / n * 1e9, t_floor / n * 1e9, case.target)
    log(f"    {'dualpose':<58} {fmt_ns(row.ours_ns):>10}  floor {fmt_ns(row.floor_ns)}")
    for peer in pz.PEERS.get(case.key, []):
        if not pz.available(peer.lib):
            row.peers.append(PeerResult(peer.name, None, 0, float("nan"), False, False, "not installed"))
            continue
        row.peers.append(time_peer(peer, inputs, ref, fn, case, n, budget, log)[0])
    return row


# ---------------------------------------------------------------------------------------------- single / import
def single_call_row(log: Callable[[str], None]) -> Row:
    log("  quat_mul, one element")
    rng = np.random.default_rng(7)
    p, q = unit_quats(1, rng)[0], unit_quats(1, rng)[0]
    ref = dp.quat_mul(p, q)

    def per_call(f: Callable[[], Any]) -> float:
        f()
        number = 2000
        gc.disable()
        try:
            return min(timeit.repeat(f, number=number, repeat=9)) / number * 1e9
        finally:
            gc.enable()

    row = Row("quat_mul, one element (4,)×(4,)", per_call(lambda: dp.quat_mul(p, q)), None, ("abs", 3000.0))
    cands = []
    if pz.available("numpy-quaternion"):
        import quaternion

        a, b = quaternion.quaternion(*pz.wxyz(p)), quaternion.quaternion(*pz.wxyz(q))
        cands.append(("numpy-quaternion p*q (scalars)", lambda: a * b,
                      lambda: pz.xyzw(quaternion.as_float_array(a * b))))
    if pz.available("quaternionic"):
        import quaternionic

        qa, qb = quaternionic.array(pz.wxyz(p)), quaternionic.array(pz.wxyz(q))
        cands.append(("quaternionic p*q", lambda: qa * qb, lambda: pz.xyzw(np.asarray(qa * qb))))
    if pz.available("scipy"):
        from scipy.spatial.transform import Rotation

        ra, rb = Rotation.from_quat(p), Rotation.from_quat(q)
        cands.append(("scipy Rotation p*q", lambda: ra * rb, lambda: (ra * rb).as_quat()))
    if pz.available("pytransform3d"):
        from pytransform3d.rotations import concatenate_quaternions

        wa, wb = pz.wxyz(p), pz.wxyz(q)
        cands.append(("pt3d concatenate_quaternions", lambda: concatenate_quaternions(wa, wb),
                      lambda: pz.xyzw(concatenate_quaternions(wa, wb))))
    for name, f, back in cands:
        err = max_err(ref, back(), True)
        t = per_call(f)
        r = PeerResult(name, t, 1, err, err <= TOL, False, "", t / per_call(lambda: dp.quat_mul(p, q)))
        row.peers.append(r)
        log(f"    {name:<58} {fmt_ns(r.ns):>10}  err {err:.1e}")
    log(f"    {'dualpose':<58} {fmt_ns(row.ours_ns):>10}")
    return row


def wall(stmt: str, reps: int) -> float:
    best = float("inf")
    for _ in range(reps):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", stmt], check=True)
        best = min(best, time.perf_counter() - t0)
    return best


def import_row(log: Callable[[str], None], reps: int) -> tuple[Row, float]:
    log("  import time (fresh interpreter, wall clock)")
    bare = wall("pass", reps)
    row = Row('python -c "import dualpose"', wall("import dualpose", reps) * 1e9, None, ("abs", 0.1e9), unit="s")
    for lib, stmt in (("numpy-quaternion", "import quaternion"), ("quaternionic", "import quaternionic"),
                      ("scipy", "from scipy.spatial.transform import Rotation, RigidTransform"),
                      ("pytransform3d", "import pytransform3d.trajectories")):
        if pz.available(lib):
            row.peers.append(PeerResult(f'python -c "{stmt}"', wall(stmt, reps) * 1e9, 1, 0.0, True, False))
    log(f"    dualpose {row.ours_ns / 1e9:.3f} s (bare interpreter {bare:.3f} s)")
    return row, bare


# ------------------------------------------------------------------------------------------------------ output
def fmt_ns(x: float | None) -> str:
    if x is None:
        return "—"
    return f"{x:.1f}" if x < 1000 else f"{x:,.0f}"


def fmt_t(x: float | None, unit: str) -> str:
    if x is None:
        return "—"
    if unit == "s":
        return f"{x / 1e9:.3f} s"
    if x >= 1000:
        return f"{x / 1000:.2f} µs"
    return f"{x:.1f} ns"


def fmt_x(x: float | None) -> str:
    return "—" if x is None else f"{x:.2f}×"


def main_table(rows: list[Row]) -> list[list[str]]:
    head = ["operation", "dualpose ns/op", "floor ns/op", "dualpose/floor", "best peer", "peer ns/op",
            "peer/dualpose", "target", "met?"]
    out = [head]
    for r in rows:
        b = r.best
        if r.unit == "s":
            ours, peer_t = fmt_t(r.ours_ns, "s"), fmt_t(b.ns if b else None, "s")
        elif r.floor_ns is None:
            ours, peer_t = fmt_t(r.ours_ns, "ns"), fmt_t(b.ns if b else None, "ns")
        else:
            ours, peer_t = fmt_ns(r.ours_ns), fmt_ns(b.ns if b else None)
        name = "—" if b is None else b.name + (f" (scaled from N={b.n:,})" if b.scaled else "")
        out.append([r.op, ours, fmt_ns(r.floor_ns), fmt_x(r.ratio_floor), name, peer_t, fmt_x(r.speedup),
                    r.target_str(), r.met()])
    return out


def detail_table(rows: list[Row]) -> list[list[str]]:
    out = [["operation", "peer", "ns/op", "peer/dualpose", "N timed", "max rel. diff vs dualpose", "note"]]
    for r in rows:
        if r.unit == "s":
            continue
        for p in r.peers:
            ratio = p.ratio
            if ratio is None and p.ns is not None and r.ours_ns is not None:
                ratio = p.ns / r.ours_ns
            n = f"{p.n:,}" + (" (scaled)" if p.scaled else "") if p.n else "—"
            err = "—" if p.err != p.err else f"{p.err:.1e}" + ("" if p.ok else " MISMATCH, not ranked")
            t = fmt_ns(p.ns) if r.floor_ns is not None else fmt_t(p.ns, "ns")
            out.append([r.op, p.name, t, fmt_x(ratio), n, err, p.note])
    return out


def render_text(table: list[list[str]]) -> str:
    widths = [max(len(row[i]) for row in table) for i in range(len(table[0]))]
    lines = []
    for k, row in enumerate(table):
        lines.append("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip())
        if k == 0:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)


def render_md(table: list[list[str]]) -> str:
    esc = [[c.replace("|", "\\|") for c in row] for row in table]
    lines = ["| " + " | ".join(esc[0]) + " |", "|" + "|".join("---" for _ in esc[0]) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in esc[1:]]
    return "\n".join(lines)


def loadavg() -> str:
    try:
        with open("/proc/loadavg") as f:
            return " ".join(f.read().split()[:3])
    except OSError:
        return "unknown"


def machine() -> dict[str, str]:
    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {"cpu": cpu, "nproc": str(os.cpu_count()), "python": platform.python_version(),
            "platform": platform.platform()}


def markdown(rows: list[Row], n: int, bare: float, cmd: str, notes: list[str], load: tuple[str, str]) -> str:
    m = machine()
    v = pz.versions()
    parts = [
        "# Speed against the peers",
        "",
        f"Command: `{cmd}`  ",
        f"N = {n:,} elements per batched operation; one process; single-threaded kernels.  ",
        f"Machine: {m['cpu']}, nproc = {m['nproc']}; Python {m['python']}; {m['platform']}.  ",
        "Versions: " + ", ".join(f"{k} {val}" for k, val in v.items()) + ".  ",
        f"Load average (1, 5, 15 min) at start: {load[0]}; at end: {load[1]}.",
        "",
        render_md(main_table(rows)),
        "",
        "`dualpose/floor` is dualpose's time over the fused-loop floor `np.add(a, b, out=c)` moving the same bytes "
        "(for these rows dualpose also writes into a preallocated `out=` array, as the floor does; the allocating "
        "call is in the log); "
        "`peer/dualpose` > 1 means dualpose is faster; it is measured with the peer and dualpose timed alternately "
        "in one loop, so it can differ slightly from the quotient of the two ns/op columns.  "
        f"Bare interpreter start-up (`python -c pass`) on this machine: {bare:.3f} s.",
        "",
        "All peers (each checked against dualpose before timing):",
        "",
        render_md(detail_table(rows)),
    ]
    if notes:
        parts += ["", *[f"* {s}" for s in notes]]
    return "\n".join(parts) + "\n"


# ------------------------------------------------------------------------------------------------------ main
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="N = 100,000 and short time budgets (smoke run)")
    ap.add_argument("-n", type=int, default=None, help="elements per batched operation (default 1,000,000)")
    ap.add_argument("--markdown", metavar="PATH", help="also write the tables as Markdown to PATH")
    ap.add_argument("--only", metavar="OPS", help="comma-separated operation names to run (debugging)")
    ns = ap.parse_args(argv)
    n = ns.n or (100_000 if ns.quick else 1_000_000)
    budget = 0.3 if ns.quick else 1.5

    def log(s: str) -> None:
        print(s, file=sys.stderr, flush=True)

    m = machine()
    load0 = loadavg()
    log(f"dualpose benchmarks: N = {n:,}; {m['cpu']}, nproc = {m['nproc']}")
    notes: list[str] = []
    dq_mod, dq_problem = dq_module_status()
    cases = [(c, getattr(dp, c.fn_name)) for c in QUAT_CASES]
    if dq_mod is not None and not dq_problem:
        cases += [(c, getattr(dq_mod, c.fn_name)) for c in DQ_CASES]
    else:
        notes.append(f"Dual-quaternion rows skipped: {_DQ} not usable ({dq_problem}).")
    only = set(ns.only.split(",")) if ns.only else None
    rows: list[Row] = []
    for case, fn in cases:
        if only and case.fn_name not in only:
            continue
        try:
            rows.append(run_case(case, fn, n, budget, log))
        except Exception as exc:
            log(f"    FAILED: {type(exc).__name__}: {exc}")
            notes.append(f"{case.op}: dualpose call failed ({type(exc).__name__}: {exc}).")
            rows.append(Row(case.op, None, None, case.target, note="failed"))
    bare = 0.0
    if not only or "single" in only:
        rows.append(single_call_row(log))
    if not only or "import" in only:
        r, bare = import_row(log, 3 if ns.quick else 7)
        rows.append(r)

    load = (load0, loadavg())
    cmd = " ".join([os.path.relpath(sys.executable), "benchmarks/bench_algebra.py", *(argv or sys.argv[1:])])
    print(f"\nN = {n:,}; {m['cpu']}, nproc = {m['nproc']}; " + ", ".join(f"{k} {v}" for k, v in pz.versions().items()))
    print(f"load average at start {load[0]}, at end {load[1]}")
    print()
    print(render_text(main_table(rows)))
    print()
    print(render_text(detail_table(rows)))
    for s in notes:
        print(f"\nNOTE: {s}")
    if ns.markdown:
        text = markdown(rows, n, bare, cmd, notes, load)
        try:  # a hand-written tail after KEEP_MARKER survives regeneration
            with open(ns.markdown, encoding="utf-8") as f:
                old = f.read()
            if KEEP_MARKER in old:
                text += "\n" + old[old.index(KEEP_MARKER):]
        except OSError:
            pass
        with open(ns.markdown, "w", encoding="utf-8") as f:
            f.write(text)
        log(f"wrote {ns.markdown}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
