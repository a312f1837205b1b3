"""The shared progress helper writes plain lines (no carriage return) when stderr is not a terminal."""

from __future__ import annotations

from dualpose.cli._progress import progress_bar


def test_plain_lines_off_a_terminal(capsys) -> None:
    with progress_bar(3, "job") as bar:
        bar.update()
        bar.update(2)
    err = capsys.readouterr().err
    assert "\r" not in err
    assert err.splitlines() == ["job: 1/3", "job: 3/3"]
