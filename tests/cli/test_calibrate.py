"""``dualpose calibrate``: JSON keys, estimates within their predicted bounds, table, bad --poses."""

from __future__ import annotations

import json

import pytest

from dualpose.cli.main import main


def test_json_estimates_are_within_predicted_bounds(capsys):
    assert main(["calibrate", "--json", "--time-offset", "-20", "--gravity-misalignment", "5"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["extrinsic_error_deg"] < 3 * out["extrinsic_sigma_deg"]
    assert out["gravity_error_deg"] < 3 * out["gravity_sigma_deg"]
    assert abs(out["gravity_tilt_deg"] - 5.0) < 3 * out["gravity_sigma_deg"]
    # the whole chain runs on its own estimates with an uncalibrated accelerometer bias: the gravity error (0.1-1.3°)
    # biases the filter NIS minimum (10 seeds: 1.4 ms RMS, 2.7 ms worst; benchmarks/calibration_accuracy.py)
    assert abs(out["time_offset_error_ms"]) < 3.0 and out["time_offset_injected_ms"] == -20.0
    assert abs(out["time_offset_ms"] - out["time_offset_stage1_ms"]) < 4 * out["time_offset_stage1_sigma_ms"]


def test_table_and_bad_poses(capsys):
    assert main(["calibrate", "--poses", "3", "--extrinsic", "random"]) == 0
    table = capsys.readouterr().out
    assert "camera-IMU rotation error" in table and "filter NIS" in table
    with pytest.raises(SystemExit) as exc:
        main(["calibrate", "--poses", "1"])
    assert exc.value.code == 2
    assert "argument --poses: must be an integer in [2, 1000000]" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--gravity-misalignment", "1e300"),
        ("--gravity-misalignment", "nan"),
        ("--time-offset", "inf"),
        ("--time-offset", "-1e4"),
        ("--poses", "10000000"),
        ("--seed", "-1"),
    ],
)
def test_numeric_options_out_of_range_are_usage_errors(option, value, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["calibrate", option, value])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"dualpose calibrate: error: argument {option}:" in err and len(err.strip().splitlines()[-1]) < 200


def test_progress_is_plain_lines_off_a_terminal(capsys):
    assert main(["calibrate", "--poses", "2", "--json"]) == 0
    err = capsys.readouterr().err
    assert "\r" not in err
    assert err.splitlines()[-1] == "dualpose calibrate: 4/4 time offset"


def test_static_session_many_poses_matches_the_per_pose_solver():
    """The batched static poses (simulation + PnP of many poses at once) give the per-pose PnP answer."""
    import numpy as np

    import dualpose as dp
    from dualpose.calibration import static_periods
    from dualpose.registration.pnp import solve_pnp_ransac
    from dualpose.sim.calibration_scenarios import simulate_static_pose_set

    s = simulate_static_pose_set(40, 3)
    st = static_periods(s.accel, s.pixels, s.points, s.valid, s.camera.matrix, 1e-3, 100.0)
    for k in range(0, 40, 7):
        ref, _ = solve_pnp_ransac(s.pixels[k][s.valid[k]], s.points[k][s.valid[k]], s.camera.matrix)
        assert dp.quat_angle(ref.q_wc, st["q_wc"][k]) < 1e-9
        np.testing.assert_allclose(st["attitude_covariance"][k], ref.covariance[:3, :3], rtol=1e-6)
    up_b = st["specific_force"] / np.linalg.norm(st["specific_force"], axis=1, keepdims=True)
    true_up_b = dp.quat_rotate(dp.quat_conj(s.q_wb), -s.gravity / 9.81)
    assert np.degrees(np.arccos(np.min(np.sum(up_b * true_up_b, axis=1)))) < 2  # accel bias + noise: < 1 deg
