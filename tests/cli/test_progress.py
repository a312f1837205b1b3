"""``dualpose.cli._progress``: plain stage lines off a terminal, a tqdm bar on one, silence with enabled=False."""

from __future__ import annotations

import io

from dualpose.cli._progress import Progress, progress_bar


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_plain_lines_for_every_stage_when_enabled():
    out = io.StringIO()
    with Progress("eval", ["read", "align"], stream=out, enabled=True) as prog:
        with prog.stage("read") as step:
            step(1, 2)
        with prog.stage("align"):
            pass
    lines = out.getvalue().splitlines()
    assert lines[0] == "dualpose eval: [1/2] read ..."
    assert lines[1].startswith("dualpose eval: [1/2] read done in ")
    assert lines[2] == "dualpose eval: [2/2] align ..." and len(lines) == 4


def test_off_a_terminal_only_slow_stages_are_reported():
    out = io.StringIO()
    with Progress("eval", ["a", "b"], stream=out, delay=0.0) as prog:
        with prog.stage("a"):
            pass
    assert out.getvalue().startswith("dualpose eval: [1/2] a done in ")
    quiet = io.StringIO()
    with Progress("eval", ["a"], stream=quiet, delay=3600.0) as prog, prog.stage("a"):
        pass
    assert quiet.getvalue() == ""


def test_disabled_is_silent_and_unknown_stages_extend_the_total():
    out = io.StringIO()
    with Progress("fuse", ["a"], stream=out, enabled=False) as prog:
        with prog.stage("a"):
            pass
        with prog.stage("extra"):
            pass
    assert out.getvalue() == "" and prog.stages == ["a", "extra"]


def test_terminal_gets_a_tqdm_bar():
    out = _Tty()
    with Progress("eval", ["read", "align"], stream=out, delay=0.0) as prog:
        with prog.stage("read") as step:
            step(5, 10)
        with prog.stage("align"):
            pass
    text = out.getvalue()
    assert "dualpose eval" in text and "2/2" in text and "read" in text


def test_plain_lines_off_a_terminal(capsys) -> None:
    with progress_bar(3, "job") as bar:
        bar.update()
        bar.update(2)
    err = capsys.readouterr().err
    assert "\r" not in err
    assert err.splitlines() == ["job: 1/3", "job: 3/3"]
