"""IMU gaps seen by the streaming filters themselves (EskfStream, Hol22Stream, AhrsStream fed with ``update_imu``):
each gap longer than five nominal sample periods is warned about once and kept in ``doubts``, the states are those of
the block path (which does not watch) bit for bit, a saved state carries the nominal period so a gap across the save
is seen, and the line pipelines report each gap once, named by its line (docs/refusals.md)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from dualpose import sim
from dualpose.estimation import initialization
from dualpose.estimation.ahrs.stream import AhrsStream
from dualpose.estimation.eskf import ErrorStateEKF, EskfStream
from dualpose.estimation.hol22 import Hol22EKF, Hol22Stream
from dualpose.pipelines.ahrs_stream import stream_ahrs_lines
from dualpose.types.recording import RecordingWarning

RUN = sim.recording_from_simulation(sim.simulate_eight(0), rest_seconds=0.9)
X0, P0 = initialization.initial_state_from_run(RUN, 0.9)
PERIOD = RUN.nominal_period()


def _gapped() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The simulated IMU with two gaps cut out: 20 and 7 sample periods (> 5), and one of 4 (not a gap)."""
    keep = np.ones(len(RUN.t), bool)
    keep[300:319] = keep[600:606] = keep[900:903] = False
    return RUN.t[keep], RUN.gyro[keep], RUN.accel[keep]


def _fusion_stream(kind: str) -> EskfStream | Hol22Stream:
    if kind == "eskf":
        return EskfStream(ErrorStateEKF.from_state(RUN, X0, P0))
    return Hol22Stream(Hol22EKF.from_eskf_state(X0, P0, RUN))


@pytest.mark.parametrize("kind", ["eskf", "hol22", "ahrs"])
def test_each_gap_is_warned_once_and_kept_and_the_states_do_not_change(kind):
    t, g, a = _gapped()
    make = (lambda: AhrsStream(1.0 / PERIOD, use_mag=False, n_rest=0)) if kind == "ahrs" else (
        lambda: _fusion_stream(kind))  # fmt: skip
    stream = make()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        states = np.array([stream.update_imu(t[k], g[k], a[k]) for k in range(len(t))])
    gaps = [w for w in caught if issubclass(w.category, RecordingWarning)]
    assert len(gaps) == 2 and stream.gap_watch.count == 2
    assert [d.code for d in stream.doubts] == ["imu_gap", "imu_gap"]
    first = str(gaps[0].message)
    assert f"t = {float(t[300])!r} s: IMU gap of" in first and "20 sample periods" in first
    block = make()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the block path does not watch
        ref = block.update_batch(t, g, a)
    np.testing.assert_array_equal(states, ref[0] if kind == "ahrs" else ref.states)


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_a_gap_across_a_saved_state_is_seen_after_the_restore(kind):
    stream = _fusion_stream(kind)
    for k in range(10):
        stream.update_imu(RUN.t[k], RUN.gyro[k], RUN.accel[k])
    saved = stream.state_dict()
    assert saved["imu_period"] == pytest.approx(PERIOD, rel=1e-3)  # the set-up's update_rate
    again = type(stream).from_state(saved)
    with pytest.warns(RecordingWarning, match="IMU gap"):
        again.update_imu(RUN.t[40], RUN.gyro[40], RUN.accel[40])
    fresh = type(stream).from_state(_fusion_stream(kind).state_dict())  # saved before any sample: no gap at the first
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fresh.update_imu(RUN.t[0], RUN.gyro[0], RUN.accel[0])
    legacy = {k: v for k, v in saved.items() if k not in ("imu_period", "checksum")}  # saved before gaps were watched
    assert type(stream).from_state(legacy).gap_watch.period is None


def test_the_ahrs_line_pipeline_reports_a_gap_once_by_its_line():
    t, g, a = _gapped()
    rows = np.column_stack([t, g, a]).tolist()
    lines = ["# t gx gy gz ax ay az\n"] + [", ".join(map(repr, row)) + "\n" for row in rows]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = list(stream_ahrs_lines(lines, 1.0 / PERIOD, use_mag=False))
    assert len(out) == len(t)
    gaps = [str(w.message) for w in caught if issubclass(w.category, RecordingWarning)]
    assert len(gaps) == 2 and gaps[0].startswith("stdin line 302: IMU gap of"), gaps  # sample 300 after a comment
