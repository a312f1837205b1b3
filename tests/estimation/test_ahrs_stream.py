"""The streaming AHRS (dualpose.estimation.ahrs_stream): one sample at a time equals the batch estimator bit for bit,
outputs are causal, and a saved state continues exactly; on a synthetic recording and on a real BROAD trial."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

import dualpose as dp
from dualpose import _native
from dualpose.estimation.ahrs import estimate_orientation, rest_statistics
from dualpose.estimation.ahrs_stream import AhrsStream
from dualpose.io import load_broad

BROAD = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "broad"
BROAD_TRIAL = "24_disturbed_tapping_A"  # disturbed: the gates and the adaptive noise are exercised
RATE = 100.0


def synthetic(seed: int = 5, rest_s: float = 2.0, move_s: float = 20.0):
    """Seeded IMU samples (n, 3) of a smooth rotation after a rest period, with linear acceleration, a magnetic
    disturbance (gates) and noise; returns (t, gyr, acc, mag, n_rest)."""
    rng = np.random.default_rng(seed)
    n_rest, n = int(rest_s * RATE), int((rest_s + move_s) * RATE)
    t = np.arange(n + 1) / RATE
    tm = np.clip(t - rest_s, 0.0, None)
    rv = np.stack([0.8 * np.sin(0.9 * tm), 0.6 * np.sin(1.3 * tm + 0.5), 2.0 * np.sin(0.4 * tm)], axis=1)
    q = dp.quat_from_rotvec(rv)
    w = dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(q[:-1]), q[1:])) * RATE  # body rate over each step
    q, t, tm = q[:-1], t[:-1], tm[:-1]
    a_lin = np.stack([2.0 * np.sin(5.0 * tm), 1.5 * np.sin(8.0 * tm + 0.4), 0.5 * np.sin(3.0 * tm)], axis=1)
    field = np.broadcast_to([0.0, 19.0, -45.0], (n, 3)).copy()
    field[(tm > 8.0) & (tm < 11.0)] += [30.0, 10.0, 15.0]
    conj = dp.quat_conj(q)
    gyr = w + [0.01, -0.02, 0.015] + rng.normal(scale=0.002, size=(n, 3))
    acc = dp.quat_rotate(conj, a_lin + [0.0, 0.0, 9.81]) + rng.normal(scale=0.05, size=(n, 3))
    mag = dp.quat_rotate(conj, field) + rng.normal(scale=0.5, size=(n, 3))
    return t, gyr, acc, mag, RATE, n_rest


def broad():
    if not BROAD.is_dir():
        pytest.skip("BROAD data directory missing")
    tr = load_broad(BROAD / f"{BROAD_TRIAL}.mat")
    return np.arange(len(tr.gyr)) / tr.rate, tr.gyr, tr.acc, tr.mag, tr.rate, tr.static_start


@pytest.fixture(scope="module", params=["synthetic", "broad"])
def run(request):
    return synthetic() if request.param == "synthetic" else broad()


def batch(run, use_mag=True, n_rest=None):
    t, gyr, acc, mag, rate, n0 = run
    n_rest = n0 if n_rest is None else n_rest
    return estimate_orientation(
        gyr, acc, mag, rate, use_mag=use_mag, n_rest=n_rest, mag_time_offset=0.0, mag_calibration=None
    )


def stream_one_by_one(s: AhrsStream, t, gyr, acc, mag, start: int = 0):
    """update_imu per sample from `start`; returns (quat, bias) per sample, the rest-period outputs filled in."""
    n = len(t)
    q, b = np.empty((n, 4)), np.empty((n, 3))
    for k in range(start, n):
        q[k] = s.update_imu(t[k], gyr[k], acc[k], None if mag is None else mag[k])
        b[k] = s.gyro_bias
    return q, b


@pytest.mark.parametrize("use_mag", [True, False])
def test_stream_equals_batch_bit_for_bit(run, use_mag):
    t, gyr, acc, mag, rate, n_rest = run
    ref = batch(run, use_mag)
    s = AhrsStream(rate, use_mag=use_mag, n_rest=n_rest)
    q, b = stream_one_by_one(s, t, gyr, acc, mag if use_mag else None)
    assert np.isnan(q[: n_rest - 1]).all()  # the rest period is buffered until complete ...
    q[:n_rest], b[:n_rest] = s.rest_quat, s.rest_gyro_bias  # ... and its outputs are kept
    assert np.array_equal(q, ref.quat)
    assert np.array_equal(b, ref.gyroscope_bias)
    assert np.array_equal(s.covariance, ref.covariance)
    # blocks of irregular sizes through update_batch: the same numbers
    s2 = AhrsStream(rate, use_mag=use_mag, n_rest=n_rest)
    cuts = [0, 7, n_rest // 2, n_rest + 3, n_rest + 400, len(t)]
    m = mag if use_mag else np.zeros_like(gyr)
    parts = [s2.update_batch(t[i:j], gyr[i:j], acc[i:j], m[i:j]) for i, j in zip(cuts[:-1], cuts[1:], strict=True)]
    q2 = np.concatenate([p[0] for p in parts])
    b2 = np.concatenate([p[1] for p in parts])
    q2[:n_rest], b2[:n_rest] = s2.rest_quat, s2.rest_gyro_bias
    assert np.array_equal(q2, ref.quat)
    assert np.array_equal(b2, ref.gyroscope_bias)


def test_stream_without_rest_period_and_with_given_rest_statistics():
    run = synthetic()
    t, gyr, acc, mag, rate, n_rest = run
    ref0 = batch(run, n_rest=0)
    q, b = stream_one_by_one(AhrsStream(rate, n_rest=0), t, gyr, acc, mag)
    assert np.array_equal(q, ref0.quat) and np.array_equal(b, ref0.gyroscope_bias)
    # rest statistics known beforehand: every output is available at its own sample
    rest = rest_statistics(gyr, acc, mag, rate, n_rest)
    q, b = stream_one_by_one(AhrsStream(rate, rest=rest), t, gyr, acc, mag)
    ref = batch(run)
    assert np.array_equal(q, ref.quat) and np.array_equal(b, ref.gyroscope_bias)


def test_outputs_are_causal(run):
    t, gyr, acc, mag, rate, n_rest = run
    k = n_rest + 500
    q, b = AhrsStream(rate, n_rest=n_rest).update_batch(t, gyr, acc, mag)
    for arr in (gyr, acc, mag):
        changed = [x.copy() for x in (gyr, acc, mag)]
        changed[[id(gyr), id(acc), id(mag)].index(id(arr))][k + 100] += [0.7, -3.0, 20.0]
        s = AhrsStream(rate, n_rest=n_rest)
        q1, b1 = stream_one_by_one(s, t[: k + 200], *(c[: k + 200] for c in changed))
        assert np.array_equal(q1[n_rest : k + 1], q[n_rest : k + 1])
        assert np.array_equal(b1[n_rest : k + 1], b[n_rest : k + 1])
        assert not np.array_equal(q1[k + 100 : k + 200], q[k + 100 : k + 200])  # the change is seen after it


@pytest.mark.parametrize("where", ["rest", "moving"])
def test_save_and_restore_continues_exactly(run, where):
    t, gyr, acc, mag, rate, n_rest = run
    k = n_rest // 2 if where == "rest" else n_rest + 777
    whole = AhrsStream(rate, n_rest=n_rest)
    q_ref, b_ref = stream_one_by_one(whole, t, gyr, acc, mag)
    s = AhrsStream(rate, n_rest=n_rest)
    stream_one_by_one(s, t[:k], gyr[:k], acc[:k], mag[:k])
    saved = pickle.loads(pickle.dumps(s.state_dict()))
    s.update_imu(t[k], gyr[k] + 1.0, acc[k], mag[k])  # the saved state is a copy: later use does not touch it
    r = AhrsStream.from_state(saved)
    q, b = stream_one_by_one(r, t, gyr, acc, mag, start=k)
    # NaN: outputs of rest samples returned before the rest period was complete (the same in both)
    assert np.array_equal(q[k:], q_ref[k:], equal_nan=True) and np.array_equal(b[k:], b_ref[k:], equal_nan=True)
    assert np.array_equal(r.rest_quat, whole.rest_quat)
    assert np.array_equal(r.covariance, whole.covariance)
    assert r.samples == whole.samples


def test_a_saved_state_of_the_wrong_size_or_version_is_refused():
    t, gyr, acc, mag, rate, n_rest = synthetic(move_s=2.0)
    s = AhrsStream(rate, n_rest=n_rest)
    s.update_batch(t, gyr, acc, mag)
    good = s.state_dict()
    assert good["version"] == AhrsStream.LAYOUT_VERSION == _native.AHRS_STREAM_VERSION
    bad = dict(good, version=good["version"] + 1)
    with pytest.raises(ValueError, match="state has AHRS stream layout version"):
        AhrsStream.from_state(bad)
    with pytest.raises(ValueError, match="state has .* bytes"):
        AhrsStream.from_state(dict(good, state=good["state"][:-8]))
    with pytest.raises(ValueError, match="state is not an AHRS stream state"):
        AhrsStream.from_state(dict(good, state=np.zeros(64, np.uint8)))
    buf = good["state"].copy()
    buf.view(np.uint64)[1] += 1  # the layout version inside the buffer's header
    with pytest.raises(ValueError, match="state has AHRS stream layout version"):
        AhrsStream.from_state(dict(good, state=buf))
    with pytest.raises(ValueError, match="state is not a saved AhrsStream"):
        AhrsStream.from_state({"state": good["state"]})
    # the buffer as raw bytes is accepted
    r = AhrsStream.from_state(dict(good, state=good["state"].tobytes()))
    assert np.array_equal(r.quat, s.quat)


def test_bad_samples_raise_naming_them():
    s = AhrsStream(RATE, n_rest=0)
    s.update_imu(0.0, [0, 0, 0], [0, 0, 9.8], [0, 20, -40])
    with pytest.raises(ValueError, match="t must increase"):
        s.update_imu(0.0, [0, 0, 0], [0, 0, 9.8], [0, 20, -40])
    with pytest.raises(ValueError, match="mag is required"):
        s.update_imu(0.01, [0, 0, 0], [0, 0, 9.8])
    with pytest.raises(ValueError, match="gyro must be 3 numbers"):
        s.update_imu(0.02, [0, 0], [0, 0, 9.8], [0, 20, -40])
    with pytest.raises(ValueError, match="accel must have shape"):
        s.update_batch([0.1, 0.2], np.zeros((2, 3)), np.zeros((3, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="n_rest must be 0"):
        AhrsStream(RATE, n_rest=5)
