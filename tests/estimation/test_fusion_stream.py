"""The streaming camera–IMU filters (EskfStream, Hol22Stream): one sample / frame at a time and in blocks they
equal the batch ``run`` of ErrorStateEKF and Hol22EKF bit for bit (frames between IMU samples, at IMU times, at and
before the first sample, after the last), outputs are causal, a saved state continues exactly, and bad states and
inputs are refused."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from dualpose import sim
from dualpose.estimation import initialization
from dualpose.estimation.eskf import ErrorStateEKF, EskfStream
from dualpose.estimation.hol22 import Hol22EKF, Hol22Stream


def recording(seed: int = 0) -> dict:
    """The simulated eight with extra frames: before t[0], at t[0], at an IMU time, twice at one time, after t[-1]."""
    run = sim.recording_from_simulation(sim.simulate_eight(seed), rest_seconds=0.9)
    assert run.time_offset == 0.0
    f = run.frames
    frames = [(float(f.t[j]), *f.frame(j)) for j in range(len(f.t))]
    t = run.t
    pix0, pts0 = frames[0][1], frames[0][2]
    frames[5] = (float(t[60]), *frames[5][1:])  # exactly at an IMU time
    frames.insert(9, (frames[9][0], *frames[8][1:]))  # two frames at one time
    frames = [(t[0] - 0.01, pix0, pts0), (float(t[0]), pix0, pts0)] + frames + [(t[-1] + 0.01, pix0, pts0)]
    frames.sort(key=lambda fr: fr[0])
    counts = [len(fr[1]) for fr in frames]
    return dict(
        run=run, t=t, gyro=run.gyro, accel=run.accel, frame_t=np.array([fr[0] for fr in frames]),
        offsets=np.r_[0, np.cumsum(counts)], pixels=np.concatenate([fr[1] for fr in frames]),
        points=np.concatenate([fr[2] for fr in frames]),
    )  # fmt: skip


REC = recording()
X0, P0 = initialization.initial_state_from_run(REC["run"], 0.9)


def make_filter(kind: str, **kwargs):
    run = REC["run"]
    if kind == "eskf":
        return ErrorStateEKF.from_state(run, X0, P0, **kwargs)
    return Hol22EKF.from_eskf_state(X0, P0, run, **kwargs)


STREAMS = {"eskf": EskfStream, "hol22": Hol22Stream}
ARRAYS = ("t", "gyro", "accel", "frame_t", "offsets", "pixels", "points")


def batch(kind: str, rec: dict = REC, **kwargs):
    """Batch run: states (N, dim), covariances, per-correspondence NIS (M,) (NaN where skipped), accepted."""
    r = make_filter(kind, **kwargs).run(*(rec[k] for k in ARRAYS))
    if kind == "eskf":
        X = np.c_[r.position, r.velocity, r.quat, r.gyro_bias, r.accel_bias]
    else:
        X = np.c_[r.position, r.velocity, r.acceleration, np.c_[-r.quat[:, :3], r.quat[:, 3:]], r.omega,
                  r.gyro_bias, r.accel_bias]  # fmt: skip
    return X, r.covariance, r.innovation.nis, r.innovation.accepted


def events(rec: dict) -> list[tuple[float, int, int]]:
    """(time, 0 camera / 1 IMU, index) in time order, a frame before the IMU sample at its time."""
    ev = [(float(t), 1, k) for k, t in enumerate(rec["t"])]
    ev += [(float(t), 0, j) for j, t in enumerate(rec["frame_t"])]
    return sorted(ev)


def feed(stream, rec: dict, evs=None):
    """Feed events one at a time; returns the states after each IMU sample and the FrameUpdates."""
    states, frames = [], []
    o = rec["offsets"]
    for _, kind, i in events(rec) if evs is None else evs:
        if kind:
            states.append(stream.update_imu(rec["t"][i], rec["gyro"][i], rec["accel"][i]))
        else:
            frames.append(stream.update_camera(rec["frame_t"][i], rec["pixels"][o[i] : o[i + 1]],
                                               rec["points"][o[i] : o[i + 1]]))  # fmt: skip
    return np.array(states), frames


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_one_at_a_time_equals_batch(kind):
    X, Ps, nis, acc = batch(kind)
    stream = STREAMS[kind](make_filter(kind))
    states, frames = feed(stream, REC)
    np.testing.assert_array_equal(states, X)
    np.testing.assert_array_equal(stream.covariance, Ps[-1])
    assert [f.status for f in frames].count("skipped") == 1 and frames[0].status == "skipped"
    assert frames[-1].status == "pending" and stream.pending_frames[0] is frames[-1]
    done = [f for f in frames if f.status == "done"]
    assert len(done) == len(frames) - 2
    np.testing.assert_array_equal(np.concatenate([f.nis for f in done]), nis)
    np.testing.assert_array_equal(np.concatenate([f.accepted for f in done]), acc)
    assert np.isfinite(nis).all() and acc.mean() > 0.9  # the frames really were used


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_camera_time_offset_as_batch(kind):
    X = batch(kind, camera_time_offset=0.0037)[0]
    states, _ = feed(STREAMS[kind](make_filter(kind, camera_time_offset=0.0037)), REC,
                     sorted(events(REC), key=lambda e: e[0] + (0.0037 if e[1] == 0 else 0.0)))  # fmt: skip
    np.testing.assert_array_equal(states, X)


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_blocks_equal_batch(kind):
    X, Ps, nis, _ = batch(kind)
    rng = np.random.default_rng(3)
    cuts = np.unique(np.r_[0, np.sort(rng.choice(np.arange(1, len(REC["t"])), 7, replace=False)), len(REC["t"])])
    stream = STREAMS[kind](make_filter(kind))
    t, ft, o = REC["t"], REC["frame_t"], REC["offsets"]
    states, covs, frames = [], [], []
    j0 = 0
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        j1 = len(ft) if b == len(t) else int(np.searchsorted(ft, t[b - 1], side="right"))
        r = stream.update_batch(t[a:b], REC["gyro"][a:b], REC["accel"][a:b], ft[j0:j1], o[j0 : j1 + 1] - o[j0],
                                REC["pixels"][o[j0] : o[j1]], REC["points"][o[j0] : o[j1]], covariance=True)
        states.append(r.states)
        covs.append(r.covariance)
        frames += r.frames
        j0 = j1
    np.testing.assert_array_equal(np.concatenate(states), X)
    np.testing.assert_array_equal(np.concatenate(covs), Ps)
    np.testing.assert_array_equal(np.concatenate([f.nis for f in frames if f.status == "done"]), nis)


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_mixed_single_and_block_calls(kind):
    """Frames queued by update_camera are filtered by a following block, as the batch does."""
    X = batch(kind)[0]
    evs = events(REC)
    stream = STREAMS[kind](make_filter(kind))
    k = next(i for i, e in enumerate(evs) if e[1] == 0 and e[0] > REC["t"][300])  # a frame after sample 300
    states, frames = feed(stream, REC, evs[: k + 1])
    assert len(stream.pending_frames) == 1
    n0 = len(states)
    j = evs[k][2] + 1
    t, o = REC["t"], REC["offsets"]
    r = stream.update_batch(t[n0:], REC["gyro"][n0:], REC["accel"][n0:], REC["frame_t"][j:], o[j:] - o[j],
                            REC["pixels"][o[j] :], REC["points"][o[j] :])  # fmt: skip
    assert frames[-1].status == "done"
    np.testing.assert_array_equal(np.r_[states, r.states], X)


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_causal(kind):
    """Changing a future IMU sample or frame never changes an earlier output."""
    base, _ = feed(STREAMS[kind](make_filter(kind)), REC)
    k = 350
    rec = {key: np.array(v, copy=True) if isinstance(v, np.ndarray) else v for key, v in REC.items()}
    rec["gyro"][k + 1 :] += 0.3
    rec["accel"][k + 1 :] *= 1.1
    j = int(np.searchsorted(rec["frame_t"], rec["t"][k], side="right"))
    rec["pixels"][rec["offsets"][j] :] += 3.0
    changed, _ = feed(STREAMS[kind](make_filter(kind)), rec)
    np.testing.assert_array_equal(changed[: k + 1], base[: k + 1])
    assert np.all(changed[k + 1 :] != base[k + 1 :], axis=1).any()


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_save_restore_continues_exactly(kind):
    evs = events(REC)
    full, _ = feed(STREAMS[kind](make_filter(kind)), REC)
    # cut right after a frame was queued (one pending), after an IMU sample, and before the first sample
    k_frame = next(i for i, e in enumerate(evs) if e[1] == 0 and e[0] > REC["t"][200])
    for cut in (0, 1, 150, k_frame + 1):
        stream = STREAMS[kind](make_filter(kind))
        first, _ = feed(stream, REC, evs[:cut])
        saved = pickle.loads(pickle.dumps(stream.state_dict()))
        stream.update_imu(1e9, [1.0, 2.0, 3.0], [4.0, 5.0, 6.0])  # the saved copy does not see later updates
        restored = STREAMS[kind].from_state(saved)
        rest, _ = feed(restored, REC, evs[cut:])
        np.testing.assert_array_equal(np.concatenate([first.reshape(-1, full.shape[1]), rest]), full)


def test_refuses_bad_states():
    eskf, hol = EskfStream(make_filter("eskf")), Hol22Stream(make_filter("hol22"))
    with pytest.raises(ValueError, match="'eskf' stream; Hol22Stream reads 'hol22'"):
        Hol22Stream.from_state(eskf.state_dict())
    d = hol.state_dict()
    d["state"] = eskf.state_dict()["state"]  # an ESKF buffer under a Hol22 label
    with pytest.raises(ValueError, match="is not a Hol22 stream state"):
        Hol22Stream.from_state(d)
    d = eskf.state_dict()
    d["state"] = d["state"][:-8]
    with pytest.raises(ValueError, match="has .* bytes"):
        EskfStream.from_state(d)
    d = eskf.state_dict()
    d["state"][8] += 1  # the header's layout version
    v = EskfStream.LAYOUT_VERSION
    with pytest.raises(ValueError, match=f"layout version {v + 1}; this build reads an ESKF stream state version {v}"):
        EskfStream.from_state(d)
    d = eskf.state_dict()
    d["version"] = 99
    with pytest.raises(ValueError, match="layout version 99"):
        EskfStream.from_state(d)
    with pytest.raises(ValueError, match="not a saved EskfStream"):
        EskfStream.from_state({"state": b""})


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_refuses_bad_inputs(kind):
    stream = STREAMS[kind](make_filter(kind))
    stream.update_imu(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 9.81])
    with pytest.raises(ValueError, match="increase strictly"):
        stream.update_imu(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 9.81])
    with pytest.raises(ValueError, match="gyro must be 3 numbers"):
        stream.update_imu(0.01, [0.0, 0.0], [0.0, 0.0, 9.81])
    with pytest.raises(ValueError, match="not after the last IMU sample"):
        stream.update_camera(0.0, np.zeros((2, 2)), np.ones((2, 3)))
    with pytest.raises(ValueError, match=r"pixels must have shape \(M, 2\) and points \(M, 3\)"):
        stream.update_camera(0.02, np.zeros((2, 2)), np.ones((3, 3)))
    frame = stream.update_camera(0.03, np.zeros((2, 2)), np.ones((2, 3)))
    with pytest.raises(ValueError, match="time order"):
        stream.update_camera(0.02, np.zeros((2, 2)), np.ones((2, 3)))
    with pytest.raises(ValueError, match=r"accel must be 3 numbers \(shape \(3,\)\); got shape \(4,\)"):
        stream.update_imu(0.05, [0.0, 0.0, 0.0], [0.0, 0.0, 9.81, 1.0])  # the slow path: a frame is queued
    assert frame.status == "pending" and stream.samples == 1  # nothing was filtered
    with pytest.raises(ValueError, match="t must be finite"):
        stream.update_batch([0.005, 0.004], np.zeros((2, 3)), np.zeros((2, 3)))


def test_source_filter_unchanged():
    filt = make_filter("eskf")
    x, P = filt.state, filt.covariance
    stream = EskfStream(filt)
    stream.update_imu(0.0, [0.1, 0.0, 0.0], [0.0, 0.0, 9.81])
    stream.update_imu(0.01, [0.1, 0.0, 0.0], [0.0, 0.0, 9.81])
    np.testing.assert_array_equal(filt.state, x)
    np.testing.assert_array_equal(filt.covariance, P)
    assert stream.samples == 2 and stream.time == 0.01


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_refuses_non_finite_samples_and_changes_nothing(kind):
    """A NaN or infinite sample or correspondence is refused with a ValueError naming it, and the refused call leaves
    the stream as it was: continuing gives the same states as a stream that never saw it."""
    a, b = (STREAMS[kind](make_filter(kind)) for _ in range(2))
    for s in (a, b):
        s.update_imu(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 9.81])
    with pytest.raises(ValueError, match="gyro must be finite"):
        a.update_imu(0.01, np.array([np.nan, 0.0, 0.0]), [0.0, 0.0, 9.81])  # the native fast path
    with pytest.raises(ValueError, match="accel must be finite"):
        a.update_imu(0.01, [0.0, 0.0, 0.0], [0.0, np.inf, 9.81])
    with pytest.raises(ValueError, match=r"gyro must be finite: row 1 is \[nan, 0.0, 0.0\]"):
        a.update_batch([0.01, 0.02], [[0.0, 0.0, 0.0], [np.nan, 0.0, 0.0]], np.tile([0.0, 0.0, 9.81], (2, 1)))
    with pytest.raises(ValueError, match="pixels and points must be finite"):
        a.update_camera(0.015, np.array([[np.nan, 1.0]]), np.ones((1, 3)))
    assert a.samples == b.samples == 1 and not a.pending_frames
    np.testing.assert_array_equal(a.update_imu(0.01, [0.1, 0.0, 0.0], [0.0, 0.0, 9.81]),
                                  b.update_imu(0.01, [0.1, 0.0, 0.0], [0.0, 0.0, 9.81]))
