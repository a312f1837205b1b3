"""Peer-library adapters for ``bench_algebra.py`` (benchmark-only; not part of the package).

Every adapter is a :class:`Peer`: ``prepare`` converts dualpose-layout inputs to the peer's layout and objects
(NOT timed), ``run`` is the timed call, ``back`` converts the peer's result to dualpose's layout (NOT timed) so
that it can be checked against dualpose's result before anything is timed.

Layouts: dualpose quaternions are xyzw, dual quaternions ``[real xyzw, dual xyzw]`` with ``dual = ½ t (x) real``,
twists ``[ω, v]``.  numpy-quaternion, quaternionic and pytransform3d quaternions are wxyz; pytransform3d dual
quaternions are ``[real wxyz, dual wxyz]`` with the same ``dual = ½ t (x) real``; scipy ``Rotation`` is xyzw and
``RigidTransform`` stores 4x4 matrices (``as_dual_quat()`` is dualpose's layout; ``as_exp_coords()`` is ``[ω, v]``).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Peer", "PEERS", "available", "versions"]

_WXYZ = [3, 0, 1, 2]
_XYZW = [1, 2, 3, 0]
_DQ_PT3D = [3, 0, 1, 2, 7, 4, 5, 6]  # dualpose [rx ry rz rw dx dy dz dw] -> pytransform3d [rw rx ry rz dw dx dy dz]
_DQ_OURS = [1, 2, 3, 0, 5, 6, 7, 4]  # inverse permutation

_LIBS = {
    "numpy-quaternion": "quaternion",
    "quaternionic": "quaternionic",
    "scipy": "scipy.spatial.transform",
    "pytransform3d": "pytransform3d",
}


@dataclass(frozen=True)
class Peer:
    """One peer implementation of an operation."""

    lib: str
    name: str
    prepare: Callable[[dict[str, np.ndarray]], tuple]
    run: Callable[..., Any]
    back: Callable[[Any], np.ndarray]
    note: str = ""


def available(lib: str) -> bool:
    """Whether the peer library ``lib`` (a key of the adapter table) imports."""
    try:
        importlib.import_module(_LIBS[lib])
    except ImportError:
        return False
    return True


def versions() -> dict[str, str]:
    """Installed versions of numpy, numba and every peer library."""
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for dist in ("dualpose", "numpy", "numba", "scipy", "numpy-quaternion", "quaternionic", "pytransform3d"):
        try:
            out[dist] = version(dist)
        except PackageNotFoundError:
            out[dist] = "not installed"
    return out


def wxyz(q: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(q[..., _WXYZ])


def xyzw(q: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(q)[..., _XYZW])


def dq_pt3d(dq: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(dq[..., _DQ_PT3D])


def dq_ours(dq: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(dq)[..., _DQ_OURS])


# --------------------------------------------------------------------------------------------------- library shims
def _nq():
    import quaternion

    return quaternion


def _qn():
    import quaternionic

    return quaternionic


def _R():
    from scipy.spatial.transform import Rotation

    return Rotation


def _RT():
    from scipy.spatial.transform import RigidTransform

    return RigidTransform


def _nq_arr(q: np.ndarray):
    return _nq().as_quat_array(wxyz(q))


def _nq_back(r: Any) -> np.ndarray:
    return xyzw(_nq().as_float_array(r))


def _qn_arr(q: np.ndarray):
    return _qn().array(wxyz(q))


def _qn_back(r: Any) -> np.ndarray:
    return xyzw(np.asarray(r))


def _pt3d_br():
    import pytransform3d.batch_rotations as br

    return br


def _pt3d_tr():
    import pytransform3d.trajectories as tr

    return tr


# ---------------------------------------------------------------------------------- screw-parameter glue (pt3d)
def pt3d_dq_from_twist(tw: np.ndarray) -> np.ndarray:
    """Twist ``[ω, v]`` -> pytransform3d dual quaternion via its screw parameters (the timed peer pipeline).

    Mapping (Lynch & Park): θ = |ω|, screw direction s = ω/θ, pitch h = (s·v)/θ, point on the axis q = s × v / θ
    (the component of the moment ``v/θ = q × s + h s`` perpendicular to s, solved for q ⊥ s).  All twists used in
    the benchmark have θ ≥ 0.05, so no pure-translation branch is needed.
    """
    w, v = tw[..., :3], tw[..., 3:]
    th = np.linalg.norm(w, axis=-1)
    s = w / th[..., None]
    h = np.einsum("...i,...i->...", s, v) / th
    q = np.cross(s, v) / th[..., None]
    return _pt3d_tr().dual_quaternions_from_screw_parameters(q, s, h, th)


def pt3d_twist_from_dq(dq_wxyz: np.ndarray) -> np.ndarray:
    """pytransform3d dual quaternion -> twist ``[ω, v]`` via its screw parameters (the timed peer pipeline).

    ``screw_parameters_from_dual_quaternions`` gives (q, s, h, θ); the twist is ``θ [s, q × s + h s]``
    (pytransform3d's ``screw_axis_from_screw_parameters`` times θ, written out for arrays).
    """
    q, s, h, th = _pt3d_tr().screw_parameters_from_dual_quaternions(dq_wxyz)
    out = np.empty(th.shape + (6,))
    out[..., :3] = s * th[..., None]
    out[..., 3:] = (np.cross(q, s) + h[..., None] * s) * th[..., None]
    return out


def scipy_sclerp(a: Any, b: Any, t: np.ndarray) -> Any:
    """ScLERP with scipy ``RigidTransform``: ``a * exp(t log(a⁻¹ b))`` through exponential coordinates.

    scipy has no batched ScLERP (``RigidTransform.__pow__`` takes one scalar exponent), so the documented
    identity ``p ** n == from_exp_coords(n * p.as_exp_coords())`` is used with a per-element ``t``.
    """
    rt = _RT()
    return a * rt.from_exp_coords(t[..., None] * (a.inv() * b).as_exp_coords())


def pure_to_twist(p: np.ndarray) -> np.ndarray:
    """Pure dual quaternion ``½(ω + ε v)`` (dualpose layout) -> twist ``[ω, v]``."""
    return np.ascontiguousarray(2.0 * np.concatenate([p[..., 0:3], p[..., 4:7]], axis=-1))


def twist_to_pure(tw: np.ndarray) -> np.ndarray:
    """Twist ``[ω, v]`` -> pure dual quaternion ``½(ω + ε v)`` (dualpose layout, scalar parts 0)."""
    out = np.zeros(tw.shape[:-1] + (8,))
    out[..., 0:3] = 0.5 * tw[..., :3]
    out[..., 4:7] = 0.5 * tw[..., 3:]
    return out


def _rt_dq(q: np.ndarray) -> np.ndarray:
    return np.asarray(q.as_dual_quat())


# ------------------------------------------------------------------------------------------------ adapter table
def _peers() -> dict[str, list[Peer]]:
    R, RT = _R, _RT
    nq, qn = _nq, _qn
    br, tr = _pt3d_br, _pt3d_tr
    P = Peer
    return {
        "quat_mul": [
            P("numpy-quaternion", "numpy-quaternion p*q", lambda d: (_nq_arr(d["p"]), _nq_arr(d["q"])),
              lambda a, b: a * b, _nq_back),
            P("quaternionic", "quaternionic p*q", lambda d: (_qn_arr(d["p"]), _qn_arr(d["q"])),
              lambda a, b: a * b, _qn_back),
            P("scipy", "scipy Rotation p*q", lambda d: (R().from_quat(d["p"]), R().from_quat(d["q"])),
              lambda a, b: a * b, lambda r: r.as_quat()),
            P("pytransform3d", "pt3d batch_concatenate_quaternions", lambda d: (wxyz(d["p"]), wxyz(d["q"])),
              lambda a, b: br().batch_concatenate_quaternions(a, b), xyzw),
        ],
        "quat_rotate": [
            P("numpy-quaternion", "numpy-quaternion q*v*conj(q)",
              lambda d: (_nq_arr(d["q"]), nq().from_vector_part(d["v"])),
              lambda q, v: q * v * q.conjugate(), lambda r: nq().as_vector_part(r),
              "v given as pure quaternions (converted outside the timing)"),
            P("quaternionic", "quaternionic q*v*conj(q)",
              lambda d: (_qn_arr(d["q"]), qn().array.from_vector_part(d["v"])),
              lambda q, v: q * v * q.conj(), lambda r: np.asarray(r)[..., 1:],
              "v given as pure quaternions (converted outside the timing)"),
            P("scipy", "scipy Rotation.apply", lambda d: (R().from_quat(d["q"]), d["v"]),
              lambda r, v: r.apply(v), np.asarray),
        ],
        "quat_exp": [
            P("numpy-quaternion", "numpy-quaternion np.exp", lambda d: (_nq_arr(d["q"]),), np.exp, _nq_back),
            P("quaternionic", "quaternionic np.exp", lambda d: (_qn_arr(d["q"]),), np.exp, _qn_back),
        ],
        "quat_log": [
            P("numpy-quaternion", "numpy-quaternion np.log", lambda d: (_nq_arr(d["q"]),), np.log, _nq_back),
            P("quaternionic", "quaternionic np.log", lambda d: (_qn_arr(d["q"]),), np.log, _qn_back),
        ],
        "quat_from_rotvec": [
            P("scipy", "scipy Rotation.from_rotvec", lambda d: (d["v"],), lambda v: R().from_rotvec(v),
              lambda r: r.as_quat()),
            P("numpy-quaternion", "numpy-quaternion from_rotation_vector", lambda d: (d["v"],),
              lambda v: nq().from_rotation_vector(v), _nq_back),
            P("quaternionic", "quaternionic from_rotation_vector", lambda d: (d["v"],),
              lambda v: qn().array.from_rotation_vector(v), _qn_back),
        ],
        "rotvec_from_quat": [
            P("scipy", "scipy Rotation.as_rotvec", lambda d: (R().from_quat(d["q"]),), lambda r: r.as_rotvec(),
              np.asarray, "Rotation built outside the timing"),
            P("numpy-quaternion", "numpy-quaternion as_rotation_vector", lambda d: (_nq_arr(d["q"]),),
              lambda q: nq().as_rotation_vector(q), np.asarray),
            P("quaternionic", "quaternionic to_rotation_vector", lambda d: (_qn_arr(d["q"]),),
              lambda q: q.to_rotation_vector, np.asarray),
        ],
        "matrix_from_quat": [
            P("scipy", "scipy Rotation.as_matrix", lambda d: (R().from_quat(d["q"]),), lambda r: r.as_matrix(),
              np.asarray, "Rotation built outside the timing"),
            P("numpy-quaternion", "numpy-quaternion as_rotation_matrix", lambda d: (_nq_arr(d["q"]),),
              lambda q: nq().as_rotation_matrix(q), np.asarray),
            P("quaternionic", "quaternionic to_rotation_matrix", lambda d: (_qn_arr(d["q"]),),
              lambda q: q.to_rotation_matrix, np.asarray),
            P("pytransform3d", "pt3d matrices_from_quaternions", lambda d: (wxyz(d["q"]),),
              lambda q: br().matrices_from_quaternions(q), np.asarray),
        ],
        "quat_from_matrix": [
            P("scipy", "scipy Rotation.from_matrix", lambda d: (d["m"],), lambda m: R().from_matrix(m),
              lambda r: r.as_quat()),
            P("numpy-quaternion", "numpy-quaternion from_rotation_matrix", lambda d: (d["m"],),
              lambda m: nq().from_rotation_matrix(m, nonorthogonal=False), _nq_back,
              "nonorthogonal=False (the fast direct method; the default eigen-solver is slower)"),
            P("quaternionic", "quaternionic from_rotation_matrix", lambda d: (d["m"],),
              lambda m: qn().array.from_rotation_matrix(m, nonorthogonal=False), _qn_back,
              "nonorthogonal=False (the fast direct method)"),
            P("pytransform3d", "pt3d quaternions_from_matrices", lambda d: (d["m"],),
              lambda m: br().quaternions_from_matrices(m), xyzw),
        ],
        "quat_slerp": [
            P("scipy", "scipy Slerp (build+eval)",
              lambda d: (np.arange(len(d["t"]) + 1.0), R().from_quat(np.concatenate([d["q0"], d["q1"][-1:]])),
                         np.arange(len(d["t"])) + d["t"]),
              lambda times, rots, tq: _slerp_scipy(times, rots, tq), lambda r: r.as_quat(),
              "keys q0[0..n-1], q1[n-1]; the benchmark pairs are consecutive keys (q1[i] = q0[i+1])"),
            P("numpy-quaternion", "numpy-quaternion np.slerp_vectorized",
              lambda d: (_nq_arr(d["q0"]), _nq_arr(d["q1"]), d["t"]),
              lambda a, b, t: np.slerp_vectorized(a, b, t), _nq_back,
              "the ufunc form of quaternion.slerp_evaluate, registered by numpy-quaternion"),
            P("quaternionic", "quaternionic.slerp", lambda d: (_qn_arr(d["q0"]), _qn_arr(d["q1"]), d["t"]),
              lambda a, b, t: qn().slerp(a, b, t), _qn_back),
        ],
        # ---- dual quaternions
        "dualquat_mul": [
            P("pytransform3d", "pt3d batch_concatenate_dual_quaternions",
              lambda d: (dq_pt3d(d["a"]), dq_pt3d(d["b"])),
              lambda a, b: tr().batch_concatenate_dual_quaternions(a, b), dq_ours),
            P("scipy", "scipy RigidTransform a*b", lambda d: (RT().from_dual_quat(d["a"]), RT().from_dual_quat(d["b"])),
              lambda a, b: a * b, _rt_dq, "4x4 matrix product internally; built outside the timing"),
        ],
        "dualquat_transform": [
            P("pytransform3d", "pt3d batch_dq_prod_vector", lambda d: (dq_pt3d(d["a"]), d["x"]),
              lambda a, x: tr().batch_dq_prod_vector(a, x), np.asarray),
            P("scipy", "scipy RigidTransform.apply", lambda d: (RT().from_dual_quat(d["a"]), d["x"]),
              lambda a, x: a.apply(x), np.asarray, "matrix form; built outside the timing"),
        ],
        "dualquat_from_twist": [
            P("scipy", "scipy RigidTransform.from_exp_coords", lambda d: (d["tw"],),
              lambda tw: RT().from_exp_coords(tw), _rt_dq, "result held as 4x4 matrices"),
            P("scipy", "scipy from_exp_coords().as_dual_quat()", lambda d: (d["tw"],),
              lambda tw: RT().from_exp_coords(tw).as_dual_quat(), np.asarray),
            P("pytransform3d", "pt3d screw params -> dual_quaternions_from_screw_parameters", lambda d: (d["tw"],),
              pt3d_dq_from_twist, dq_ours, "numpy glue twist -> (q, s, h, θ) included in the timing"),
            P("pytransform3d", "pt3d transforms_from_exponential_coordinates", lambda d: (d["tw"],),
              lambda tw: tr().transforms_from_exponential_coordinates(tw),
              lambda m: dq_ours(tr().dual_quaternions_from_transforms(m)), "result as 4x4 matrices"),
        ],
        "twist_from_dualquat": [
            P("scipy", "scipy RigidTransform.as_exp_coords", lambda d: (RT().from_dual_quat(d["a"]),),
              lambda t: t.as_exp_coords(), np.asarray, "RigidTransform (matrices) built outside the timing"),
            P("scipy", "scipy from_dual_quat().as_exp_coords()", lambda d: (d["a"],),
              lambda a: RT().from_dual_quat(a).as_exp_coords(), np.asarray),
            P("pytransform3d", "pt3d screw_parameters_from_dual_quaternions -> twist", lambda d: (dq_pt3d(d["a"]),),
              pt3d_twist_from_dq, np.asarray, "numpy glue (q, s, h, θ) -> twist included in the timing"),
            P("pytransform3d", "pt3d exponential_coordinates_from_transforms",
              lambda d: (tr().transforms_from_dual_quaternions(dq_pt3d(d["a"])),),
              lambda m: tr().exponential_coordinates_from_transforms(m), np.asarray,
              "4x4 matrices built outside the timing"),
        ],
        "dualquat_sclerp": [
            P("pytransform3d", "pt3d dual_quaternions_sclerp",
              lambda d: (dq_pt3d(d["a"]), dq_pt3d(d["b"]), d["t"]),
              lambda a, b, t: tr().dual_quaternions_sclerp(a, b, t), dq_ours),
            P("scipy", "scipy RigidTransform a*exp(t*log(a^-1 b))",
              lambda d: (RT().from_dual_quat(d["a"]), RT().from_dual_quat(d["b"]), d["t"]),
              scipy_sclerp, _rt_dq, "no batched ScLERP in scipy; exp-coords identity of RigidTransform.__pow__"),
        ],
    }


def _slerp_scipy(times: np.ndarray, rots: Any, tq: np.ndarray) -> Any:
    from scipy.spatial.transform import Slerp

    return Slerp(times, rots)(tq)


def _twist_peers_as_pure(peers: list[Peer], to_pure: bool) -> list[Peer]:
    """Re-express twist peers for dualquat_exp (input pure DQ) / dualquat_log (output pure DQ)."""
    out = []
    for p in peers:
        if to_pure:  # exp: the peer takes the twist 2*(real vec, dual vec) of the pure dual quaternion
            out.append(Peer(p.lib, p.name, (lambda d, p=p: p.prepare({"tw": pure_to_twist(d["pure"])})),
                            p.run, p.back, p.note))
        else:  # log: the peer's twist result is mapped to the pure dual quaternion ½(ω + ε v)
            out.append(Peer(p.lib, p.name, p.prepare, p.run, (lambda r, p=p: twist_to_pure(p.back(r))), p.note))
    return out


def _build() -> dict[str, list[Peer]]:
    table = _peers()
    table["dualquat_exp"] = _twist_peers_as_pure(table["dualquat_from_twist"], True)
    table["dualquat_log"] = _twist_peers_as_pure(table["twist_from_dualquat"], False)
    return table


PEERS: dict[str, list[Peer]] = _build()
