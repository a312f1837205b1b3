"""One validation layer per input kind, shared by the batch, streaming, constructor and command-line paths
(docs/refusals.md, "Inputs: samples, parameters, saved states, set-ups").

* **IMU samples** (:func:`imu_rows`, :func:`imu_vector`, :func:`sample_times`, :func:`check_rate`,
  :func:`check_rest_samples`): finite, within :data:`IMU_LIMITS` (a larger value is a corrupt sample, not a
  measurement), strictly increasing finite times, a sampling rate in :data:`RATE_RANGE_HZ`.
* **Camera frames** (:func:`frame_points`) and **cameras** (:func:`check_camera`): finite correspondences, positive
  focal lengths, the principal point inside the image.
* **Filter parameters** (:func:`probability`, :func:`positive`, :func:`finite_vector`, :func:`unit_quaternion`,
  :func:`covariance_matrix`, :func:`time_offset`).  A quaternion that should be unit is normalised when its norm is
  within :data:`UNIT_TOLERANCE` of 1 (rounding in a typed or printed value) and refused otherwise (a zero, a
  missing component, a wrong order).
* **Saved states** (:func:`seal`, :func:`check_seal`): a BLAKE2b checksum over the whole saved dictionary, checked on
  load; the values themselves are checked by the stream's ``from_state`` with the functions above.
* **Repeated information** (:func:`check_agree` and :func:`check_pose_agrees`, from
  :mod:`dualpose.algebra._agreement` so that every layer can use them; :func:`check_stamps_agree`,
  :func:`check_rigid`, :func:`check_rotation_matrix`, :func:`check_same_transform`): a container or file whose
  fields state the same thing twice (seconds and integer nanoseconds, a transform and its inverse, a rate given
  under two keys, a quaternion and a matrix) is refused when they disagree beyond the precision they are stored
  with; the message names both fields, the difference and the tolerance.
* **Sensor set-ups** (:func:`rate_doubt`, :func:`gyro_unit_doubt`, :func:`accel_unit_problem`,
  :func:`rest_problem`, :func:`gap_doubt`): what is impossible is refused (ValueError); what a user may mean but
  probably does not is a :class:`Doubt` that the caller warns about *and* reports with its result.

Every error is a ValueError (a TypeError for a value of the wrong type) naming the argument; the sample checks take
a ``where(k)`` that names sample ``k`` as the user sees it (an index, or a file and line).
"""

from __future__ import annotations

import hashlib
import math
import struct
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dualpose.algebra._agreement import COMPUTED_TOLERANCE, check_agree, check_pose_agrees, disagreement
from dualpose.types.imu import ImuNoise

__all__ = [
    "IMU_LIMITS",
    "MAX_REST_SAMPLES",
    "RATE_RANGE_HZ",
    "UNIT_TOLERANCE",
    "Doubt",
    "COMPUTED_TOLERANCE",
    "RIGID_TOLERANCE",
    "accel_unit_problem",
    "check_agree",
    "check_camera",
    "check_pose_agrees",
    "check_imu_noise",
    "check_rate",
    "check_rest_samples",
    "check_rigid",
    "check_rotation_matrix",
    "check_same_transform",
    "check_seal",
    "check_stamps_agree",
    "covariance_matrix",
    "disagreement",
    "finite_vector",
    "frame_points",
    "gap_doubt",
    "gravity_angle",
    "gravity_up_problem",
    "gravity_vector",
    "gyro_unit_doubt",
    "imu_rows",
    "imu_vector",
    "positive",
    "probability",
    "rate_doubt",
    "rest_problem",
    "sample_times",
    "seal",
    "time_offset",
    "unit_quaternion",
]

#: largest plausible reading per IMU stream: rad/s, m/s² (far above any MEMS or tactical IMU's full scale, ±35 rad/s
#: and ±160 m/s² being typical) and any magnetometer unit up to nT; a larger value is a corrupt sample
IMU_LIMITS: dict[str, float] = {"gyro": 1.0e3, "accel": 1.0e4, "mag": 1.0e8}
_UNITS = {"gyro": "rad/s", "accel": "m/s²", "mag": "(field unit)"}

#: sampling rates a filter accepts, Hz (below: steps of minutes; above: no IMU)
RATE_RANGE_HZ: tuple[float, float] = (1.0e-2, 1.0e9)

#: most samples a stream buffers for its rest period (rate x rest seconds): 80 MB of samples
MAX_REST_SAMPLES = 1_000_000

