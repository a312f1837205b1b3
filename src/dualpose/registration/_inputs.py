"""Argument checking for the registration solvers: shapes, finiteness, weights and the minimum-data rule."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from dualpose._validation import as_array

__all__ = ["METHODS", "method_code", "prepare_single", "prepare_batch", "check_minimum_data"]

_EMPTY3 = np.zeros((0, 3))
_EMPTY = np.zeros(0)

#: solver names and their kernel codes
METHODS = {"dq": 0, "horn": 1, "svd": 2}


def method_code(method: str) -> int:
    try:
        return METHODS[method]
    except (KeyError, TypeError):
        raise ValueError(f"method must be one of {sorted(METHODS)}; got {method!r}") from None


def _vectors(x: Any, name: str, lead: int) -> NDArray[np.float64]:
    """``x`` as a C-contiguous float64 array of shape ``lead-dims + (n, 3)``; finite."""
    arr = as_array(x, name, 3)
    if arr.ndim != lead + 2:
        shape = "(n, 3)" if lead == 0 else "(B, n, 3)"
        raise ValueError(f"{name} must have shape {shape}; got shape {arr.shape}")
    return np.ascontiguousarray(arr)  # finiteness is checked by the solver kernel (one pass)


def _weights(w: Any, name: str, shape: tuple[int, ...]) -> NDArray[np.float64]:
    if w is None:
        return _EMPTY if shape == (0,) else np.ones(shape)
    try:
        arr = np.asarray(w, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real numeric array of shape {shape}") from None
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape} (one weight per correspondence); got shape {arr.shape}")
    if not np.isfinite(arr).all() or (arr < 0).any():
        raise ValueError(f"{name} must be finite and non-negative")
    return np.array(arr, dtype=np.float64, order="C")  # a writeable C-contiguous copy


def _unit(d: NDArray[np.float64], name: str, offset: int = 0) -> NDArray[np.float64]:
    if d.size == 0:
        return d
    if not np.isfinite(d).all():
        raise ValueError(f"{name} contains NaN or infinity")
    norms = np.sqrt(np.einsum("...i,...i->...", d, d))
    if (norms == 0).any():
        at = np.argwhere(norms == 0)[0]
        idx = tuple(int(i) + (offset if k == 0 and d.ndim == 3 else 0) for k, i in enumerate(at))
        raise ValueError(f"{name} must be nonzero direction vectors; entry {idx} is zero")
    result: NDArray[np.float64] = d / norms[..., None]
    return result


def _pair(
    a: Any, b: Any, names: tuple[str, str], lead: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    if (a is None) != (b is None):
        raise ValueError(f"{names[0]} and {names[1]} must be given together")
    if a is None:
        return None
    a, b = _vectors(a, names[0], lead), _vectors(b, names[1], lead)
    if a.shape != b.shape:
        raise ValueError(f"{names[0]} and {names[1]} must have the same shape; got {a.shape} and {b.shape}")
    return a, b


def check_minimum_data(n_points: int, n_directions: int) -> None:
    """Raise unless there are enough correspondences to fix a rotation: ``n_directions + max(n_points - 1, 0) >= 2``.

    That is, at least 3 points, or 1 point and 2 directions, or 2 points and 1 direction, or 2 directions
    (rotation only).  Correspondences with zero weight do not count.  Geometric degeneracy (collinear points,
    parallel directions) is not an error: it is reported in ``PoseEstimate.degeneracy``.
    """
    if n_directions + max(n_points - 1, 0) < 2:
        raise ValueError(
            "not enough correspondences to determine a rotation: need at least 3 points, 1 point + 2 directions, "
            f"2 points + 1 direction or 2 directions (with nonzero weight); got {n_points} point(s) and "
            f"{n_directions} direction(s)"
        )


#: ``(p0, p1, beta, n0, n1, alpha)``: points, point weights, unit directions, direction weights (float64)
Problem = tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
    NDArray[np.float64],
]


def _prepare(
    lead: int,
    model_points: Any,
    measured_points: Any,
    model_directions: Any,
    measured_directions: Any,
    point_weights: Any,
    direction_weights: Any,
    *,
    offset: int = 0,
) -> Problem:
    given_p = _pair(model_points, measured_points, ("model_points", "measured_points"), lead)
    given_n = _pair(model_directions, measured_directions, ("model_directions", "measured_directions"), lead)
    if given_p is not None:
        batch = given_p[0].shape[:lead]
    elif given_n is not None:
        batch = given_n[0].shape[:lead]
    else:
        raise ValueError("give model_points/measured_points, model_directions/measured_directions, or both")
    if given_p is not None and given_n is not None and given_p[0].shape[:lead] != given_n[0].shape[:lead]:
        raise ValueError(f"points have batch shape {given_p[0].shape[:lead]} but directions {given_n[0].shape[:lead]}")
    if given_p is None:
        p0 = p1 = np.zeros((*batch, 0, 3)) if batch else _EMPTY3
        if point_weights is not None:
            raise ValueError("point_weights given without points")
    else:
        p0, p1 = given_p
    if given_n is None:
        n0 = n1 = np.zeros((*batch, 0, 3)) if batch else _EMPTY3
        if direction_weights is not None:
            raise ValueError("direction_weights given without directions")
    else:
        n0, n1 = given_n
    beta = _weights(point_weights, "point_weights", p0.shape[:-1])
    alpha = _weights(direction_weights, "direction_weights", n0.shape[:-1])
    n0, n1 = _unit(n0, "model_directions", offset), _unit(n1, "measured_directions", offset)
    n_pts = p0.shape[-2] if point_weights is None else (beta > 0).sum(axis=-1)
    n_dirs = n0.shape[-2] if direction_weights is None else (alpha > 0).sum(axis=-1)
    if lead == 0 or np.ndim(n_pts) == np.ndim(n_dirs) == 0:
        check_minimum_data(int(n_pts), int(n_dirs))
        return p0, p1, beta, n0, n1, alpha
    bad = n_dirs + np.maximum(n_pts - 1, 0) < 2
    if np.any(bad):
        i = int(np.argmax(bad))
        try:
            check_minimum_data(int(np.broadcast_to(n_pts, bad.shape)[i]), int(np.broadcast_to(n_dirs, bad.shape)[i]))
        except ValueError as exc:
            raise ValueError(f"problem {i + offset}: {exc}") from None
    return p0, p1, beta, n0, n1, alpha


def prepare_single(*args: Any) -> Problem:
    """Checked ``(p0, p1, beta, n0, n1, alpha)`` for one problem (shapes (n, 3), (n,), (m, 3), (m,))."""
    return _prepare(0, *args)


def prepare_batch(*args: Any, offset: int = 0) -> Problem:
    """Checked ``(p0, p1, beta, n0, n1, alpha)`` for B problems (shapes (B, n, 3), (B, n), (B, m, 3), (B, m)).

    Messages number the problems from ``offset`` (the index of the first problem given in a larger batch)."""
    return _prepare(1, *args, offset=offset)
