"""The streaming AHRS (dualpose.estimation.ahrs.stream): one sample at a time equals the batch estimator bit for bit
with the default (online magnetometer time offset) settings, every output is causal -- batch and stream, inside and
after the rest period -- and a saved state continues exactly; on a synthetic recording and on a real BROAD trial."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import dualpose as dp
from dualpose import _native
from dualpose.estimation.ahrs import AhrsConfig, estimate_orientation, rest_statistics
from dualpose.estimation.ahrs.stream import AhrsStream
from dualpose.io import load_broad
from realdata import data_dir

BROAD = data_dir("broad")
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


def batch(run, use_mag=True, n_rest=None, **kw):
    t, gyr, acc, mag, rate, n0 = run
    n_rest = n0 if n_rest is None else n_rest
    return estimate_orientation(gyr, acc, mag, rate, use_mag=use_mag, n_rest=n_rest, **kw)


def stream_one_by_one(s: AhrsStream, t, gyr, acc, mag, start: int = 0):
    """update_imu per sample from `start`; returns (quat, bias) per sample."""
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
    assert np.isfinite(q).all()  # every output at its own sample, the rest period's included
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
    assert np.array_equal(q2, ref.quat)
    assert np.array_equal(b2, ref.gyroscope_bias)
    if use_mag:  # the online lag estimate is part of the state: the same value at the end
        assert s.mag_time_offset == s2.mag_time_offset == ref.mag_time_offset
    # a fixed lag, compensated the same causal way
    ref_fixed = batch(run, use_mag, mag_time_offset=0.012)
    q3, _ = AhrsStream(rate, use_mag=use_mag, n_rest=n_rest, mag_time_offset=0.012).update_batch(
        t, gyr, acc, mag if use_mag else None
    )
    assert np.array_equal(q3, ref_fixed.quat)


def test_stream_without_rest_period_and_with_given_rest_statistics():
    run = synthetic()
    t, gyr, acc, mag, rate, n_rest = run
    ref0 = batch(run, n_rest=0)
    q, b = stream_one_by_one(AhrsStream(rate, n_rest=0), t, gyr, acc, mag)
    assert np.array_equal(q, ref0.quat) and np.array_equal(b, ref0.gyroscope_bias)
    # rest statistics known beforehand: the filter runs from the first sample; from the rest period's last sample on
    # (where the batch estimator's filter output begins) the same numbers -- without the rest detector, which in the
    # stream sees these first samples (for it they are not the rest period its statistics came from) and in the
    # batch estimator does not
    rest = rest_statistics(gyr, acc, mag, rate, n_rest)
    off = AhrsConfig(rest_window=0.0)
    q, b = stream_one_by_one(AhrsStream(rate, rest=rest, config=off), t, gyr, acc, mag)
    ref = batch(run, config=off)
    k = n_rest - 1
    assert np.array_equal(q[k:], ref.quat[k:]) and np.array_equal(b[k:], ref.gyroscope_bias[k:])


@pytest.mark.parametrize("where", ["rest", "last rest sample", "moving"])
def test_outputs_are_causal(run, where):
    # changing one sample (gyro, accel or mag) never changes an earlier output, to the bit: batch and stream
    t, gyr, acc, mag, rate, n_rest = run
    j = {"rest": n_rest // 2, "last rest sample": n_rest - 1, "moving": n_rest + 600}[where]
    end = n_rest + 900
    ref = batch((t[:end], gyr[:end], acc[:end], mag[:end], rate, n_rest))
    for which in range(3):
        changed = [x[:end].copy() for x in (gyr, acc, mag)]
        changed[which][j] += [0.7, -3.0, 20.0][which] * np.array([1.0, -0.5, 0.3])
        r = batch((t[:end], *changed, rate, n_rest))
        assert np.array_equal(r.quat[:j], ref.quat[:j]) and np.array_equal(r.gyroscope_bias[:j], ref.gyroscope_bias[:j])
        assert not np.array_equal(r.quat[j:], ref.quat[j:])  # the change is seen from its own sample on
        q1, b1 = stream_one_by_one(AhrsStream(rate, n_rest=n_rest), t[:end], *changed)
        assert np.array_equal(q1, r.quat) and np.array_equal(b1, r.gyroscope_bias)


@pytest.mark.parametrize("where", ["rest", "moving", "late"])
def test_save_and_restore_continues_exactly(run, where):
    # "late": near the end, where (on the BROAD trial) the online time offset is estimated and compensated
    t, gyr, acc, mag, rate, n_rest = run
    k = {"rest": n_rest // 2, "moving": n_rest + 777, "late": len(t) - 500}[where]
    whole = AhrsStream(rate, n_rest=n_rest)
    q_ref, b_ref = stream_one_by_one(whole, t, gyr, acc, mag)
    s = AhrsStream(rate, n_rest=n_rest)
    stream_one_by_one(s, t[:k], gyr[:k], acc[:k], mag[:k])
    saved = pickle.loads(pickle.dumps(s.state_dict()))
    s.update_imu(t[k], gyr[k] + 1.0, acc[k], mag[k])  # the saved state is a copy: later use does not touch it
    r = AhrsStream.from_state(saved)
    q, b = stream_one_by_one(r, t, gyr, acc, mag, start=k)
    assert np.array_equal(q[k:], q_ref[k:]) and np.array_equal(b[k:], b_ref[k:])
    assert np.array_equal(r.covariance, whole.covariance)
    assert r.mag_time_offset == whole.mag_time_offset
    if where == "late" and rate > 200:  # the BROAD trial: τ̂ ≈ 11 ms is in use at the save
        assert 0.005 < AhrsStream.from_state(saved).mag_time_offset < 0.02
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
    with pytest.raises(ValueError, match="t must be finite and increase"):
        s.update_imu(0.0, [0, 0, 0], [0, 0, 9.8], [0, 20, -40])
    with pytest.raises(ValueError, match="mag is required"):
        s.update_imu(0.01, [0, 0, 0], [0, 0, 9.8])
    with pytest.raises(ValueError, match="gyro must be 3 numbers"):
        s.update_imu(0.02, [0, 0], [0, 0, 9.8], [0, 20, -40])
    with pytest.raises(ValueError, match="accel must have shape"):
        s.update_batch([0.1, 0.2], np.zeros((2, 3)), np.zeros((3, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="n_rest must be 0"):
        AhrsStream(RATE, n_rest=5)
    r = AhrsStream(RATE, n_rest=20)  # inside the rest period (buffered in Python): the same checks
    with pytest.raises(ValueError, match="gyro must be 3 numbers"):
        r.update_imu(0.0, 0.5, [0, 0, 9.8], [0, 20, -40])  # a scalar is not broadcast
    with pytest.raises(ValueError, match="mag must be 3 numbers"):
        r.update_imu(0.0, [0, 0, 0], [0, 0, 9.8], [0, 20])
    assert r.samples == 0


@pytest.mark.parametrize("n_rest", [0, 20], ids=["filter", "rest period"])
def test_non_finite_samples_are_refused_and_change_nothing(n_rest):
    """NaN or infinity in a sample is refused with a ValueError naming the argument -- on the compiled per-sample path,
    in the rest period and in a block -- and the refused call leaves the stream as it was."""
    a, b = AhrsStream(RATE, n_rest=n_rest), AhrsStream(RATE, n_rest=n_rest)
    for s in (a, b):
        s.update_imu(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 9.8], [0.0, 20.0, -40.0])
    with pytest.raises(ValueError, match="gyro must be finite"):
        a.update_imu(0.01, np.array([np.nan, 0.0, 0.0]), [0.0, 0.0, 9.8], [0.0, 20.0, -40.0])
    with pytest.raises(ValueError, match="mag must be finite"):
        a.update_imu(0.01, [0.0, 0.0, 0.0], [0.0, 0.0, 9.8], [np.inf, 20.0, -40.0])
    with pytest.raises(ValueError, match=r"accel must be finite: row 1 is \[0.0, nan, 9.8\]"):
        a.update_batch([0.01, 0.02], np.zeros((2, 3)), [[0.0, 0.0, 9.8], [0.0, np.nan, 9.8]],
                       np.tile([0.0, 20.0, -40.0], (2, 1)))  # fmt: skip
    assert a.samples == b.samples == 1
    args = (0.01, [0.1, 0.0, 0.0], [0.0, 0.0, 9.8], [0.0, 20.0, -40.0])
    np.testing.assert_array_equal(a.update_imu(*args), b.update_imu(*args))


def test_mag_time_offset_settings_are_checked():
    with pytest.raises(ValueError, match='mag_time_offset must be "online" or a number'):
        AhrsStream(RATE, mag_time_offset="estimate")  # the whole recording's estimate needs the future
    with pytest.raises(ValueError, match="mag_time_offset must be a finite number"):
        AhrsStream(RATE, mag_time_offset=float("nan"))
    with pytest.raises(TypeError, match="mag_time_offset must be a string or a number"):
        AhrsStream(RATE, mag_time_offset=[0.01])
    with pytest.raises(ValueError, match="time-offset search range is too long for this rate"):
        AhrsStream(20000.0, n_rest=0).update_imu(0.0, [0, 0, 0], [0, 0, 9.8], [0, 20, -40])
    s = AhrsStream(RATE, n_rest=0, mag_time_offset=0.011)
    s.update_imu(0.0, [0, 0, 0], [0, 0, 9.8], [0, 20, -40])
    assert s.mag_time_offset == 0.011
    assert AhrsStream.from_state(s.state_dict()).mag_time_offset == 0.011
