"""``dualpose ahrs``: JSON keys, 9D/6D, table output, errors naming the file."""

from __future__ import annotations

import json

import pytest

from dualpose.cli.main import main
from realdata import data_dir, require_full

BROAD = data_dir("broad")
TRIAL = BROAD / "24_disturbed_tapping_A.mat"
#: the whole trial (not the cut in tests/data): its still period after the movement, the calibration decision
FULL = data_dir("broad", full=True).is_dir()
KEYS = ("total_rmse_deg", "heading_rmse_deg", "inclination_rmse_deg", "us_per_sample")


@pytest.fixture(autouse=True)
def _data():
    if not BROAD.is_dir():
        pytest.skip("BROAD data directory missing")


@pytest.mark.parametrize("flag", ["--mag", "--no-mag"])
def test_json_keys(flag, capsys):
    assert main(["ahrs", str(TRIAL), flag, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in KEYS:
        assert isinstance(out[key], float) and out[key] > 0
    assert out["mode"] == ("9D" if flag == "--mag" else "6D")
    assert out["total_rmse_deg"] >= max(out["heading_rmse_deg"], out["inclination_rmse_deg"])
    assert out["total_rmse_deg"] < 1.768  # BROAD's published Madgwick result on this trial
    assert (out["heading_offset_deg"] != 0.0) == (flag == "--no-mag")
    # the rest detector sees the trial's still period after the movement (none inside it; docs/broad.md)
    assert 0 <= out["rest_updates"] <= out["rest_samples"]
    if FULL:
        assert out["rest_samples"] > 5000 and out["rest_updates"] > 0
    if flag == "--mag":  # estimated from gyro + mag only; BROAD's magnetometer lags by ~11 ms in every trial
        assert isinstance(out["mag_time_offset_ms"], float) and 5.0 < out["mag_time_offset_ms"] < 20.0
        assert out["mag_calibration_applied"] is False  # off unless --mag-calibration
    else:
        assert out["mag_time_offset_ms"] is None
        assert out["mag_calibration_applied"] is None and "mag_calibration_model" not in out


def test_mag_calibration_flag_reports_the_decision(capsys):
    """With --mag-calibration the self-calibration decision and its parameters are reported (trial 24: the
    symmetric soft-iron model passes the rule, docs/broad.md)."""
    require_full("broad", "the calibration decision on the whole trial 24")
    assert main(["ahrs", str(TRIAL), "--mag-calibration", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mag_calibration_applied"] is True
    assert out["mag_calibration_model"] != "none"
    assert len(out["mag_hard_iron_uT"]) == 3 and len(out["mag_soft_iron_matrix"]) == 3
    assert out["mag_norm_spread_after"] < out["mag_norm_spread_before"]


def test_table(capsys):
    assert main(["ahrs", str(TRIAL), "--mag-calibration"]) == 0
    text = capsys.readouterr().out
    assert "24_disturbed_tapping_A (9D" in text and "inclination RMSE" in text and "us/sample" in text
    assert "mag time offset" in text and "mag calibration" in text


def test_missing_and_bad_files_name_the_file(tmp_path, capsys):
    missing = tmp_path / "nope.mat"
    assert main(["ahrs", str(missing), "--json"]) == 1  # data errors exit 1
    assert str(missing) in capsys.readouterr().err
    bad = tmp_path / "bad.mat"
    bad.write_text("not a MATLAB file\n")
    assert main(["ahrs", str(bad)]) == 1
    err = capsys.readouterr().err
    assert str(bad) in err and "error" in err


@pytest.mark.parametrize("flag", ["--mag", "--no-mag"])
def test_offline_json_scores_the_smoother_next_to_the_filter(flag, capsys):
    """--offline: the RTS smoother's scores and the forward filter's (forward_*); on this trial the smoother is
    better in total and in inclination (docs/broad.md, "Offline (smoothed)"), and the self-calibration is off by
    default, as in the forward filter."""
    assert main(["ahrs", str(TRIAL), flag, "--offline", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["offline"] is True and out["mode"] == ("9D" if flag == "--mag" else "6D")
    for key in KEYS:
        assert isinstance(out[key], float) and out[key] > 0
        if key != "us_per_sample":
            assert isinstance(out["forward_" + key], float)
    assert out["total_rmse_deg"] < out["forward_total_rmse_deg"]
    assert out["inclination_rmse_deg"] < out["forward_inclination_rmse_deg"]
    assert out["mag_calibration_applied"] is (False if flag == "--mag" else None)


def test_offline_with_calibration_and_table(capsys):
    assert main(["ahrs", str(TRIAL), "--offline", "--mag-calibration", "--json"]) == 0
    applied = json.loads(capsys.readouterr().out)["mag_calibration_applied"]
    assert applied is True if FULL else isinstance(applied, bool)  # the whole trial passes the rule
    assert main(["ahrs", str(TRIAL), "--offline"]) == 0
    text = capsys.readouterr().out
    assert "offline: RTS smoother" in text and "forward filter" in text and "smoother time" in text


def test_offline_with_stream_is_a_usage_error(capsys):
    assert main(["ahrs", "--stream", "--rate", "100", "--offline"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("dualpose ahrs: error: ") and "--offline" in err