#: a quaternion that should be unit is normalised within this distance of norm 1 and refused beyond it
UNIT_TOLERANCE = 1.0e-3

#: largest clock offset between two sensors, s (a boot clock against the Unix epoch is ~2e9 s)
MAX_TIME_OFFSET_S = 1.0e10

#: largest plausible magnitude of a position (m) or velocity (m/s) given to a filter
MAX_POSITION_M = 1.0e7
MAX_VELOCITY_M_S = 1.0e4

#: largest plausible IMU noise parameter (Kalibr units): above these the filter's covariances overflow or mean nothing
NOISE_LIMITS = {
    "gyroscope_noise_density": 1.0,
    "gyroscope_random_walk": 1.0,
    "accelerometer_noise_density": 10.0,
    "accelerometer_random_walk": 10.0,
    "gyroscope_initial_bias_sigma": 10.0,
    "accelerometer_initial_bias_sigma": 100.0,
}

Where = Callable[[int], str]


def _row(k: int) -> str:
    return f"sample {k}"


@dataclass(frozen=True)
class Doubt:
    """An input that can be processed but probably not as intended: ``code`` (a short key, stable across versions)
    and ``message`` (one line, what was seen and what to check)."""

    code: str
    message: str

    def as_dict(self) -> dict[str, str]:
        """``{"code": ..., "message": ...}`` (JSON-ready)."""
        return {"code": self.code, "message": self.message}


# ------------------------------------------------------------------------------------------------ IMU samples


def _as_float(x: Any, name: str) -> NDArray[np.float64]:
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be numbers; got {type(x).__name__} ({exc})") from None
    return a


def imu_rows(x: Any, name: str, kind: str, n: int | None = None, where: Where = _row) -> NDArray[np.float64]:
    """IMU samples ``x`` as a C-contiguous float64 array of shape (n, 3), each finite and within
    ``IMU_LIMITS[kind]`` (``kind`` "gyro", "accel" or "mag").

    Raises
    ------
    ValueError
        Another shape (``n`` rows when given), or the first row ``k`` that is not finite or out of range, named
        ``where(k)``.
    """
    a = np.ascontiguousarray(_as_float(x, name))
    if a.ndim != 2 or a.shape[1] != 3 or (n is not None and a.shape[0] != n):
        raise ValueError(f"{name} must have shape ({'n' if n is None else n}, 3); got {a.shape}")
    limit = IMU_LIMITS[kind]
    with np.errstate(invalid="ignore"):
        bad = ~(np.abs(a) <= limit).all(axis=1)  # NaN compares False
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(_sample_problem(a[k], name, kind, where(k)))
    return a


def _sample_problem(v: NDArray[np.float64], name: str, kind: str, at: str) -> str:
    if not np.isfinite(v).all():
        return f"{name} must be finite: {at} is {v.tolist()}"
    return (f"{name}: {at} has |value| {float(np.abs(v).max()):.3g} > {IMU_LIMITS[kind]:g} {_UNITS[kind]}: a corrupt "
            "sample, not a measurement")  # fmt: skip


def imu_vector(v: Any, name: str, kind: str) -> NDArray[np.float64]:
    """One IMU sample ``v`` as a float64 array of shape (3,), finite and within ``IMU_LIMITS[kind]``."""
    try:
        a = np.array(v, dtype=np.float64)
    except (TypeError, ValueError):
        a = _as_float(v, name)
    if a.shape != (3,):
        raise ValueError(f"{name} must be 3 numbers (shape (3,)); got shape {a.shape}")
    x, y, z = a.tolist()  # Python floats: the per-sample check of a stream costs well under a microsecond
    lim = IMU_LIMITS[kind]
    if not (-lim <= x <= lim and -lim <= y <= lim and -lim <= z <= lim):  # NaN compares False
        raise ValueError(_sample_problem(a, name, kind, "the sample"))
    return a


def sample_times(t: Any, name: str = "t", after: float = -math.inf, where: Where = _row) -> NDArray[np.float64]:
    """Times ``t`` (s) as a C-contiguous float64 array of shape (n,): finite, strictly increasing, the first after
    ``after`` (the last time already filtered).

    Raises
    ------
    ValueError
        Naming ``where(k)`` of the first time that is not finite or does not increase.
    """
    a = np.ascontiguousarray(_as_float(t, name)).reshape(-1)
    if not a.size:
        return a
    prev = np.concatenate(([after], a[:-1]))
    with np.errstate(invalid="ignore"):
        bad = ~(np.isfinite(a) & (a > prev))
    if bad.any():
        k = int(np.argmax(bad))
        p = float(prev[k])
        raise ValueError(f"{name} must be finite and increase strictly: {where(k)} is {float(a[k])!r} after {p!r}")
    return a


