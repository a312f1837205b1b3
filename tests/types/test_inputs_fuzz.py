"""Fuzzing the input checks every path shares (``dualpose.types._inputs``; docs/refusals.md, "Inputs: samples,
parameters, saved states, set-ups").

Each case gives a correct result or a ValueError / TypeError naming the argument: never another exception, never a NaN
output.  Properties, over hypothesis strategies for IMU samples, filter parameters, saved-state bytes and set-ups:

* a sample the batch path refuses is refused by the streams too (one check), and what they accept gives finite output;
* a constructor refuses a parameter outside its range, and what it accepts is in range (unit quaternions, a
  probability strictly inside (0, 1), a positive sigma);
* a saved state with any bit flipped, random bytes after its header, or a NaN payload is refused on load (the
  checksum, and the values when the checksum is removed), and an intact one continues exactly;
* a set-up with an out-of-range value is refused, naming it.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from dualpose import sim
from dualpose.estimation import initialization
from dualpose.estimation.ahrs import estimate_orientation
from dualpose.estimation.ahrs.stream import AhrsStream
from dualpose.estimation.eskf import ErrorStateEKF, EskfStream
from dualpose.estimation.hol22 import Hol22EKF, Hol22Stream
from dualpose.types import FilterStart, ImuNoise, SensorSetup
from dualpose.types._inputs import IMU_LIMITS, check_seal, seal

FUZZ = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])

RUN = sim.recording_from_simulation(sim.simulate_eight(0), rest_seconds=0.9)
X0, P0 = initialization.initial_state_from_run(RUN, 0.9)


def eskf(**kwargs) -> ErrorStateEKF:
    return ErrorStateEKF.from_state(RUN, X0, P0, **kwargs)


def started(kind: str):
    """A stream of ``kind`` ("eskf", "hol22", "ahrs") after 120 samples of the simulated run."""
    n = 120
    if kind == "ahrs":
        s = AhrsStream(100.0, use_mag=False, n_rest=50)
        s.update_batch(RUN.t[:n], RUN.gyro[:n], RUN.accel[:n])
        return s
    s = EskfStream(eskf()) if kind == "eskf" else Hol22Stream(Hol22EKF.from_eskf_state(X0, P0, RUN))
    s.update_batch(RUN.t[:n], RUN.gyro[:n], RUN.accel[:n])
    return s


def restore(kind: str, state):
    return {"ahrs": AhrsStream, "eskf": EskfStream, "hol22": Hol22Stream}[kind].from_state(state)


def step(s, k: int = 120) -> np.ndarray:
    out = s.update_imu(RUN.t[k], RUN.gyro[k], RUN.accel[k])
    return np.asarray(out)


# ---------------------------------------------------------------------------------------------------- samples

#: one component of an IMU sample: ordinary, huge, tiny, NaN or infinite
component = st.one_of(
    st.floats(-50.0, 50.0),
    st.sampled_from([1e300, -1e300, 1e4, 2e3, 1e-300, math.nan, math.inf, -math.inf]),
    st.floats(allow_nan=True, allow_infinity=True),
)
sample = st.lists(component, min_size=3, max_size=3)


def plausible(v: list[float], kind: str) -> bool:
    return all(math.isfinite(x) and abs(x) <= IMU_LIMITS[kind] for x in v)


@FUZZ
@given(gyro=sample, accel=sample)
def test_a_sample_is_refused_by_every_path_alike_or_gives_finite_output(gyro, accel):
    ok = plausible(gyro, "gyro") and plausible(accel, "accel")
    G = np.tile(RUN.gyro[:1], (12, 1))
    A = np.tile(RUN.accel[:1], (12, 1))
    G[11], A[11] = gyro, accel
    outcomes = []
    for run in (
        lambda: estimate_orientation(G, A, None, 100.0, use_mag=False, n_rest=10).quat[-1],
        lambda: AhrsStream(100.0, use_mag=False, n_rest=10).update_batch(np.arange(12) * 0.01, G, A)[0][-1],
        lambda: started("ahrs").update_imu(RUN.t[120], gyro, accel),
        lambda: started("eskf").update_imu(RUN.t[120], gyro, accel),
        lambda: started("hol22").update_imu(RUN.t[120], gyro, accel),
    ):
        try:
            out = np.asarray(run())
        except ValueError as exc:
            assert str(exc).startswith(("gyr", "acc"))
            outcomes.append(False)
        else:
            assert np.isfinite(out).all()
            outcomes.append(True)
    assert outcomes == [ok] * len(outcomes)


@FUZZ
@given(t=st.lists(st.one_of(st.floats(0.0, 2.0), st.sampled_from([math.nan, math.inf, -math.inf])), min_size=2,
                  max_size=6))  # fmt: skip
def test_times_must_be_finite_and_increase_in_every_stream(t):
    ok = all(map(math.isfinite, t)) and all(b > a for a, b in zip(t, t[1:], strict=False))
    n = len(t)
    for s in (AhrsStream(100.0, use_mag=False, n_rest=0), EskfStream(eskf())):
        try:
            s.update_batch(t, np.tile(RUN.gyro[:1], (n, 1)), np.tile(RUN.accel[:1], (n, 1)))
        except ValueError as exc:
            assert not ok and str(exc).startswith("t must be finite and increase strictly")
        else:
            assert ok


def test_a_long_rest_at_a_high_rate_is_refused_before_allocating():
    with pytest.raises(ValueError, match="rest period of 100000000000 samples"):
        AhrsStream(1e9, use_mag=False, n_rest=100_000_000_000)
    s = AhrsStream(1e5, use_mag=False, n_rest=1_000_000)  # allowed: the buffer grows with the samples received
    s.update_imu(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 9.81])
    assert len(s._pending[0]) <= 1024


@pytest.mark.parametrize("rate", [0.0, -1.0, 1e-100, math.nan, math.inf, 1e10])
def test_an_implausible_rate_is_refused_by_batch_and_stream(rate):
    for run in (lambda: AhrsStream(rate, use_mag=False),
                lambda: estimate_orientation(np.zeros((20, 3)), np.tile([0, 0, 9.81], (20, 1)), None, rate,
                                             use_mag=False)):  # fmt: skip
        with pytest.raises(ValueError, match="rate must be a sampling rate"):
            run()


def test_zero_specific_force_at_rest_is_refused_before_any_output():
    s = AhrsStream(100.0, use_mag=False, n_rest=10)
    with pytest.raises(ValueError, match="mean specific force of the rest period so far is zero"):
        s.update_imu(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    assert s.samples == 0
    assert np.isfinite(s.update_imu(0.01, [0.0, 0.0, 0.0], [0.0, 0.0, 9.81])).all()


# ---------------------------------------------------------------------------------------------------- parameters

number = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0.0, -1.0, 1.0, 2.0, 1e300]))


@FUZZ
@given(p=number)
def test_gate_probability_strictly_inside_zero_one(p):
    for make in (lambda: eskf(gate_probability=p), lambda: Hol22EKF.from_eskf_state(X0, P0, RUN, gate_probability=p)):
        if 0.0 < p < 1.0:
            assert 0.0 < make().gate < math.inf
        else:
            with pytest.raises(ValueError, match="gate_probability must be a probability in"):
                make()


@FUZZ
@given(sigma=number)
def test_pixel_sigma_positive_and_finite(sigma):
    if math.isfinite(sigma) and 0.0 < sigma <= 1e4:
        assert eskf(pixel_sigma=sigma).pixel_sigma == sigma
    else:
        with pytest.raises(ValueError, match="pixel_sigma must be"):
            eskf(pixel_sigma=sigma)


@FUZZ
@given(q=st.lists(st.one_of(st.floats(-2.0, 2.0), st.sampled_from([0.0, math.nan])), min_size=4, max_size=4))
def test_q_bc_is_normalised_near_unit_and_refused_otherwise(q):
    norm = float(np.linalg.norm(q)) if all(map(math.isfinite, q)) else math.nan
    if abs(norm - 1.0) <= 1e-3:
        f = eskf(q_bc=q)
        assert abs(np.linalg.norm(f.q_bc) - 1.0) < 1e-12
    else:
        with pytest.raises(ValueError, match="q_bc must be"):
            eskf(q_bc=q)


@FUZZ
@given(seed=st.integers(0, 2**32 - 1), kind=st.sampled_from(["nan", "asym", "negative", "huge", "ok"]))
def test_a_covariance_must_be_finite_symmetric_psd(seed, kind):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(15, 15))
    P = A @ A.T * 1e-4
    if kind == "nan":
        P[rng.integers(15), rng.integers(15)] = np.nan
    elif kind == "asym":
        P[0, 1] += 1.0
    elif kind == "negative":
        P[3, 3] = -1.0
    elif kind == "huge":
        P *= 1e300
    if kind == "ok":
        assert np.isfinite(ErrorStateEKF(X0[:3], X0[3:6], X0[6:10], P).P).all()
    else:
        with pytest.raises(ValueError, match="covariance"):
            ErrorStateEKF(X0[:3], X0[3:6], X0[6:10], P)


def test_a_zero_quaternion_is_refused_by_hol22():
    x = Hol22EKF.from_eskf_state(X0, P0, RUN).x.copy()
    x[9:13] = 0.0
    with pytest.raises(ValueError, match=r"x0\[quat_be\] must be a unit quaternion"):
        Hol22EKF(x, np.eye(22))


# ---------------------------------------------------------------------------------------------------- saved states


@pytest.fixture(scope="module")
def saved():
    return {kind: started(kind).state_dict() for kind in ("ahrs", "eskf", "hol22")}


@pytest.mark.parametrize("kind", ["ahrs", "eskf", "hol22"])
def test_an_intact_state_continues_exactly_also_after_pickle(kind, saved):
    a = started(kind)
    b = restore(kind, pickle.loads(pickle.dumps(saved[kind])))
    assert np.array_equal(step(a), step(b))


@FUZZ
@given(kind=st.sampled_from(["ahrs", "eskf", "hol22"]), where=st.floats(0.0, 1.0, exclude_max=True),
       bit=st.integers(0, 7), checksum=st.booleans())  # fmt: skip
def test_a_flipped_bit_is_refused_or_continues_finite(saved, kind, where, bit, checksum):
    state = dict(saved[kind])
    buf = np.array(state["state"], copy=True)
    k = int(where * len(buf))
    buf[k] ^= np.uint8(1 << bit)
    state["state"] = buf
    if not checksum:
        del state["checksum"]
    try:
        s = restore(kind, state)
    except ValueError:
        return
    assert not checksum, "a flipped bit under a checksum must be refused"
    try:
        out = step(s)
    except ValueError:
        return
    assert np.isfinite(out).all()


@FUZZ
@given(kind=st.sampled_from(["ahrs", "eskf", "hol22"]), payload=st.binary(min_size=8, max_size=64),
       offset=st.integers(48, 4000))  # fmt: skip
def test_random_bytes_after_the_header_are_refused(saved, kind, payload, offset):
    state = dict(saved[kind])
    buf = np.array(state["state"], copy=True)
    offset = min(offset, len(buf) - len(payload))
    new = np.frombuffer(payload, np.uint8)
    assume(not np.array_equal(buf[offset : offset + len(new)], new))
    buf[offset : offset + len(new)] = new
    state["state"] = buf
    with pytest.raises(ValueError, match="checksum mismatch|inconsistent"):  # the native header check comes first
        restore(kind, state)


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_a_nan_state_is_refused_without_the_checksum(saved, kind):
    s = started(kind)
    buf = s._buf.copy()
    doubles = buf[32:].view(np.float64)  # after the 32-byte header: the configuration, then the filter
    x = s.state
    at = int(np.flatnonzero(doubles == x[0])[-1])  # the state's first value
    doubles[at] = np.nan
    state = {**saved[kind], "state": buf}
    del state["checksum"]
    with pytest.raises(ValueError, match="not finite"):
        restore(kind, state)


@pytest.mark.parametrize("field", ["pending", "t", "rest_sums"])
def test_ahrs_pending_values_are_checked(field):
    s = AhrsStream(100.0, use_mag=False, n_rest=50)
    s.update_batch(RUN.t[:20], RUN.gyro[:20], RUN.accel[:20])
    state = s.state_dict()
    del state["checksum"]
    if field == "pending":
        state["pending"]["gyro"][3, 1] = np.nan
    elif field == "t":
        state["t"] = math.inf
    else:
        state["rest_sums"][0] = np.nan
    with pytest.raises(ValueError):
        AhrsStream.from_state(state)


@FUZZ
@given(value=st.one_of(st.floats(allow_nan=True), st.text(max_size=3), st.none(), st.binary(max_size=4)))
def test_check_seal_refuses_any_change(value):
    state = seal({"a": np.arange(3.0), "b": {"c": 1.5, "d": [1, 2]}, "buf": np.arange(5, dtype=np.uint8)})
    assert check_seal(state)
    changed = dict(state, b={"c": value, "d": [1, 2]})
    assume(not (isinstance(value, float) and value == 1.5))
    with pytest.raises(ValueError, match="checksum mismatch|not a saved stream"):
        check_seal(changed)


# ---------------------------------------------------------------------------------------------------- set-ups


@FUZZ
@given(field=st.sampled_from(["position", "velocity", "position_sigma", "velocity_sigma", "attitude_sigma", "quat"]),
       value=st.sampled_from([math.nan, math.inf, 1e300, -1.0, 0.0]))  # fmt: skip
def test_a_filter_start_out_of_range_is_refused_naming_the_field(field, value):
    args = {"position": np.zeros(3), "quat": np.array([0.0, 0.0, 0.0, 1.0])}
    if field in ("position", "velocity"):
        args[field] = np.array([value, 0.0, 0.0])
        ok = math.isfinite(value) and abs(value) < 1e4
    elif field == "quat":
        args[field] = np.array([value, 0.0, 0.0, 1.0])
        ok = value == 0.0
    else:
        args[field] = value
        ok = math.isfinite(value) and value > 0 and value < 3.0
    if ok:
        FilterStart(**args)
    else:
        with pytest.raises(ValueError, match=field):
            FilterStart(**args)


@pytest.mark.parametrize(("change", "match"), [
    ({"time_offset": 1e300}, "time_offset must be a finite clock offset"),
    ({"gravity": [0.0, 0.0, 1e300]}, "gravity: magnitude"),
    ({"imu_noise": ImuNoise(update_rate=1e-100)}, "update_rate"),
    ({"pixel_sigma": 0.0}, "pixel_sigma"),
])  # fmt: skip
def test_a_sensor_setup_out_of_range_is_refused(change, match):
    start = FilterStart(position=np.zeros(3), quat=np.array([0.0, 0.0, 0.0, 1.0]))
    base = {k: getattr(RUN, k) for k in ("camera", "q_bc", "p_bc", "pixel_sigma", "imu_noise", "time_offset",
                                         "gravity")}  # fmt: skip
    with pytest.raises(ValueError, match=match):
        SensorSetup(**{**base, **change}, start=start)


def test_a_principal_point_outside_the_image_is_refused():
    from dualpose.types.camera import CameraIntrinsics

    cam = CameraIntrinsics(200.0, 200.0, 1e6, 120.0, 320, 240)
    with pytest.raises(ValueError, match="principal point"):
        eskf(camera=cam)
