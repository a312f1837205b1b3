"""``dualpose eval`` on bad input: one-line errors (exit 2 usage, 1 data), warnings, plots, pipes, KITTI."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import dualpose as dp
from dualpose.cli.main import main
from dualpose.io import Trajectory, write_kitti, write_tum


def _walk(n: int, seed: int, noise: float = 0.0) -> Trajectory:
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 6.0, n)
    p = np.column_stack([np.cos(s), np.sin(1.3 * s), 0.3 * s]) + rng.normal(0, noise, (n, 3))
    q = dp.quat_from_rotvec(np.column_stack([0.1 * s, -0.2 * s, s]) + rng.normal(0, noise, (n, 3)))
    return Trajectory(100.0 + 0.1 * np.arange(n), p, q)


@pytest.fixture()
def pair(tmp_path) -> tuple[str, str]:
    ref, est = tmp_path / "ref.txt", tmp_path / "est.txt"
    write_tum(ref, _walk(200, 1))
    write_tum(est, _walk(200, 1, noise=0.01))
    return str(ref), str(est)


def _one_error_line(err: str, text: str) -> None:
    """One error line with ``text``, no traceback (other lines may be progress of slow stages)."""
    errors = [ln for ln in err.splitlines() if ln.startswith("dualpose eval: error: ")]
    assert len(errors) == 1 and text in errors[0] and "Traceback" not in err, err


def test_still_reference_is_refused_not_scored_perfect(tmp_path, capsys):
    n = 300
    rng = np.random.default_rng(2)
    ref = Trajectory(0.1 * np.arange(n), np.tile([1.0, 2.0, 3.0], (n, 1)), np.tile([0.0, 0, 0, 1], (n, 1)))
    est = Trajectory(ref.stamps, ref.positions + rng.normal(0, 0.05, (n, 3)), ref.quats)
    write_tum(tmp_path / "r.txt", ref)
    write_tum(tmp_path / "e.txt", est)
    for align in ("sim3", "se3"):
        assert main(["eval", str(tmp_path / "r.txt"), str(tmp_path / "e.txt"), "--align", align]) == 1
        _one_error_line(capsys.readouterr().err, "reference positions do not move")


def test_every_stamp_identical_is_refused(tmp_path, capsys):
    tr = _walk(100, 3)
    write_tum(tmp_path / "r.txt", tr)
    write_tum(tmp_path / "e.txt", Trajectory(np.full(100, 5.0), tr.positions, tr.quats))
    assert main(["eval", str(tmp_path / "r.txt"), str(tmp_path / "e.txt")]) == 1
    _one_error_line(capsys.readouterr().err, "stamp 5.0 s has different poses")


def test_unsorted_estimate_warns_and_equals_the_sorted_run(tmp_path, pair, capsys):
    ref, est = pair
    lines = Path(est).read_text().splitlines()
    body = lines[1:]
    order = np.random.default_rng(4).permutation(len(body))
    shuffled = tmp_path / "shuffled.txt"
    shuffled.write_text("\n".join([body[i] for i in order]) + "\n")
    assert main(["eval", ref, est, "--json"]) == 0
    want = json.loads(capsys.readouterr().out)
    assert main(["eval", ref, str(shuffled), "--json"]) == 0
    cap = capsys.readouterr()
    got = json.loads(cap.out)
    assert "dualpose eval: warning: estimate" in cap.err and "sorted them" in cap.err
    assert got["rpe_rmse_m"] == pytest.approx(want["rpe_rmse_m"], rel=1e-12)


@pytest.mark.parametrize(("ext", "magic"), [(".pdf", b"%PDF"), (".svg", b"<?xml"), (".png", b"\x89PNG")])
def test_plot_format_follows_the_extension(tmp_path, pair, capsys, ext, magic):
    ref, est = pair
    out = tmp_path / f"fig{ext}"
    assert main(["eval", ref, est, "--plot", str(out), "--quiet"]) == 0
    assert out.read_bytes().startswith(magic)


def test_plot_never_overwrites_an_input_and_unknown_extensions_are_usage_errors(tmp_path, pair, capsys):
    ref, est = pair
    before = Path(est).read_bytes()
    assert main(["eval", ref, est, "--plot", est, "--force"]) == 2
    _one_error_line(capsys.readouterr().err, "is the input file")
    assert Path(est).read_bytes() == before
    link = tmp_path / "alias.txt"
    os.symlink(ref, link)
    assert main(["eval", ref, est, "--plot", str(link), "--force"]) == 2
    capsys.readouterr()
    assert main(["eval", ref, est, "--plot", str(tmp_path / "fig.xyz")]) == 2
    _one_error_line(capsys.readouterr().err, "unknown figure format 'xyz'")


@pytest.mark.parametrize(
    ("extra", "text"),
    [
        (["--t-start", "5", "--t-end", "5"], "--t-start (5.0) must be smaller than --t-end (5.0)"),
        (["--n-align", "10", "--align", "none"], "--n-align applies to --align se3, sim3, scale or posyaw"),
        (["--n-align", "10", "--align", "origin"], "no effect with --align origin"),
        (["--max-diff", "nan"], "--max-diff must be a finite number"),
    ],
)
def test_usage_errors_exit_2(pair, capsys, extra, text):
    assert main(["eval", *pair, *extra]) == 2
    _one_error_line(capsys.readouterr().err, text)


def test_time_window(pair, capsys):
    assert main(["eval", *pair, "--t-start", "105", "--t-end", "110", "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["matched_poses"] == 51 and out["settings"]["t_start"] == 105.0
    assert main(["eval", *pair, "--t-start", "500"]) == 1
    _one_error_line(capsys.readouterr().err, "has no pose in [t_start, t_end]")


def test_huge_coordinates_give_a_clear_error(tmp_path, capsys):
    tr = _walk(50, 5)
    write_tum(tmp_path / "r.txt", Trajectory(tr.stamps * 1e300, tr.positions * 1e300, tr.quats * 1e300))
    write_tum(tmp_path / "e.txt", Trajectory(tr.stamps * 1e300, tr.positions * 1e300, tr.quats * 1e300))
    assert main(["eval", str(tmp_path / "r.txt"), str(tmp_path / "e.txt")]) == 1
    _one_error_line(capsys.readouterr().err, "overflow squared distances")


def test_kitti_pair_with_and_without_times(tmp_path, capsys):
    ref, est = _walk(120, 6), _walk(120, 6, noise=0.01)
    write_kitti(tmp_path / "ref.txt", ref)
    write_kitti(tmp_path / "est.txt", est)
    (tmp_path / "times.txt").write_text("\n".join(f"{t:.6f}" for t in ref.stamps) + "\n")
    args = ["eval", str(tmp_path / "ref.txt"), str(tmp_path / "est.txt"), "--json", "--quiet"]
    assert main(args) == 0
    by_index = json.loads(capsys.readouterr().out)
    times = str(tmp_path / "times.txt")
    assert main([*args, "--ref-times", times, "--est-times", times]) == 0
    by_times = json.loads(capsys.readouterr().out)
    assert by_index["matched_poses"] == by_times["matched_poses"] == 120
    assert by_index["ate_rmse_m"] == pytest.approx(by_times["ate_rmse_m"], rel=1e-12)
    assert by_index["settings"]["reference_format"] == "kitti"
    write_tum(tmp_path / "t.txt", ref)
    assert main(["eval", str(tmp_path / "t.txt"), str(tmp_path / "est.txt"), "--ref-times", times]) == 1
    _one_error_line(capsys.readouterr().err, "a times file is only used with KITTI pose files")


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"dualpose {dp.__version__}"


def test_closed_stdout_exits_quietly_with_141(pair):
    src = str(Path(dp.__file__).resolve().parents[1])  # the dualpose this test imported
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]))
    code = "import sys; from dualpose.cli.main import main; sys.exit(main(sys.argv[1:]))"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "eval", *pair, "--json", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    proc.stdout.close()  # the reader went away, as `| head -0` does
    err = proc.stderr.read().decode()
    assert proc.wait() == 141
    assert "Traceback" not in err and "BrokenPipeError" not in err
