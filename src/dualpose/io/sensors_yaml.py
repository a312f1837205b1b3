"""Camera-rig sensor files in YAML: the ``sensors.yaml`` layout and Kalibr's ``camchain.yaml`` (Furgale et al. 2013).

``sensors.yaml``::

    target: {type: aprilgrid, tag_rows: 6, tag_cols: 6, tag_size_m: 0.088, tag_spacing_ratio: 0.3}
    imu0: {rate_hz: 200.0, gyroscope_noise_density: ..., gyroscope_random_walk: ...,
           accelerometer_noise_density: ..., accelerometer_random_walk: ..., gravity_m_s2: 9.81}
    cam0:
      resolution: [752, 480]
      rate_hz: 20.0
      camera_model: pinhole
      intrinsics_fx_fy_cx_cy: [fx, fy, cx, cy]
      distortion_model: radial-tangential          # or equidistant (any name camera_from_parameters accepts)
      distortion_k1_k2_p1_p2: [k1, k2, p1, p2]     # equidistant: distortion_k1_k2_k3_k4
    T_cam0_cam1: {data: [16 numbers, row-major]}   # x_cam0 = T x_cam1 (any T_camA_camB)

Kalibr ``camchain.yaml`` (cameras ``cam0``, ``cam1``, ...)::

    cam0:
      camera_model: pinhole
      intrinsics: [fu, fv, pu, pv]
      distortion_model: radtan                     # or equidistant
      distortion_coeffs: [k1, k2, r1, r2]
      resolution: [752, 480]
      T_cam_imu: [[...], [...], [...], [...]]      # x_cam = T x_imu
      timeshift_cam_imu: 0.0
    cam1:
      ...
      T_cn_cnm1: [[...], ...]                      # x_cam1 = T x_cam0

Noise terms are Kalibr's continuous-time densities (:class:`~dualpose.types.imu.ImuNoise`).  Every error names the
file and the line of the offending (or, for a missing key, the enclosing) entry.
"""

from __future__ import annotations

import math
import os
import re
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from dualpose.io._text import check_path, open_input
from dualpose.io.recording import RecordingError
from dualpose.types import _inputs
from dualpose.types.camera_models import (
    CAMERA_MODEL_NAMES,
    DistortedCamera,
    EquidistantCamera,
    RadTanCamera,
    camera_from_parameters,
)
from dualpose.types.imu import ImuNoise
from dualpose.types.target import RigSensors

__all__ = ["read_rig_sensors"]

_CAMERA_KEY = re.compile(r"^cam\d+$")
_PAIR_KEY = re.compile(r"^T_(cam\d+)_(cam\d+)$")
_NOISE_KEYS = (
    "gyroscope_noise_density",
    "gyroscope_random_walk",
    "accelerometer_noise_density",
    "accelerometer_random_walk",
)


#: the path of an entry in the YAML document (mapping keys from the top)
_Keys = tuple[str, ...]


