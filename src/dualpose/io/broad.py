"""Reader for BROAD trials (Berlin Robust Orientation Estimation Assessment Dataset; Laidig et al. 2021).

A BROAD trial file (MATLAB ``.mat``; v5 read with :func:`scipy.io.loadmat`, v7.3/HDF5 with ``h5py`` if installed)
holds, per sample at ``sampling_rate`` (285.714 Hz):

=============  =========  ==========================================================================================
file field     unit       meaning
=============  =========  ==========================================================================================
``imu_gyr``    rad/s      angular rate, IMU (body) axes
``imu_acc``    m/s²       specific force, IMU axes
``imu_mag``    µT         magnetic field, IMU axes (optional: a 6D trial without it loads with NaN ``mag``)
``opt_quat``   --         optical reference orientation of the IMU w.r.t. ENU, **wxyz (scalar first)**; NaN when
                          the markers were not tracked
``opt_pos``    m          optical reference position, ENU (optional: NaN when absent)
``movement``   bool       samples of the movement phase (errors are evaluated there; BROAD's protocol)
=============  =========  ==========================================================================================

:func:`load_broad` converts the quaternion to dualpose's **xyzw** layout: ``quat`` is ``q_b^i`` (IMU to ENU), so
``v_ENU = quat_rotate(quat, v_IMU)`` and ``q̇ = ½ q (x) ω`` with ``ω = gyr`` (body frame).  Nothing else is changed.

Refused (ValueError naming the file and the field, docs/broad.md): a file that is not a readable MATLAB file, a
missing required field, no samples, a ``sampling_rate`` that is not a finite positive number, IMU values above any
sensor's range (``|gyr| > 1000`` rad/s, ``|acc| > 10⁴`` m/s², ``|mag| > 10⁴`` µT: corrupt samples), and a
reference quaternion that is neither unit nor NaN (e.g. an all-zero ``opt_quat``).  NaN IMU samples are kept as
they are (the AHRS and :func:`dualpose.sim.broad_vision.recording_from_broad` refuse them, naming the field).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dualpose.io._text import open_input

__all__ = ["BroadTrial", "load_broad"]

_FIELDS = ("imu_gyr", "imu_acc", "imu_mag", "opt_quat", "opt_pos", "movement", "sampling_rate")
#: fields a trial may lack (filled with NaN)
_OPTIONAL = ("imu_mag", "opt_pos")
#: largest plausible |value| of the IMU fields (rad/s, m/s², µT)
_IMU_LIMITS = {"imu_gyr": 1.0e3, "imu_acc": 1.0e4, "imu_mag": 1.0e4}


@dataclass(frozen=True)
class BroadTrial:
    """One BROAD trial in dualpose conventions (arrays have n samples on axis 0).

    Attributes
    ----------
    name : str
        File stem, e.g. ``"01_undisturbed_slow_rotation_A"``.
    rate : float
        Sampling rate, Hz.
    gyr, acc, mag : ndarray, shape (n, 3)
        rad/s, m/s², µT in IMU axes.
    quat : ndarray, shape (n, 4)
        Reference orientation ``q_b^i`` (IMU to ENU), **xyzw**; NaN rows where the optical system lost track.
    pos : ndarray, shape (n, 3)
        Reference position (m, ENU).
    movement : ndarray of bool, shape (n,)
        Movement-phase mask.
    info : str
        The file's description text.
    description : str
        From ``trials.json`` next to the file, if present.
    groups : tuple of str
        From ``trials.json`` (e.g. ``"rotation"``, ``"fast"``, ``"disturbed"``).
    has_mag : bool
        False when the file has no ``imu_mag`` field (``mag`` is then all NaN).
    """

    name: str
    rate: float
    gyr: np.ndarray
    acc: np.ndarray
    mag: np.ndarray
    quat: np.ndarray
    pos: np.ndarray
    movement: np.ndarray
    info: str = ""
    description: str = ""
    groups: tuple[str, ...] = field(default_factory=tuple)
    has_mag: bool = True

    @property
    def time(self) -> NDArray[np.float64]:
        """Sample times, seconds from the first sample, shape (n,)."""
        return np.arange(self.gyr.shape[0]) / self.rate

    @property
    def static_start(self) -> int:
        """Number of samples before the first movement-phase sample (the static start used for the gyro bias)."""
        idx = np.flatnonzero(self.movement)
        return int(idx[0]) if idx.size else self.movement.size

    def require_finite(self, fields: tuple[str, ...] = ("imu_gyr", "imu_acc"), start: int = 0) -> None:
        """Raise ``ValueError`` naming the file's field and the trial's own sample number (0-based) of the first
        non-finite sample of ``fields`` (of ``imu_gyr``, ``imu_acc``, ``imu_mag``) from sample ``start`` on."""
        arrays = {"imu_gyr": self.gyr, "imu_acc": self.acc, "imu_mag": self.mag}
        for key in fields:
            bad = np.flatnonzero(~np.isfinite(arrays[key][start:]).all(axis=1))
            if bad.size:
                k = start + int(bad[0])
                where = f" from sample {start} on, where the run starts" if start else ""
                raise ValueError(f"field {key}: sample {k} (t = {k / self.rate:.6f} s) is not finite ({bad.size} "
                                 f"such{where}); drop or interpolate the missing samples")  # fmt: skip


def _read_mat(path: Path) -> dict[str, NDArray[Any]]:
    with open_input(path, "a MATLAB .mat file") as fh:  # refuses a directory or a device; a pipe is read once
        head = fh.read(512)
        fh.seek(0)
        if b"\x89HDF" in head or head[:8] == b"\x89HDF\r\n\x1a\n":
            try:
                import h5py
            except ImportError:
                msg = f"{path} is a MATLAB v7.3 (HDF5) file; reading it needs h5py (pip install h5py)"
                raise ImportError(msg) from None
            with h5py.File(fh, "r") as f:
                out = {}
                for k in _FIELDS + ("info",):
                    if k in f:
                        a = np.asarray(f[k])
                        out[k] = a.T if a.ndim == 2 else a  # MATLAB writes column-major
                if "info" in out and out["info"].dtype.kind in "ui":
                    out["info"] = np.array(["".join(map(chr, out["info"].ravel()))])
                return out
        from scipy.io import loadmat

        raw = loadmat(fh)  # type: ignore[arg-type]  # scipy-stubs admit paths only; loadmat reads file objects
    # a MATLAB sparse matrix is a numeric matrix stored another way: read it as the dense one
    return {k: v.toarray() if hasattr(v, "toarray") else v for k, v in raw.items()}


def load_broad(path: str | Path) -> BroadTrial:
    """Load one BROAD trial file (``.mat``) with its units and frames documented in :class:`BroadTrial`.

    Parameters
    ----------
    path : str or Path
        A BROAD ``.mat`` file.  A ``trials.json`` in the same directory, if present, supplies the description and
        groups.

    Returns
    -------
    BroadTrial
        Quaternions converted from BROAD's wxyz to dualpose's xyzw.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    ValueError
        When a required field is missing or has the wrong shape.
    """
    name = os.fspath(path)  # as given: messages name the file the way the user did
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no BROAD trial file at {name}")
    open_input(name, "a MATLAB .mat file").close()  # a directory or a device: named as such, nothing read
    try:
        raw = _read_mat(path)
    except ImportError:
        raise
    except Exception as exc:  # scipy.io / h5py raise assorted errors on files that are not MATLAB files
        raise ValueError(f"{name}: not a readable MATLAB .mat file ({exc})") from None
    missing = [k for k in _FIELDS if k not in raw and k not in _OPTIONAL]
    if missing:
        raise ValueError(f"{name} is not a BROAD trial: missing fields {missing}")
    gyr_shape = np.shape(raw["imu_gyr"])
    n = gyr_shape[0] if len(gyr_shape) else 0
    if len(gyr_shape) == 2 and gyr_shape[0] == 3 and gyr_shape[1] > 3:
        raise ValueError(f"{name}: field imu_gyr has shape {gyr_shape}: samples must be rows, ({gyr_shape[1]}, 3); "
                         "is it transposed?")  # fmt: skip
    if n < 2:
        raise ValueError(f"{name}: field imu_gyr: no samples (got shape {np.shape(raw['imu_gyr'])})")
    rate = np.asarray(raw["sampling_rate"], dtype=np.float64).ravel()
    if rate.size != 1 or not (np.isfinite(rate[0]) and rate[0] > 0):
        raise ValueError(f"{name}: field sampling_rate must be one finite number > 0 (Hz); got {rate.tolist()}")

    def vec(key: str, width: int) -> NDArray[np.float64]:
        if key not in raw:
            return np.full((n, width), np.nan)
        try:
            a = np.asarray(raw[key], dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{name}: field {key} must be numeric") from None
        if a.shape != (n, width):
            hint = "; is it transposed?" if a.shape == (width, n) else ""
            raise ValueError(f"{name}: field {key} must have shape ({n}, {width}) like imu_gyr; got {a.shape}{hint}")
        limit = _IMU_LIMITS.get(key)
        if limit is not None:
            bad = np.flatnonzero((np.abs(a) > limit).any(axis=1))  # infinities too; NaN samples are kept
            if bad.size:
                k = int(bad[0])
                raise ValueError(f"{name}: field {key}: sample {k} has |value| {np.abs(a[k]).max():.3g} > "
                                 f"{limit:g}: a corrupt sample ({bad.size} such)")  # fmt: skip
        return a

    wxyz = vec("opt_quat", 4)
    tracked = np.isfinite(wxyz).all(axis=1)
    norm = np.linalg.norm(wxyz[tracked], axis=1)
    off = np.flatnonzero(np.abs(norm - 1.0) > 0.01)
    if off.size:
        k = int(np.flatnonzero(tracked)[off[0]])
        raise ValueError(
            f"{name}: field opt_quat: {off.size} of {int(tracked.sum())} reference quaternions are not unit "
            f"(sample {k} has norm {np.linalg.norm(wxyz[k]):.3g}); untracked samples must be NaN"
        )
    info = raw.get("info", "")
    info = str(np.asarray(info).ravel()[0]) if np.size(info) else ""
    description, groups = "", ()
    meta = path.parent / "trials.json"
    if meta.is_file():
        entry = json.loads(meta.read_text()).get("trials", {}).get(path.stem, {})
        description, groups = entry.get("description", ""), tuple(entry.get("groups", ()))
    movement = np.asarray(raw["movement"]).ravel().astype(bool)
    if movement.shape != (n,):
        raise ValueError(f"{name}: field movement must have {n} samples; got {movement.shape}")
    return BroadTrial(
        name=path.stem,
        rate=float(rate[0]),
        gyr=vec("imu_gyr", 3),
        acc=vec("imu_acc", 3),
        mag=vec("imu_mag", 3),
        quat=np.ascontiguousarray(wxyz[:, [1, 2, 3, 0]]),
        pos=vec("opt_pos", 3),
        movement=movement,
        info=info,
        description=description,
        groups=groups,
        has_mag="imu_mag" in raw,
    )