def check_rate(rate: Any, name: str = "rate") -> float:
    """A sampling rate in :data:`RATE_RANGE_HZ` (Hz) as a float."""
    r = _scalar(rate, name)
    lo, hi = RATE_RANGE_HZ
    if not lo <= r <= hi:
        raise ValueError(f"{name} must be a sampling rate in [{lo:g}, {hi:g}] Hz; got {r!r}")
    return r


def check_rest_samples(n_rest: int, rate: float, name: str = "n_rest") -> int:
    """A rest period of ``n_rest`` samples at ``rate`` Hz that a stream can buffer (at most
    :data:`MAX_REST_SAMPLES`)."""
    if n_rest > MAX_REST_SAMPLES:
        raise ValueError(
            f"{name}: a rest period of {n_rest} samples ({n_rest / rate:.3g} s at {rate:g} Hz) is more than the "
            f"{MAX_REST_SAMPLES} samples a stream buffers: shorten the rest period or check the rate"
        )
    return n_rest


# ------------------------------------------------------------------------------------------------ camera


def frame_points(pixels: Any, points: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The correspondences of one camera frame as fresh C-contiguous arrays ``pixels`` (M, 2), ``points`` (M, 3), all
    finite and ``|value| <= 1e9`` (pixels, metres)."""
    pix = np.array(_as_float(pixels, "pixels"), dtype=np.float64, ndmin=2, copy=True)
    pts = np.array(_as_float(points, "points"), dtype=np.float64, ndmin=2, copy=True)
    if pix.size == 0:
        pix = pix.reshape(0, 2)
    if pts.size == 0:
        pts = pts.reshape(0, 3)
    if pix.ndim != 2 or pix.shape[1] != 2 or pts.shape != (len(pix), 3):
        raise ValueError(f"pixels must have shape (M, 2) and points (M, 3); got {pix.shape} and {pts.shape}")
    for a, name in ((pix, "pixels"), (pts, "points")):
        with np.errstate(invalid="ignore"):
            bad = ~(np.abs(a) <= 1e9).all(axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            raise ValueError(f"pixels and points must be finite (within ±1e9 px, m): correspondence {k + 1} has "
                             f"{name} {a[k].tolist()}")  # fmt: skip
    return np.ascontiguousarray(pix), np.ascontiguousarray(pts)


def check_camera(camera: Any, name: str = "camera") -> None:
    """Positive finite focal lengths ``fx``, ``fy``, a finite principal point, inside the image ``[0, width] x
    [0, height]`` when the camera has a size (px)."""
    try:
        fx, fy, cx, cy = (float(getattr(camera, k)) for k in ("fx", "fy", "cx", "cy"))
    except (AttributeError, TypeError, ValueError):
        raise TypeError(f"{name} must be a pinhole camera with fx, fy, cx, cy; got {type(camera).__name__}") from None
    if not (math.isfinite(fx) and math.isfinite(fy) and fx > 0 and fy > 0):
        raise ValueError(f"{name}: fx and fy must be finite and > 0 px; got {fx!r}, {fy!r}")
    if not (math.isfinite(cx) and math.isfinite(cy)):
        raise ValueError(f"{name}: cx and cy must be finite px; got {cx!r}, {cy!r}")
    w, h = getattr(camera, "width", 0) or 0, getattr(camera, "height", 0) or 0
    if w > 0 and h > 0 and not (0 <= cx <= w and 0 <= cy <= h):
        raise ValueError(f"{name}: the principal point ({cx:g}, {cy:g}) px is outside the {w} x {h} image; cx, cy are "
                         "pixels from the top-left corner")  # fmt: skip


# ------------------------------------------------------------------------------------------------ parameters


def _scalar(v: Any, name: str) -> float:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        arr = np.asarray(v) if isinstance(v, np.ndarray) else None
        if arr is None or arr.shape != () or arr.dtype.kind not in "iuf":
            raise TypeError(f"{name} must be a number; got {type(v).__name__}")
    return float(v)


def probability(p: Any, name: str) -> float:
    """A probability strictly inside (0, 1) (a gate at 0 accepts nothing, at 1 everything)."""
    v = _scalar(p, name)
    if not 0.0 < v < 1.0:
        raise ValueError(f"{name} must be a probability in (0, 1); got {v!r}")
    return v


def positive(v: Any, name: str, upper: float = math.inf, unit: str = "") -> float:
    """A finite number in ``(0, upper]``."""
    x = _scalar(v, name)
    if not (math.isfinite(x) and 0.0 < x <= upper):
        bound = f"(0, {upper:g}]" if math.isfinite(upper) else "> 0 and finite"
        raise ValueError(f"{name} must be {bound}{' ' + unit if unit else ''}; got {x!r}")
    return x


def time_offset(v: Any, name: str) -> float:
    """A clock offset in seconds, finite and at most :data:`MAX_TIME_OFFSET_S` in magnitude."""
    x = _scalar(v, name)
    if not abs(x) <= MAX_TIME_OFFSET_S:
        raise ValueError(f"{name} must be a finite clock offset within ±{MAX_TIME_OFFSET_S:g} s; got {x!r}")
    return x


def finite_vector(v: Any, name: str, size: int, limit: float = math.inf, unit: str = "") -> NDArray[np.float64]:
    """``v`` as a fresh float64 array of shape (size,), finite and each ``|component| <= limit``."""
    a = np.array(_as_float(v, name), dtype=np.float64)
    if a.shape != (size,):
        raise ValueError(f"{name} must have shape ({size},); got {a.shape}")
    with np.errstate(invalid="ignore"):
        ok = bool((np.abs(a) <= limit).all()) if math.isfinite(limit) else bool(np.isfinite(a).all())
    if not ok:
        bound = f"within ±{limit:g}{' ' + unit if unit else ''}" if math.isfinite(limit) else "finite"
        raise ValueError(f"{name} must be {bound}; got {a.tolist()}")
    return a


def unit_quaternion(q: Any, name: str, tolerance: float = UNIT_TOLERANCE) -> NDArray[np.float64]:
    """A quaternion (4,) xyzw that should be unit, normalised: refused when not finite or when its norm is off 1 by
    more than ``tolerance`` (a zero quaternion, a missing or misplaced component)."""
    a = finite_vector(q, name, 4)
    with np.errstate(over="ignore"):
        nq = float(np.linalg.norm(a))
    if not abs(nq - 1.0) <= tolerance:
        raise ValueError(f"{name} must be a unit quaternion (x, y, z, w); got {a.tolist()} of norm {nq:.6g} (accepted "
                         f"within {tolerance:g} of 1 and normalised)")  # fmt: skip
    return a if abs(nq - 1.0) <= 1e-12 else a / nq  # unit to rounding: kept bit for bit


def covariance_matrix(P: Any, name: str, n: int, psd_tolerance: float = 1e-9) -> NDArray[np.float64]:
    """A covariance (n, n): finite, symmetric to ``1e-9`` of its largest entry (returned symmetrised), positive
    semi-definite (no eigenvalue below ``-psd_tolerance`` times the largest)."""
    a = np.array(_as_float(P, name), dtype=np.float64)
    if a.shape != (n, n):
        raise ValueError(f"{name} must have shape ({n}, {n}); got {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite (no NaN or infinity)")
    scale = float(np.abs(a).max())
    if scale > 1e150:
        raise ValueError(f"{name}: entries up to {scale:.3g} overflow the filter's arithmetic")
    if float(np.abs(a - a.T).max()) > 1e-9 * scale:
        raise ValueError(f"{name} must be symmetric; largest asymmetry {float(np.abs(a - a.T).max()):.3g}")
    s: NDArray[np.float64] = 0.5 * (a + a.T)
    if scale > 0:
        lo = float(np.linalg.eigvalsh(s).min())
        if lo < -psd_tolerance * scale:
            raise ValueError(f"{name} must be positive semi-definite; smallest eigenvalue {lo:.3g}")
    return s


def gravity_vector(gravity: object, name: str = "gravity") -> NDArray[np.float64]:
    """``gravity`` (3,) m/s², world frame, as a float64 array of magnitude in [1, 100] m/s² (its direction is
    checked against the accelerometer: :func:`gravity_up_problem`)."""
    g = np.array(gravity, dtype=np.float64) if not isinstance(gravity, str) else np.zeros(0)
    if g.shape != (3,):
        raise ValueError(f"{name} must have shape (3,); got {g.shape}")
    with np.errstate(over="ignore"):
        m = float(np.linalg.norm(g)) if np.isfinite(g).all() else math.nan
    if not 1.0 <= m <= 100.0:
        raise ValueError(f"{name}: magnitude must be in [1, 100] m/s² (9.81 on Earth); got {g.tolist()}")
    return g


def gravity_angle(f_w: NDArray[np.float64], gravity: NDArray[np.float64]) -> float:
    """Angle (deg) between a world-frame specific force at rest ``f_w`` and ``-gravity``: about 0 when gravity
    points the way the accelerometer says (atan2, accurate at small angles; 90 for a zero force, which has no
    direction)."""
    if not float(np.linalg.norm(f_w)):
        return 90.0
    return math.degrees(math.atan2(float(np.linalg.norm(np.cross(f_w, gravity))), float(-(f_w @ gravity))))


def gravity_up_problem(f_w: NDArray[np.float64], gravity: NDArray[np.float64], where: str) -> str | None:
    """The refusal of a ``gravity`` that points up: more than 90° from where the specific force at rest ``f_w``
    (world frame) says down is; None when fine."""
    angle = gravity_angle(f_w, gravity)
    if angle <= 90.0:
        return None
    return (f"{where}: gravity {gravity.tolist()} points up: at rest the specific force (accelerometer) rotated to the "
            f"world is {np.round(f_w, 3).tolist()} m/s², {angle:.0f} deg from -gravity; the world z axis points up "
            "and gravity is [0, 0, -9.81] (docs/fusion.md)")  # fmt: skip


def check_imu_noise(noise: ImuNoise, name: str = "imu_noise") -> None:
    """Every ``noise`` parameter finite and in ``[0, NOISE_LIMITS]`` (``update_rate`` in the filters' rate range)."""
    if not isinstance(noise, ImuNoise):
        raise TypeError(f"{name} must be an ImuNoise; got {type(noise).__name__}")
    for f in fields(noise):
        v = getattr(noise, f.name)
        hi = NOISE_LIMITS.get(f.name, 1e6)  # update_rate: Hz
        if not (isinstance(v, (int, float)) and math.isfinite(v) and 0 <= v <= hi):
            raise ValueError(f"{name}.{f.name} must be finite and in [0, {hi:g}]; got {v!r}")
    check_rate(noise.update_rate, f"{name}.update_rate")


# ------------------------------------------------------------------------------------------------ agreement

#: a rotation matrix or rigid transform read from a file or built by a caller is orthonormal to this (entries of
#: ``RᵀR − I``; files print 7 or more significant digits), and two that should be the same transform agree to this
#: (entries of ``R_a R_bᵀ − I``, translations relative to ``max(1, |t|)``)
RIGID_TOLERANCE = 1.0e-6


def check_stamps_agree(seconds: Any, stamps_ns: Any, seconds_name: str = "stamps",
                       ns_name: str = "stamps_ns") -> None:  # fmt: skip
    """Refuse float seconds ``seconds`` (N,) that are not the integer nanoseconds ``stamps_ns`` (N,) they repeat:
    each must be within half a nanosecond (the integer's rounding) plus two float64 units in the last place of the
    stamp (its own rounding: 0.5 µs at the Unix epoch) of ``stamps_ns · 1e-9``, computed exactly as whole seconds
    plus the remainder."""
    ns = np.asarray(stamps_ns).astype(np.int64, copy=False)
    whole, frac = np.divmod(ns, 1_000_000_000)
    exact = whole.astype(np.float64) + frac.astype(np.float64) * 1e-9
    t = np.asarray(seconds, dtype=np.float64)
    check_agree(seconds_name, t, ns_name + " · 1e-9", exact, 0.5e-9 + 2.0 * np.spacing(np.abs(exact)),
                what="the time of each sample", unit="s")  # fmt: skip


def check_rotation_matrix(r: Any, name: str, tolerance: float = RIGID_TOLERANCE) -> NDArray[np.float64]:
    """``r`` as a float64 (3, 3) proper rotation matrix: finite, ``RᵀR`` within ``tolerance`` of the identity (its
    columns repeat one another's information: unit length, orthogonal), determinant +1 (not a reflection)."""
    a = np.asarray(_as_float(r, name), dtype=np.float64)
    if a.shape != (3, 3) or not np.isfinite(a).all():
        raise ValueError(f"{name} must be a finite 3 x 3 rotation matrix; got shape {a.shape}")
    check_agree(f"{name}ᵀ{name}", a.T @ a, "the identity", np.eye(3), tolerance,
                what="a rotation's columns are orthonormal")  # fmt: skip
    if np.linalg.det(a) <= 0.0:
        raise ValueError(f"{name} must be a proper rotation (determinant +1); its determinant is "
                         f"{float(np.linalg.det(a)):.6g}: a reflection (a flipped axis)")  # fmt: skip
    return a


def check_rigid(T: Any, name: str, tolerance: float = RIGID_TOLERANCE) -> NDArray[np.float64]:
    """``T`` as a float64 (4, 4) rigid transform ``[[R, t], [0 0 0 1]]``: a proper rotation block
    (:func:`check_rotation_matrix`), a finite translation and the last row 0 0 0 1 (to ``tolerance``)."""
    a = np.asarray(_as_float(T, name), dtype=np.float64)
    if a.shape != (4, 4) or not np.isfinite(a).all():
        raise ValueError(f"{name} must be a finite 4 x 4 transform; got shape {a.shape}")
    check_agree(f"{name} last row", a[3], "0 0 0 1", [0.0, 0.0, 0.0, 1.0], tolerance,
                what="the last row of a rigid transform")  # fmt: skip
    check_rotation_matrix(a[:3, :3], f"{name} rotation block", tolerance)
    return a


def check_same_transform(name_a: str, T_a: NDArray[np.float64], name_b: str, T_b: NDArray[np.float64],
                         tolerance: float = RIGID_TOLERANCE) -> None:  # fmt: skip
    """Refuse two rigid transforms (4, 4) that should be the same and are not: their rotations within
    ``10 · tolerance`` (entries of ``R_a R_bᵀ − I``: each is orthonormal to ``tolerance`` only) and their
    translations within ``10 · tolerance · max(1, |t|)`` (in the translation's unit)."""
    tol = 10.0 * tolerance
    check_agree(f"{name_a} rotation", T_a[:3, :3] @ T_b[:3, :3].T, f"{name_b} rotation", np.eye(3), tol,
                what="one rotation: R_a R_bᵀ must be the identity")  # fmt: skip
    scale = max(1.0, float(np.abs(T_a[:3, 3]).max()), float(np.abs(T_b[:3, 3]).max()))
    check_agree(f"{name_a} translation", T_a[:3, 3], f"{name_b} translation", T_b[:3, 3], tol * scale,
                what="one transform")  # fmt: skip


# ------------------------------------------------------------------------------------------------ saved states


def _encode(obj: Any, out: list[bytes]) -> None:
    """A canonical byte encoding of a saved state: dicts by sorted key, sequences in order, numbers and arrays as
    float64 (so that a round trip through ``pickle`` or ``numpy.savez`` encodes the same), ``uint8`` buffers as
    their bytes."""
    if obj is None:
        out.append(b"N")
    elif isinstance(obj, str):
        out.append(b"S" + struct.pack("<q", len(obj)) + obj.encode("utf-8", "surrogatepass"))
    elif isinstance(obj, Mapping):
        out.append(b"D" + struct.pack("<q", len(obj)))
        for k in sorted(obj, key=str):
            _encode(str(k), out)
            _encode(obj[k], out)
    elif isinstance(obj, (bytes, bytearray, memoryview, np.bytes_)):  # a buffer saved as bytes: as its uint8 array
        b = bytes(obj)
        out.append(b"B" + struct.pack("<q", len(b)) + b)
    elif isinstance(obj, (list, tuple)):
        out.append(b"L" + struct.pack("<q", len(obj)))
        for v in obj:
            _encode(v, out)
    else:
        a = np.asarray(obj)
        if a.dtype == np.uint8 and a.ndim:
            out.append(b"B" + struct.pack("<q", a.size) + np.ascontiguousarray(a).tobytes())
        elif a.dtype.kind == "O":
            _encode(a.tolist(), out)
        elif a.dtype.kind == "S" and a.shape == ():
            _encode(a.item(), out)
        elif a.dtype.kind in "U":
            _encode(str(a), out)
        else:
            f = np.ascontiguousarray(a, dtype="<f8")
            out.append(b"F" + struct.pack("<q", f.ndim) + struct.pack(f"<{f.ndim}q", *f.shape) + f.tobytes())


def _digest(state: Mapping[str, Any]) -> str:
    parts: list[bytes] = []
    _encode({k: v for k, v in state.items() if k != "checksum"}, parts)
    return hashlib.blake2b(b"".join(parts), digest_size=16).hexdigest()


def seal(state: dict[str, Any]) -> dict[str, Any]:
    """``state`` with ``"checksum"``: the BLAKE2b-128 digest (hex) of everything else in it."""
    state["checksum"] = _digest(state)
    return state


def check_seal(state: Mapping[str, Any], name: str = "state") -> bool:
    """Verify the checksum of a saved state written by :func:`seal`; returns whether it had one (a state saved
    before checksums were written has none and is checked by its values only).

    Raises
    ------
    ValueError
        A checksum that does not match: the saved state was altered or corrupted after it was written.
    """
    if "checksum" not in state:
        return False
    got = state["checksum"]
    if isinstance(got, np.ndarray) and got.shape == ():
        got = got.item()
    try:
        want = _digest(state)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{name} holds values that are not a saved stream's: {str(exc)[:120]}") from None
    if got != want:
        raise ValueError(f"{name}: checksum mismatch: the saved state was altered or corrupted after it was written")
    return True


# ------------------------------------------------------------------------------------------------ set-ups


def rest_problem(rest_seconds: float | None, duration: float, where: str) -> str | None:
    """The refusal of a rest period (s) as long as the whole recording (``duration`` s): nothing would be left to
    fuse after the static alignment; None when fine."""
    if rest_seconds is None:
        return None
    if not (math.isfinite(rest_seconds) and rest_seconds >= 0):
        return f"{where}: rest_duration_s must be a finite number of seconds >= 0; got {rest_seconds!r}"
    if rest_seconds >= duration:
        return (f"{where}: rest_duration_s = {rest_seconds:g} s is not shorter than the recording ({duration:.3f} s of "
                "IMU data): nothing is left to fuse after the static alignment")  # fmt: skip
    return None


def rate_doubt(t: NDArray[np.float64], update_rate: float, where: str, tolerance: float = 0.1,
               rate_name: str = "imu.update_rate") -> Doubt | None:
    """A stated IMU ``update_rate`` (Hz) that contradicts the median spacing of the stamps ``t`` (s) by more than
    ``tolerance`` (relative)."""
    if len(t) < 3:
        return None
    measured = 1.0 / float(np.median(np.diff(t)))
    if abs(measured / update_rate - 1.0) <= tolerance:
        return None
    return Doubt("imu_rate_mismatch", f"{where}: {rate_name} is {update_rate:g} Hz but the IMU stamps are "
                 f"{measured:.4g} Hz apart (median): the filter's noise and steps assume the stated rate")  # fmt: skip


#: at rest a gyroscope reads its bias (MEMS: below 0.1 rad/s) plus white noise
_REST_RATE_LIMIT = 0.5  # rad/s
_NOISE_RATIO_LIMIT = 20.0  # measured / modelled noise at rest; deg/s reads 57x the model


def gyro_unit_doubt(gyro_rest: NDArray[np.float64], noise_density: float, rate: float, where: str) -> Doubt | None:
    """A gyroscope that reads like deg/s, seen over the rest period ``gyro_rest`` (k, 3) (rad/s expected): its mean
    above 0.5 rad/s (no gyroscope bias is that large), or its noise 20 times above the noise model's
    ``noise_density * sqrt(rate)`` (deg/s reads 57.3 times the rad/s values)."""
    if len(gyro_rest) < 10:
        return None
    mean = float(np.linalg.norm(gyro_rest.mean(axis=0)))
    std = float(np.sqrt(np.mean(np.var(gyro_rest, axis=0))))
    model = noise_density * math.sqrt(rate)
    if mean <= _REST_RATE_LIMIT and not (model > 0 and std > _NOISE_RATIO_LIMIT * model):
        return None
    return Doubt("gyro_unit", f"{where}: at rest the gyroscope reads {mean:.3g} rad/s on average with noise "
                 f"{std:.3g} rad/s ({std / model if model > 0 else math.inf:.3g} x the noise model): is it in deg/s? "
                 "the gyroscope must be in rad/s")  # fmt: skip


#: gyroscope rotation / camera rotation over a moving start-up above which the gyroscope reads like deg/s (57.3)
_ROTATION_RATIO_LIMIT = 10.0


def gyro_rotation_doubt(gyro_angle: float, camera_angle: float, where: str) -> Doubt | None:
    """A gyroscope that reads like deg/s on a *moving* sensor (no rest period): the rotation its rates integrate to
    between camera poses, ``gyro_angle`` (rad, summed over the intervals), more than 10 times the rotation the poses
    themselves show, ``camera_angle`` (rad): deg/s reads 57.3 times the rad/s values; biases and noise add a few
    per cent."""
    if not (camera_angle > 0 and gyro_angle > _ROTATION_RATIO_LIMIT * camera_angle):
        return None
    return Doubt("gyro_unit", f"{where}: between the start-up's camera poses the gyroscope turns "
                 f"{gyro_angle / camera_angle:.3g} x as far as the camera ({math.degrees(gyro_angle):.4g} deg against "
                 f"{math.degrees(camera_angle):.4g} deg): is it in deg/s? the gyroscope must be in rad/s")  # fmt: skip


def accel_unit_problem(accel_rest: NDArray[np.float64], gravity: NDArray[np.float64], where: str) -> str | None:
    """The refusal of an accelerometer in units of g: its mean magnitude over the rest period ``accel_rest`` (k, 3)
    within 20 % of 1 while ``|gravity|`` is an Earth gravity (m/s²)."""
    if not len(accel_rest):
        return None
    f = float(np.linalg.norm(accel_rest.mean(axis=0)))
    g = float(np.linalg.norm(gravity))
    if abs(f - 1.0) <= 0.2 and g > 5.0:
        return (f"{where}: at rest the accelerometer reads {f:.3f} while |gravity| is {g:.3f} m/s²: the accelerometer "
                "is in g; convert it to m/s² (multiply by 9.80665)")  # fmt: skip
    return None


def gap_doubt(dt: float, period: float, where: str, periods: float = 5.0) -> Doubt | None:
    """An IMU gap of ``dt`` seconds, more than ``periods`` nominal sample ``period`` s."""
    if dt <= periods * period:
        return None
    return Doubt("imu_gap", f"{where}: IMU gap of {dt:.6g} s ({dt / period:.3g} sample periods): the estimate drifts "
                 "across it")  # fmt: skip


# ------------------------------------------------------------------------------------------------ gravity direction

#: 1σ of an estimated gravity direction (rad) above which a start-up is refused: its attitude would be a guess
GRAVITY_SIGMA_REFUSE = math.radians(5.0)
#: ... and above which it is kept but doubted (a tilt error of this size biases the start)
GRAVITY_SIGMA_DOUBT = math.radians(1.0)


def rest_gravity_sigma(accel_rest: NDArray[np.float64], noise_density: float = 0.0, rate: float = 0.0) -> float:
    """The 1σ (rad, root of the tangent-plane covariance trace) of the gravity direction that the mean of the
    specific force samples ``accel_rest`` (N, 3), m/s², taken at rest gives: the covariance of the mean is the
    samples' own spread (their covariance; a vibrating or moving "rest" shows here), floored at the accelerometer's
    white noise ``noise_density² · rate`` per axis (m/s²/√Hz, Hz; what a single sample or a quiet spread still
    carries), over ``N``; its part across the mean direction ``f̂``, divided by ``|f|``.  Infinite when the mean
    specific force is zero (free fall: no direction)."""
    a = np.asarray(accel_rest, dtype=np.float64).reshape(-1, 3)
    n = len(a)
    if n == 0:
        return math.inf
    f = a.mean(axis=0)
    nf = float(np.linalg.norm(f))
    if not nf > 0.0:
        return math.inf
    fh = f / nf
    tangent = np.eye(3) - np.outer(fh, fh)
    spread = float(np.trace(tangent @ np.cov(a.T, ddof=1) @ tangent)) if n >= 2 else 0.0
    white = 2.0 * noise_density**2 * rate  # two tangent axes
    return math.sqrt(max(spread, white) / n) / nf


def gravity_sigma_doubt(sigma: float, where: str, how: str) -> Doubt | None:
    """The one rule for an estimated gravity direction of 1σ ``sigma`` (rad): refused above
    :data:`GRAVITY_SIGMA_REFUSE` (ValueError naming ``where`` and ``how`` it was estimated), a ``"gravity_sigma"``
    doubt above :data:`GRAVITY_SIGMA_DOUBT`, otherwise None."""
    deg = math.degrees(sigma)
    if not sigma <= GRAVITY_SIGMA_REFUSE:
        raise ValueError(f"{where}: the gravity direction is not determined by {how}: its standard deviation is "
                         f"{deg:.3g} deg (more than {math.degrees(GRAVITY_SIGMA_REFUSE):g} deg)")  # fmt: skip
    if sigma <= GRAVITY_SIGMA_DOUBT:
        return None
    return Doubt("gravity_sigma", f"{where}: the gravity direction from {how} is poorly determined: standard "
                 f"deviation {deg:.3g} deg (more than {math.degrees(GRAVITY_SIGMA_DOUBT):g} deg): the start attitude "
                 "is tilted by about as much")  # fmt: skip