class _Doc:
    """The parsed YAML with the node tree, so that errors can name the line of a key."""

    def __init__(self, path: str) -> None:
        self.path = path
        try:
            with open_input(path) as f:
                text = f.read().decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise RecordingError(f"{path}: not a UTF-8 text file ({exc})") from None
        try:
            self.node = yaml.compose(text, Loader=yaml.SafeLoader)
            self.data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f":{mark.line + 1}" if mark is not None else ""
            raise RecordingError(f"{path}{where}: YAML syntax error: {getattr(exc, 'problem', None) or exc}") from None
        if not isinstance(self.data, dict):
            raise RecordingError(f"{path}:1: the sensor file must hold a mapping at the top level")

    def line(self, keys: _Keys) -> int:
        """1-based line of the entry at ``keys`` (the deepest one that exists)."""
        node, line = self.node, 1
        for key in keys:
            if not isinstance(node, yaml.MappingNode):
                break
            for k, v in node.value:
                if k.value == str(key):
                    node, line = v, k.start_mark.line + 1
                    break
            else:
                break
        return line

    def error(self, keys: _Keys, message: str) -> RecordingError:
        return RecordingError(f"{self.path}:{self.line(keys)}: {'.'.join(map(str, keys))}: {message}")

    def get(self, keys: _Keys, kind: str, required: bool = True, default: Any = None) -> Any:
        """The value at ``keys`` checked as ``kind``: "map" (dict), "number" (float or int), "int", "numbers:N"
        (float64 (N,)), "matrix4" (float64 (4, 4)), "str"; ``default`` when absent and not ``required``."""
        value = self.data
        for key in keys:
            if not isinstance(value, dict) or key not in value:
                if required:
                    raise self.error(keys, "missing")
                return default
            value = value[key]
        return self.check(keys, value, kind)

    def check(self, keys: _Keys, value: Any, kind: str) -> Any:
        if kind == "map":
            if not isinstance(value, dict):
                raise self.error(keys, f"must be a mapping; got {type(value).__name__}")
            return value
        if kind == "str":
            if not isinstance(value, str):
                raise self.error(keys, f"must be a string; got {value!r}")
            return value
        if kind in ("number", "int"):
            value = _yaml11_number(value)
            ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
            if not ok or (kind == "int" and (not isinstance(value, int) or value <= 0)):
                what = "a positive integer" if kind == "int" else "a finite number"
                raise self.error(keys, f"must be {what}; got {value!r}")
            return value
        if kind.startswith("numbers:"):
            n = int(kind.split(":")[1])
            a = self._array(keys, value)
            if a.shape != (n,):
                raise self.error(keys, f"must be a list of {n} numbers; got shape {a.shape}")
            return a
        if kind == "matrix4":
            if isinstance(value, dict) and "data" in value:
                keys, value = keys + ("data",), value["data"]
            a = self._array(keys, value)
            if a.shape == (16,):
                a = a.reshape(4, 4)
            if a.shape != (4, 4):
                raise self.error(keys, f"must be a 4x4 matrix (4 rows or 16 numbers, row-major); got shape {a.shape}")
            try:
                return _inputs.check_rigid(a, "T")
            except ValueError as exc:
                raise self.error(keys, f"must be a rigid transform: {exc}") from None
        raise AssertionError(kind)  # pragma: no cover

    def _array(self, keys: _Keys, value: Any) -> NDArray[np.float64]:
        if isinstance(value, list):
            value = [[_yaml11_number(v) for v in r] if isinstance(r, list) else _yaml11_number(r) for r in value]
        flat = value if isinstance(value, list) else [value]
        if any(isinstance(v, (str, bool)) for v in flat):
            raise self.error(keys, f"must hold numbers; got {value!r}")
        try:
            a = np.array(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise self.error(keys, f"must hold numbers; got {value!r}") from None
        if not np.isfinite(a).all():
            raise self.error(keys, "must hold finite numbers")
        return a


def _yaml11_number(value: Any) -> Any:
    """A number written without a decimal point in an exponent (``1e-4``), which YAML 1.1 (PyYAML) reads as a
    string, as the float it denotes; anything else unchanged."""
    if isinstance(value, str):
        try:
            return float(value) if re.fullmatch(r"\s*[-+]?\d+(\.\d*)?[eE][-+]?\d+\s*", value) else value
        except ValueError:  # pragma: no cover - the pattern is a float literal
            return value
    return value


def _camera(doc: _Doc, name: str) -> RadTanCamera | EquidistantCamera:
    cam = doc.get((name,), "map")
    kalibr = "intrinsics" in cam
    model_key = "distortion_model"
    model = doc.get((name, model_key), "str")
    if model.strip().lower() not in CAMERA_MODEL_NAMES:
        accepted = sorted(CAMERA_MODEL_NAMES)
        raise doc.error((name, model_key), f"unknown distortion model {model!r}; accepted: {accepted}")
    projection = doc.get((name, "camera_model"), "str", required=False, default="pinhole")
    if projection.strip().lower() != "pinhole":
        raise doc.error((name, "camera_model"), f"only the pinhole projection is supported; got {projection!r}")
    if kalibr:
        intr = doc.get((name, "intrinsics"), "numbers:4")
        dist = doc.get((name, "distortion_coeffs"), "numbers:4")
    else:
        intr = doc.get((name, "intrinsics_fx_fy_cx_cy"), "numbers:4")
        want = "distortion_" + "_".join(CAMERA_MODEL_NAMES[model.strip().lower()].DISTORTION_NAMES)
        dkeys = [str(k) for k in cam if str(k).startswith("distortion_k")]
        for dkey in dkeys:  # the key names the coefficients, the model names them too: they must agree
            if dkey != want:
                raise doc.error((name, dkey), f"the key names the coefficients of another distortion model than "
                                f"distortion_model {model!r}, whose coefficients are {want}")  # fmt: skip
        dist = doc.get((name, want), "numbers:4")
    res = doc.get((name, "resolution"), "numbers:2")
    if not (res == np.round(res)).all() or (res <= 0).any():
        raise doc.error((name, "resolution"), f"must be two positive whole numbers of pixels; got {res.tolist()}")
    try:
        return camera_from_parameters(model, intr, dist, int(res[0]), int(res[1]))
    except ValueError as exc:
        raise doc.error((name,), str(exc)) from None


def _inverse(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of a rigid transform (4, 4): ``[[Rᵀ, −Rᵀ t], [0, 1]]``."""
    inv = np.eye(4)
    inv[:3, :3] = T[:3, :3].T
    inv[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return inv


def _check_repeated_extrinsics(doc: _Doc, names: list[str], extrinsics: dict[tuple[str, str], NDArray[np.float64]],
                               t_cam_imu: dict[str, NDArray[np.float64]]) -> None:  # fmt: skip
    """Refuse camera extrinsics the file states twice that disagree: ``T_camA_camB`` and ``T_camB_camA`` (inverses
    of each other), and Kalibr's ``T_cn_cnm1`` next to both cameras' ``T_cam_imu`` (``T_cn_imu T_cnm1_imu⁻¹``);
    to :data:`~dualpose.types._inputs.RIGID_TOLERANCE` (:func:`~dualpose.types._inputs.check_same_transform`)."""
    pairs: list[tuple[str, NDArray[np.float64], str, NDArray[np.float64], tuple[str, ...]]] = []
    for (a, b), T in extrinsics.items():
        if (b, a) in extrinsics and a < b:
            pairs.append((f"T_{a}_{b}", T, f"T_{b}_{a}⁻¹", _inverse(extrinsics[(b, a)]), (f"T_{b}_{a}",)))
    for i, n in enumerate(names[1:], 1):
        prev = names[i - 1]
        if (n, prev) in extrinsics and n in t_cam_imu and prev in t_cam_imu and "T_cn_cnm1" in doc.data[n]:
            via_imu = t_cam_imu[n] @ _inverse(t_cam_imu[prev])
            pairs.append((f"{n}.T_cn_cnm1", extrinsics[(n, prev)], f"{n}.T_cam_imu {prev}.T_cam_imu⁻¹", via_imu,
                          (n, "T_cn_cnm1")))  # fmt: skip
    for name_a, T_a, name_b, T_b, keys in pairs:
        try:
            _inputs.check_same_transform(name_a, T_a, name_b, T_b)
        except ValueError as exc:
            raise doc.error(keys, str(exc)) from None


def read_rig_sensors(path: str | os.PathLike[str]) -> RigSensors:
    """Read a rig's sensor file, ``sensors.yaml`` or Kalibr ``camchain.yaml`` layout (module docstring).

    Returns
    -------
    RigSensors
        Cameras (``RadTanCamera`` / ``EquidistantCamera``) by name in file order; ``imu_noise`` None and
        ``imu_rate`` / ``gravity_magnitude`` NaN when the file has no ``imu0`` section (camchain).

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    RecordingError
        ``path:line: ...`` for a YAML syntax error, a missing or malformed key, an unknown distortion model.
    """
    p = check_path(path)
    doc = _Doc(p)
    names = [k for k in doc.data if isinstance(k, str) and _CAMERA_KEY.match(k)]
    if not names:
        raise RecordingError(f"{p}:1: no camera sections (cam0, cam1, ...)")
    cameras: dict[str, DistortedCamera] = {n: _camera(doc, n) for n in names}
    rates = {n: float(doc.get((n, "rate_hz"), "number", required=False, default=math.nan)) for n in names}
    extrinsics: dict[tuple[str, str], NDArray[np.float64]] = {}
    for key in doc.data:
        m = _PAIR_KEY.match(str(key))
        if m:
            for cam in m.groups():
                if cam not in cameras:
                    raise doc.error((key,), f"names camera {cam!r}, which the file does not define")
            cam_a, cam_b = m.groups()
            extrinsics[(cam_a, cam_b)] = doc.get((key,), "matrix4")
    t_cam_imu, shifts = {}, {}
    for i, n in enumerate(names):
        if "T_cam_imu" in doc.data[n]:
            t_cam_imu[n] = doc.get((n, "T_cam_imu"), "matrix4")
        if "timeshift_cam_imu" in doc.data[n]:
            shifts[n] = float(doc.get((n, "timeshift_cam_imu"), "number"))
        if "T_cn_cnm1" in doc.data[n]:
            if i == 0:
                raise doc.error((n, "T_cn_cnm1"), "the first camera has no previous camera")
            extrinsics[(n, names[i - 1])] = doc.get((n, "T_cn_cnm1"), "matrix4")
    _check_repeated_extrinsics(doc, names, extrinsics, t_cam_imu)
    noise, rate, gravity = None, math.nan, math.nan
    if "imu0" in doc.data:
        doc.get(("imu0",), "map")
        rate = float(doc.get(("imu0", "rate_hz"), "number", required=False, default=math.nan))
        if "update_rate" in doc.data["imu0"]:
            update_rate = float(doc.get(("imu0", "update_rate"), "number"))
            if math.isfinite(rate):  # one rate under two keys
                try:
                    _inputs.check_agree("imu0.rate_hz", rate, "imu0.update_rate", update_rate,
                                        _inputs.RIGID_TOLERANCE * abs(update_rate), what="the IMU rate", unit="Hz")
                except ValueError as exc:
                    raise doc.error(("imu0", "update_rate"), str(exc)) from None
            rate = update_rate
        if math.isfinite(rate) and not rate > 0:  # NaN: not given
            key = "update_rate" if "update_rate" in doc.data["imu0"] else "rate_hz"
            raise doc.error(("imu0", key), f"must be > 0 Hz; got {rate}")
        values = {k: float(doc.get(("imu0", k), "number")) for k in _NOISE_KEYS}
        for k, v in values.items():
            if v < 0:
                raise doc.error(("imu0", k), f"must be >= 0; got {v}")
        default = ImuNoise()
        noise = ImuNoise(**values, update_rate=rate if math.isfinite(rate) else default.update_rate)
        gravity = float(doc.get(("imu0", "gravity_m_s2"), "number", required=False, default=math.nan))
        if math.isfinite(gravity) and not gravity > 0:
            raise doc.error(("imu0", "gravity_m_s2"), f"must be > 0 (the magnitude, m/s²); got {gravity}")
    target = dict(doc.get(("target",), "map", required=False, default={}))
    return RigSensors(
        cameras=cameras, camera_rates=rates, imu_noise=noise, imu_rate=rate, gravity_magnitude=gravity,
        camera_extrinsics=extrinsics, T_cam_imu=t_cam_imu, time_offsets=shifts, target=target, path=p,
    )  # fmt: skip
