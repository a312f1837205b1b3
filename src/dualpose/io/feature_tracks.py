"""Feature-track files: GTSAM's EqVIO replay CSV and a plain documented track CSV.

**EqVIO replay CSV** (GTSAM 4.3, ``gtsam/Data/eqvio_processed_*.csv``): header
``row_type,t_abs,t_rel,seq,frame_idx,landmark_id,gx,gy,gz,ax,ay,az,bgx,bgy,bgz,bax,bay,baz,u_norm,v_norm,key,value``
and three kinds of rows: ``imu`` (``t_abs`` s, gyro rad/s, accel m/s², body = IMU frame), ``vision_feature`` (one
row per feature of a frame: ``landmark_id`` the track id, ``u_norm, v_norm`` undistorted normalised coordinates of
cam0) and ``meta`` (``key, value``: the camera ``T_ci_*`` -- cam0 pose in the IMU frame, translation and wxyz
quaternion --, intrinsics ``camera_f*``, the EqVIO filter's noise settings).  :func:`read_eqvio_csv` maps the meta
rows: ``eqf.measurement_noise_variance_norm`` → the feature σ², ``eqf.input_var_gyr`` / ``_acc`` /
``_gyr_bias_walk`` / ``_acc_bias_walk`` → the squared continuous-time densities of :class:`~dualpose.types.ImuNoise`.

**Plain track CSV** (:func:`read_track_csv`, :func:`iter_track_csv`, :func:`write_track_csv`): one observation per
line ``t, track_id, u, v`` (comma-separated; ``t`` camera-clock seconds, rows of a frame share ``t``, frames in time
order), an optional header line ``t,track_id,u,v`` and a comment line ``# coordinates: normalized`` or
``# coordinates: pixels``.  Pixels need a camera model to undistort them: the sensors file (``sensors.yaml`` /
Kalibr ``camchain.yaml``, :func:`~dualpose.io.read_rig_sensors`) of :func:`read_track_recording`.
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Iterator
from typing import NoReturn

import numpy as np
from numpy.typing import NDArray

import dualpose as dp
from dualpose.io._text import check_path, open_for_writing, open_input, parse_float_columns, parse_number, read_table
from dualpose.io.euroc import read_euroc_imu
from dualpose.io.sensors_yaml import read_rig_sensors
from dualpose.types.camera import PinholeModel
from dualpose.types.features import FeatureTracks, TrackFrame, TrackRecording
from dualpose.types.imu import ImuNoise

__all__ = ["read_eqvio_csv", "read_track_csv", "iter_track_csv", "write_track_csv", "read_track_recording",
           "is_eqvio_csv"]  # fmt: skip

EQVIO_HEADER = ("row_type,t_abs,t_rel,seq,frame_idx,landmark_id,gx,gy,gz,ax,ay,az,bgx,bgy,bgz,bax,bay,baz,u_norm,"
                "v_norm,key,value")  # fmt: skip
_TRACK_LAYOUT = "t, track_id, u, v"


def is_eqvio_csv(path: str | os.PathLike[str]) -> bool:
    """Whether the first line of ``path`` is the EqVIO replay CSV header."""
    try:
        with open_input(check_path(path)) as f:
            return f.readline(4096).decode("utf-8-sig").strip().replace(" ", "") == EQVIO_HEADER
    except (OSError, ValueError):
        return False


def read_eqvio_csv(path: str | os.PathLike[str], _checked: bool = False) -> TrackRecording:
    """Read GTSAM's EqVIO replay CSV (module docstring) into a :class:`~dualpose.types.TrackRecording`.

    Times are ``t_abs`` minus the first row's ``t_abs`` (``TrackRecording.t0`` keeps it); ``q_bc``, ``p_bc`` from
    ``T_ci_*``; the IMU noise and feature σ from the ``eqf.*`` variances (module docstring), the IMU rate from the
    samples.  Raises ``ValueError`` naming the file and line of a malformed row, a missing meta key or
    non-increasing stamps.  The rows are parsed in bulk; a file the bulk parse does not fully understand goes
    through the line-by-line reader, which names the file and line of the problem.
    """
    fast = None if _checked else _eqvio_fast(path)
    imu_lines: list[int] | None
    vis_lines: list[int] | None
    if fast is None:  # something unusual: the line-by-line reader names the file and line of the problem
        p, meta, imu, imu_lines, vis, vis_lines = _eqvio_checked(path)
    else:
        p, meta, imu, vis = fast
        imu_lines = vis_lines = None

    def meta_float(key: str, default: float | None = None) -> float:
        if key not in meta:
            if default is not None:
                return default
            raise ValueError(f"{p}: meta key {key!r} missing")
        try:
            v = float(meta[key])
        except ValueError:
            raise ValueError(f"{p}: meta {key} = {meta[key]!r} is not a number") from None
        if not math.isfinite(v):
            raise ValueError(f"{p}: meta {key} = {meta[key]!r} is not finite")
        return v

    t0 = float(imu[0, 0])
    t_imu = imu[:, 0] - t0
    bad = np.flatnonzero(np.diff(t_imu) <= 0)
    if len(bad):
        return _read_eqvio_checked(path) if imu_lines is None else _raise(
            f"{p}:{imu_lines[bad[0] + 1]}: IMU stamps must be strictly increasing")
    ft = vis[:, 0] - t0
    back = np.flatnonzero(np.diff(ft) < 0)
    if len(back):
        return _read_eqvio_checked(path) if vis_lines is None else _raise(
            f"{p}:{vis_lines[back[0] + 1]}: vision_feature rows must be in time order")
    ids_f = vis[:, 1]
    if np.any(ids_f != np.round(ids_f)):
        if vis_lines is None:
            return _read_eqvio_checked(path)
        _raise(f"{p}:{vis_lines[int(np.argmax(ids_f != np.round(ids_f)))]}: landmark_id must be a whole number")
    starts = np.flatnonzero(np.r_[True, np.diff(ft) > 0])
    offsets = np.r_[starts, len(ft)].astype(np.int64)
    frame_of = np.cumsum(np.r_[False, np.diff(ft) > 0])
    order = np.lexsort((ids_f, frame_of))  # stable: of two equal rows the later one comes second
    twice = np.flatnonzero((np.diff(frame_of[order]) == 0) & (np.diff(ids_f[order]) == 0))
    if len(twice):
        if vis_lines is None:
            return _read_eqvio_checked(path)
        row = int(order[twice[0] + 1])
        _raise(f"{p}:{vis_lines[row]}: landmark_id {int(ids_f[row])} appears twice in the frame at t_abs="
               f"{vis[row, 0]!r}")
    tracks = FeatureTracks(ft[starts], offsets, ids_f.astype(np.int64), vis[:, 2:4])
    q_bc = np.array([meta_float(f"T_ci_q{c}") for c in "xyzw"])
    p_bc = np.array([meta_float(f"T_ci_t{c}") for c in "xyz"])
    rate = 1.0 / float(np.median(np.diff(t_imu)))
    noise = ImuNoise(
        gyroscope_noise_density=math.sqrt(meta_float("eqf.input_var_gyr")),
        gyroscope_random_walk=math.sqrt(meta_float("eqf.input_var_gyr_bias_walk")),
        accelerometer_noise_density=math.sqrt(meta_float("eqf.input_var_acc")),
        accelerometer_random_walk=math.sqrt(meta_float("eqf.input_var_acc_bias_walk")),
        update_rate=rate,
    )
    focal = meta_float("camera_fx", float("nan"))
    return TrackRecording(
        t=t_imu, gyro=imu[:, 1:4], accel=imu[:, 4:7], tracks=tracks, q_bc=dp.quat_normalize(q_bc), p_bc=p_bc,
        imu_noise=noise, feature_sigma=math.sqrt(meta_float("eqf.measurement_noise_variance_norm")),
        focal_length=focal, t0=t0, meta=meta, name=os.path.basename(p),
    )  # fmt: skip


def _raise(message: str) -> NoReturn:
    raise ValueError(message)


def _read_eqvio_checked(path: str | os.PathLike[str]) -> TrackRecording:
    """:func:`read_eqvio_csv` through the line-by-line reader only (every error names file and line)."""
    return read_eqvio_csv(path, _checked=True)


def _eqvio_fast(
    path: str | os.PathLike[str],
) -> tuple[str, dict[str, str], NDArray[np.float64], NDArray[np.float64]] | None:
    """``(path, meta, imu (N, 7), vision (M, 4))`` parsed in bulk (numpy's C reader over the rows of each kind), or
    None when anything is unusual (the caller then uses the line-by-line reader)."""
    p = check_path(path)
    try:
        with open_input(p) as f:
            lines = f.read().decode("utf-8-sig").splitlines()
        if not lines or lines[0].strip().replace(" ", "") != EQVIO_HEADER:
            return None
        body = lines[1:]
        imu = [ln for ln in body if ln.startswith("imu,")]
        vis = [ln for ln in body if ln.startswith("vision_feature,")]
        meta_rows = [ln.split(",") for ln in body if ln.startswith("meta,")]
        if len(imu) + len(vis) + len(meta_rows) != sum(1 for ln in body if ln.strip()) or not imu or not vis:
            return None
        meta = {r[20].strip(): r[21].strip() for r in meta_rows if len(r) == 22}
        if len(meta) != len(meta_rows):
            return None
        a = np.loadtxt(imu, delimiter=",", usecols=(1, 6, 7, 8, 9, 10, 11), ndmin=2)
        b = np.loadtxt(vis, delimiter=",", usecols=(1, 5, 18, 19), ndmin=2)
    except (ValueError, OSError, UnicodeDecodeError):
        return None
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        return None
    return p, meta, a, b


def _eqvio_checked(
    path: str | os.PathLike[str],
) -> tuple[str, dict[str, str], NDArray[np.float64], list[int], NDArray[np.float64], list[int]]:
    """The line-by-line parse of :func:`read_eqvio_csv` (errors name file and line)."""
    table = read_table(path, ",", (22, 22), EQVIO_HEADER)
    p = table.path
    if ",".join(table.rows[0]).replace(" ", "") == EQVIO_HEADER:
        table.rows, table.linenos = table.rows[1:], table.linenos[1:]
    kinds = np.array([r[0] for r in table.rows])
    unknown = ~np.isin(kinds, ("imu", "vision_feature", "meta"))
    if unknown.any():
        k = int(np.argmax(unknown))
        raise table.error(k, f"unknown row_type {kinds[k]!r} (expected imu, vision_feature or meta)")
    meta = {table.rows[k][20]: table.rows[k][21] for k in np.flatnonzero(kinds == "meta")}

    def sub(kind: str, cols: list[int], what: str) -> tuple[NDArray[np.float64], list[int]]:
        idx = np.flatnonzero(kinds == kind)
        if len(idx) == 0:
            raise ValueError(f"{p}: no {kind!r} rows")
        rows = [[table.rows[k][c] for c in cols] for k in idx]
        part = type(table)(p, rows, [table.linenos[k] for k in idx], [])
        return parse_float_columns(part, slice(0, len(cols)), what), part.linenos

    imu, imu_lines = sub("imu", [1, 6, 7, 8, 9, 10, 11], "imu rows: t_abs, gx, gy, gz, ax, ay, az")
    vis, vis_lines = sub("vision_feature", [1, 5, 18, 19], "vision_feature rows: t_abs, landmark_id, u_norm, v_norm")
    return p, meta, imu, imu_lines, vis, vis_lines


def _coordinates(comments: list[str], path: str) -> str | None:
    for c in comments:
        key, _, value = c.partition(":")
        if key.strip().lower() == "coordinates":
            v = value.strip().lower()
            if v not in ("normalized", "pixels"):
                raise ValueError(f"{path}: '# coordinates:' must be 'normalized' or 'pixels'; got {v!r}")
            return v
    return None


def read_track_csv(
    path: str | os.PathLike[str], camera: PinholeModel | None = None, coordinates: str | None = None,
) -> FeatureTracks:
    """Read a plain track CSV (``t, track_id, u, v``; module docstring).

    ``coordinates`` (``"normalized"`` / ``"pixels"``) overrides the file's ``# coordinates:`` comment; pixels are
    undistorted with ``camera`` (a camera model of :mod:`dualpose.types`, required then).  Raises ``ValueError``
    naming file and line for a malformed row, frames out of time order or a track id repeated within a frame.
    """
    table = read_table(path, ",", (4, 4), _TRACK_LAYOUT)
    if [c.lower() for c in table.rows[0]] == ["t", "track_id", "u", "v"]:
        table.rows, table.linenos = table.rows[1:], table.linenos[1:]
        if not table.rows:
            raise ValueError(f"{table.path}: no data rows (expected {_TRACK_LAYOUT})")
    kind = coordinates or _coordinates(table.comments, table.path) or "normalized"
    if kind not in ("normalized", "pixels"):
        raise ValueError(f"coordinates must be 'normalized' or 'pixels'; got {kind!r}")
    data = parse_float_columns(table, slice(0, 4), _TRACK_LAYOUT)
    t, ids = data[:, 0], data[:, 1]
    if np.any(ids != np.round(ids)):
        raise table.error(int(np.argmax(ids != np.round(ids))), "track_id must be a whole number")
    back = np.flatnonzero(np.diff(t) < 0)
    if len(back):
        raise table.error(int(back[0]) + 1, "rows must be in time order (frames ascending)")
    starts = np.flatnonzero(np.r_[True, np.diff(t) > 0])
    offsets = np.r_[starts, len(t)].astype(np.int64)
    ids = ids.astype(np.int64)
    for a, b in zip(offsets[:-1], offsets[1:], strict=True):
        if len(np.unique(ids[a:b])) != b - a:
            _, first = np.unique(ids[a:b], return_index=True)
            dup = int(np.setdiff1d(np.arange(b - a), first)[0])
            raise table.error(int(a) + dup, f"track_id {ids[a + dup]} appears twice in the frame at t={t[a]}")
    if kind == "pixels":
        if camera is None:
            raise ValueError(f"{table.path}: pixel coordinates need a camera model (camera=...)")
        return FeatureTracks.from_pixels(t[starts], offsets, ids, data[:, 2:4], camera)
    return FeatureTracks(t[starts], offsets, ids, data[:, 2:4])


def iter_track_csv(path: str | os.PathLike[str]) -> Iterator[TrackFrame]:
    """The frames of a plain track CSV in normalised coordinates, one :class:`~dualpose.types.TrackFrame` at a
    time, reading the file line by line (for streaming; a frame is yielded when the next one starts)."""
    p = check_path(path)
    t_cur, ids, uv = None, [], []
    with open_input(p) as raw, io.TextIOWrapper(raw, encoding="utf-8-sig") as f:
        for lineno, line in enumerate(f, start=1):
            s = line.split("#", 1)[0].strip()
            if not s or s.replace(" ", "").lower() == "t,track_id,u,v":
                continue
            fields = s.split(",")
            try:
                if len(fields) != 4:
                    raise ValueError
                t, i, u, v = (parse_number(x.strip()) for x in fields)
                if not all(map(math.isfinite, (t, u, v))) or i != round(i):
                    raise ValueError
            except ValueError:
                raise ValueError(f"{p}:{lineno}: expected {_TRACK_LAYOUT} (finite numbers, whole track_id); "
                                 f"got {s[:80]!r}") from None  # fmt: skip
            if t_cur is not None and t < t_cur:
                raise ValueError(f"{p}:{lineno}: rows must be in time order")
            if t_cur is not None and t > t_cur:
                yield TrackFrame(t_cur, np.array(ids), np.array(uv))
                ids, uv = [], []
            t_cur = t
            ids.append(int(i))
            uv.append((u, v))
    if t_cur is not None:
        yield TrackFrame(t_cur, np.array(ids), np.array(uv))


def write_track_csv(path: str | os.PathLike[str], tracks: FeatureTracks, *, overwrite: bool = False) -> None:
    """Write ``tracks`` as a plain track CSV in normalised coordinates (17 significant digits)."""
    if not isinstance(tracks, FeatureTracks):
        raise TypeError(f"tracks must be a dualpose.types.FeatureTracks; got {type(tracks).__name__}")
    t = np.repeat(tracks.t, tracks.counts)
    with open_for_writing(path, overwrite) as f:
        f.write("# coordinates: normalized\nt,track_id,u,v\n")
        for a, i, (u, v) in zip(t.tolist(), tracks.track_id.tolist(), tracks.uv.tolist(), strict=True):
            f.write(f"{a!r},{i},{u!r},{v!r}\n")


def read_track_recording(tracks: str | os.PathLike[str], imu: str | os.PathLike[str], sensors: str | os.PathLike[str],
                         camera: str = "cam0", pixel_sigma: float = 1.0) -> TrackRecording:  # fmt: skip
    """A :class:`~dualpose.types.TrackRecording` from a plain track CSV, an EuRoC IMU CSV and a sensors file.

    The sensors file (``sensors.yaml`` / Kalibr ``camchain.yaml``) gives the camera model (to undistort pixel
    tracks), the camera–IMU extrinsic ``T_cam_imu`` of ``camera``, the IMU noise and the time shift; the feature σ
    is ``pixel_sigma`` over the focal length.  Times: IMU stamps (ns → s) and track stamps relative to the first
    IMU stamp.
    """
    rig = read_rig_sensors(sensors)
    cam = rig.camera(camera)
    if camera not in rig.T_cam_imu:
        raise ValueError(f"{rig.path}: no camera–IMU extrinsic (T_cam_imu) for {camera!r}")
    T_ci = np.asarray(rig.T_cam_imu[camera])  # x_c = T x_imu
    R_bc = T_ci[:3, :3].T
    p_bc = -R_bc @ T_ci[:3, 3]
    data = read_euroc_imu(imu)
    t0 = float(data.stamps[0])
    tr = read_track_csv(tracks, camera=cam)
    tr = FeatureTracks(tr.t - t0, tr.offsets, tr.track_id, tr.uv)
    noise = rig.imu_noise or ImuNoise()
    return TrackRecording(
        t=data.stamps - t0, gyro=data.gyro, accel=data.accel, tracks=tr, q_bc=dp.quat_from_matrix(R_bc), p_bc=p_bc,
        imu_noise=noise, feature_sigma=pixel_sigma / cam.fx, time_offset=rig.time_offsets.get(camera, 0.0),
        focal_length=cam.fx, t0=t0, name=os.path.basename(check_path(tracks)),
    )  # fmt: skip
