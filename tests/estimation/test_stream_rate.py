"""The stated IMU rate against the stamps, checked by the streaming filters themselves (EskfStream, Hol22Stream,
AhrsStream fed with ``update_imu``; ``GapWatch`` of ``dualpose.estimation._stream``): after the first 200 stamps a
median spacing more than 10 % off the stated rate is warned about once and kept in ``doubts`` (the rule of the batch
paths, ``rate_doubt``); the states are those of the block path bit for bit; a saved state carries the stamps collected
so far, so a stream saved and restored half-way doubts at the same sample; and the line pipelines report it once,
named by its line (docs/refusals.md)."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from dualpose import sim
from dualpose.estimation import initialization
from dualpose.estimation._stream import GapWatch
from dualpose.estimation.ahrs.stream import AhrsStream
from dualpose.estimation.eskf import ErrorStateEKF, EskfStream
from dualpose.estimation.hol22 import Hol22EKF, Hol22Stream
from dualpose.pipelines.ahrs_stream import stream_ahrs_lines
from dualpose.types.recording import RecordingWarning

RUN = sim.recording_from_simulation(sim.simulate_eight(0), rest_seconds=0.9)
X0, P0 = initialization.initial_state_from_run(RUN, 0.9)
RATE = 1.0 / RUN.nominal_period()
N = GapWatch.RATE_SAMPLES + 50


def _stream(kind: str, stated: float) -> EskfStream | Hol22Stream | AhrsStream:
    """A stream of ``kind`` whose stated rate is ``stated`` × the true one."""
    if kind == "ahrs":
        return AhrsStream(stated * RATE, use_mag=False, n_rest=0)
    noise = dataclasses.replace(RUN.imu_noise, update_rate=stated * RATE)
    if kind == "eskf":
        return EskfStream(ErrorStateEKF.from_state(RUN, X0, P0, imu_noise=noise))
    return Hol22Stream(Hol22EKF.from_eskf_state(X0, P0, RUN, imu_noise=noise))


def _feed(stream, ks) -> tuple[np.ndarray, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        states = np.array([stream.update_imu(RUN.t[k], RUN.gyro[k], RUN.accel[k]) for k in ks])
    return states, [str(w.message) for w in caught if issubclass(w.category, RecordingWarning)]


@pytest.mark.parametrize("kind", ["eskf", "hol22", "ahrs"])
def test_a_rate_the_stamps_contradict_is_doubted_once_after_200_stamps(kind):
    stream = _stream(kind, 2.0)
    before, seen = _feed(stream, range(GapWatch.RATE_SAMPLES - 1))
    assert seen == [] and stream.doubts == []  # not before 200 stamps
    after, seen = _feed(stream, range(GapWatch.RATE_SAMPLES - 1, N))
    assert [d.code for d in stream.doubts] == ["imu_rate_mismatch"] and len(seen) == 1
    name = "rate" if kind == "ahrs" else "imu_noise.update_rate"
    assert f"IMU samples up to t = {float(RUN.t[GapWatch.RATE_SAMPLES - 1])!r} s: {name} is" in seen[0]
    assert stream.gap_watch.stamps is None  # checked once; the per-sample path is the gap test alone from here on
    block = _stream(kind, 2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the block path does not watch
        ref = block.update_batch(RUN.t[:N], RUN.gyro[:N], RUN.accel[:N])
    np.testing.assert_array_equal(np.vstack([before, after]), ref[0] if kind == "ahrs" else ref.states)


@pytest.mark.parametrize("kind", ["eskf", "hol22", "ahrs"])
def test_a_stated_rate_the_stamps_agree_with_is_not_doubted(kind):
    stream = _stream(kind, 1.05)  # within 10 %
    _, seen = _feed(stream, range(N))
    assert seen == [] and stream.doubts == []


@pytest.mark.parametrize("kind", ["eskf", "hol22", "ahrs"])
def test_the_collected_stamps_travel_with_a_saved_state(kind):
    stream = _stream(kind, 2.0)
    _feed(stream, range(150))
    saved = stream.state_dict()
    assert len(saved["imu_rate_stamps"]) == 150
    again = type(stream).from_state(saved)
    _, seen = _feed(again, range(150, N))
    assert [d.code for d in again.doubts] == ["imu_rate_mismatch"] and len(seen) == 1
    assert f"t = {float(RUN.t[GapWatch.RATE_SAMPLES - 1])!r} s" in seen[0]  # at the same sample as without the save
    done = type(stream).from_state(again.state_dict())
    assert done.state_dict()["imu_rate_stamps"] is None and done.gap_watch.stamps is None
    legacy = {k: v for k, v in saved.items() if k not in ("imu_rate_stamps", "checksum")}  # saved before the check
    _, seen = _feed(type(stream).from_state(legacy), range(150, N))
    assert seen == []
    bad = dict(saved, imu_rate_stamps=np.r_[saved["imu_rate_stamps"][:-1], np.nan])
    bad.pop("checksum")
    with pytest.raises(ValueError, match="imu_rate_stamps"):
        type(stream).from_state(bad)


def test_the_ahrs_line_pipeline_reports_the_rate_doubt_once_by_its_line():
    rows = np.column_stack([RUN.t[:N], RUN.gyro[:N], RUN.accel[:N]]).tolist()
    lines = ["# t gx gy gz ax ay az\n"] + [", ".join(map(repr, row)) + "\n" for row in rows]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = list(stream_ahrs_lines(lines, 2.0 * RATE, use_mag=False))
    assert len(out) == N
    seen = [str(w.message) for w in caught if issubclass(w.category, RecordingWarning)]
    assert len(seen) == 1 and seen[0].startswith("stdin lines up to 201: rate is"), seen  # 200th stamp, line 201
