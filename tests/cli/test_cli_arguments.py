"""Numeric options, output locations and help text of demo, reproduce and register: one-line errors with the
program prefix and the option name (exit 2), checked before anything is computed."""

from __future__ import annotations

import pytest

from dualpose.cli.main import main


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["demo", "--seed", "-1"], "dualpose demo: error: argument --seed:"),
        (["reproduce", "screw-vector", "--duration", "nan"],
         "dualpose reproduce screw-vector: error: argument --duration:"),
        (["reproduce", "screw-vector", "--duration", "0"], "argument --duration: must be a finite number in (0,"),
        (["reproduce", "screw-vector", "--long-duration", "1e300"], "argument --long-duration:"),
        (["register", "a", "b", "--ransac", "--threshold", "-1"], "argument --threshold:"),
    ],
)
def test_out_of_range_numbers_are_usage_errors(argv, needle, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert needle in capsys.readouterr().err


def test_threshold_without_ransac_is_refused(tmp_path, capsys):
    a = tmp_path / "a.csv"
    a.write_text("0,0,0\n1,0,0\n0,1,0\n")
    assert main(["register", str(a), str(a), "--threshold", "0.1"]) == 2
    assert capsys.readouterr().err.strip() == (
        "dualpose register: error: --threshold is the RANSAC inlier distance: it needs --ransac"
    )


@pytest.mark.parametrize("target", ["walker1991", "screw-vector"])
@pytest.mark.parametrize("out", ["FILE", "FILE/sub", "/proc/dualpose-out"])
def test_reproduce_refuses_an_unusable_out_before_computing(target, out, tmp_path, capsys):
    (tmp_path / "FILE").write_text("x")
    out = out.replace("FILE", str(tmp_path / "FILE"))
    assert main(["reproduce", target, "--out", out]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"dualpose reproduce {target}: error: --out ")


def test_screw_vector_help_is_plain_text(capsys):
    with pytest.raises(SystemExit):
        main(["reproduce", "screw-vector", "--help"])
    text = capsys.readouterr().out
    assert "docs/inertial.md" in text
    for markup in ("``", ":data:", ":mod:", ":func:", "issue"):
        assert markup not in text
