from dualpose.cli.main import main


def test_demo_passes_its_own_checks(capsys):
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert "all checks passed" in out
    assert "FAIL" not in out
