"""Thin object facade over the functional API: :class:`Quaternion` and :class:`DualQuaternion`.

Each object holds one float64 array -- a batch of quaternions ``(..., 4)`` ordered ``[x, y, z, w]`` or of dual
quaternions ``(..., 8)`` ordered ``[real xyzw, dual xyzw]`` with ``dual = ½ t (x) real`` -- and every method is a
single call into :mod:`dualpose.algebra.quat` or :mod:`dualpose.algebra.dualquat`, so the objects add no numerics
of their own (see ``docs/conventions.md`` for the layouts and frames).

Batch semantics follow :class:`scipy.spatial.transform.Rotation`:

* ``shape`` is the batch shape (the array's shape without the trailing component axis); a single element has
  ``shape == ()``, ``len()`` and indexing of a single element raise ``TypeError``.
* ``obj[key]`` indexes the batch axes only (never the component axis) and returns the same class;
  iteration walks the first batch axis.
* ``obj.array`` is the stored ndarray itself (no copy); ``np.asarray(obj)`` gives the same array.
* ``a * b`` composes (Hamilton / dual-quaternion product, ``a`` applied after ``b``), ``a ** t`` is the power.

Equality: ``==`` is *not* overloaded and keeps Python's identity semantics (as scipy's ``Rotation`` does).
Comparing batches of floats has three reasonable meanings -- exact array equality, equality up to the double cover
``q ~ -q``, and equality within a tolerance -- and an elementwise ``==`` returning an array would also make
``if a == b:`` raise.  Use :meth:`Quaternion.approx_equal` / :meth:`DualQuaternion.approx_equal` (double-cover
aware, explicit tolerance) or compare ``.array`` with numpy.

Arithmetic with plain ndarrays is refused (``__array_ufunc__ = None``): ``ndarray * Quaternion`` raises
``TypeError`` instead of silently multiplying components.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, Literal, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose import _native
from dualpose._validation import as_array
from dualpose.algebra import dualquat as _dualquat
from dualpose.algebra import interop as _interop
from dualpose.algebra import quat as _q

__all__ = ["Quaternion", "DualQuaternion"]

_B = TypeVar("_B", bound="_Batch")



def _shape(shape: int | tuple[int, ...] | None) -> tuple[int, ...]:
    if shape is None:
        return ()
    if isinstance(shape, (int, np.integer)):
        return (int(shape),)
    return tuple(int(s) for s in shape)


def _arr(x: Any) -> Any:
    """Unwrap facade objects so the functional API receives ndarrays (array-likes pass through)."""
    return x._a if isinstance(x, _Batch) else x


class _Batch(_native.Facade):
    """Shared container behaviour: one float64 array whose last axis holds the components.

    The native base (:class:`dualpose._native.Facade`) stores the array ``_a`` and implements ``a * b`` (see
    ``_set_product`` below the classes): a product of two single elements is computed by the kernel's row directly
    and held inline until ``_a`` is first read, so composing single poses in a loop allocates no array.
    """

    __slots__ = ()
    __array_ufunc__ = None  # ndarray (op) obj -> NotImplemented -> TypeError, never componentwise arithmetic
    _size: int = 0
    _layout: str = ""
    _noun: str = ""

    def __init__(self, array: ArrayLike | _Batch, *, copy: bool = True) -> None:
        if isinstance(array, _Batch):
            array = array._a
        a = as_array(array, f"{type(self).__name__} array", self._size)
        if copy and isinstance(array, np.ndarray):
            a = a.copy()
        self._a = a

    # -- container protocol -------------------------------------------------------------------------------------
    @property
    def array(self) -> NDArray[np.float64]:
        """The stored float64 array of shape ``shape + (size,)`` -- the object itself, not a copy."""
        return self._a

    @property
    def shape(self) -> tuple[int, ...]:
        """Batch shape: the array shape without the trailing component axis (``()`` for a single element)."""
        return self._a.shape[:-1]

    @property
    def single(self) -> bool:
        """True when the object holds one element (``shape == ()``)."""
        return self._a.ndim == 1

    def __len__(self) -> int:
        if self._a.ndim == 1:
            raise TypeError(f"Single {self._noun} has no len().")
        result: int = self._a.shape[0]
        return result

    def __bool__(self) -> bool:  # like scipy: an object is truthy even when its batch is empty
        return True

    def __getitem__(self: _B, key: Any) -> _B:
        if self._a.ndim == 1:
            raise TypeError(f"Single {self._noun} is not subscriptable.")
        # Index the batch axes only: the trailing full slice always lands on the component axis or before it.
        key = key if isinstance(key, tuple) else (key,)
        return type(self)._wrap(self._a[key + (slice(None),)])

    def __iter__(self: _B) -> Iterator[_B]:
        if self._a.ndim == 1:
            raise TypeError(f"Single {self._noun} is not iterable.")
        wrap = type(self)._wrap
        return (wrap(row) for row in self._a)

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray[np.float64]:
        if copy:
            return np.array(self._a, dtype=dtype, copy=True)
        if dtype is None or np.dtype(dtype) == self._a.dtype:
            return self._a
        if copy is False:
            raise ValueError(f"cannot convert a {type(self).__name__} to {np.dtype(dtype)} without a copy")
        return self._a.astype(dtype)

    def copy(self: _B) -> _B:
        """A new object holding a copy of the array."""
        return type(self)._wrap(self._a.copy())

    def __repr__(self) -> str:
        # Whole elements only (never elide components); large batches show the first and last two elements of the
        # batch in C order.
        def fmt(x: np.ndarray) -> str:
            return np.array2string(x, precision=6, separator=", ", threshold=self._size + 1, max_line_width=200)

        head = f"{type(self).__name__}(shape={self.shape}, layout={self._layout}"
        if self._a.ndim == 1:
            return f"{head}, {fmt(self._a)})"
        rows = self._a.reshape(-1, self._size)
        if len(rows) == 0:
            return f"{head})"
        shown = [fmt(r) for r in rows] if len(rows) <= 4 else [*map(fmt, rows[:2]), "...", *map(fmt, rows[-2:])]
        return head + ",\n    " + ",\n    ".join(shown) + ")"

    def approx_equal(self, other: _Batch | ArrayLike, atol: float = 1e-12) -> NDArray[np.float64]:
        """Elementwise equality up to the double cover: ``min(max|a − b|, max|a + b|) <= atol``.

        The maximum runs over the component axis, so ``a`` and ``−a`` (the same rotation / rigid transform) compare
        equal.  ``atol`` is an absolute tolerance on the components (for unit quaternions a component error ε is
        a rotation error of about 2ε radians).  Batch shapes broadcast; returns a bool array of the batch shape.
        """
        a = self._a
        b = as_array(_arr(other), "other", self._size)
        d = np.minimum(np.abs(a - b).max(axis=-1), np.abs(a + b).max(axis=-1))
        result: NDArray[np.float64] = d <= atol
        return result


class Quaternion(_Batch):
    """A batch of quaternions, ``(..., 4)`` ordered ``[x, y, z, w]`` (scalar last), Hamilton product.

    ``Quaternion(array, copy=True)`` wraps any ``(..., 4)`` array-like (copied unless ``copy=False``); no
    normalization is applied (use :meth:`normalize`).  Unit quaternions rotate vectors actively,
    ``v' = q (x) v (x) q*``; a pose's orientation maps body (child) coordinates to world (parent) coordinates.
    ``p * q`` is the Hamilton product (rotate by ``q``, then by ``p``); ``q ** t`` the principal power.
    """

    __slots__ = ()
    _size = 4
    _layout = "xyzw"
    _noun = "quaternion"

    # -- constructors -------------------------------------------------------------------------------------------
    @classmethod
    def from_rotvec(cls, rotvec: ArrayLike) -> Quaternion:
        """From rotation vectors ``θu`` (..., 3), radians (:func:`~dualpose.algebra.quat.quat_from_rotvec`)."""
        return cls._wrap(_q.quat_from_rotvec(rotvec))

    @classmethod
    def from_matrix(cls, matrix: ArrayLike) -> Quaternion:
        """From rotation matrices (..., 3, 3); the result has ``w >= 0`` (Shepperd's method)."""
        return cls._wrap(_q.quat_from_matrix(matrix))

    @classmethod
    def from_axis_angle(cls, axis: ArrayLike, angle: ArrayLike) -> Quaternion:
        """From axes (..., 3; normalized inside) and angles (...), radians."""
        return cls._wrap(_q.quat_from_axis_angle(axis, angle))

    @classmethod
    def identity(cls, shape: int | tuple[int, ...] | None = None) -> Quaternion:
        """Identity ``[0, 0, 0, 1]``; ``shape=None`` gives a single element, an int ``n`` a batch of ``n``."""
        return cls._wrap(_q.quat_identity(_shape(shape)))

    @classmethod
    def random(
        cls, shape: int | tuple[int, ...] | None = None, rng: np.random.Generator | int | None = None
    ) -> Quaternion:
        """Uniformly distributed (Haar) rotations: normalized standard-normal 4-vectors (either sign).

        ``rng`` is a :class:`numpy.random.Generator` or a seed.
        """
        g = np.random.default_rng(rng)
        return cls._wrap(_q.quat_normalize(g.standard_normal((*_shape(shape), 4))))

    @classmethod
    def from_scipy(cls, rotation: Any) -> Quaternion:
        """From a :class:`scipy.spatial.transform.Rotation` (sign as scipy stores it).  Imports scipy."""
        return cls._wrap(_interop.quat_from_scipy(rotation))

    # -- conversions --------------------------------------------------------------------------------------------
    def as_rotvec(self) -> NDArray[np.float64]:
        """Rotation vectors (..., 3) with angle in [0, π], radians."""
        return _q.rotvec_from_quat(self._a)

    def as_matrix(self) -> NDArray[np.float64]:
        """Rotation matrices (..., 3, 3) with ``R @ v == self.apply(v)``."""
        return _q.matrix_from_quat(self._a)

    def as_axis_angle(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Unit axes (..., 3) and angles (...) in [0, π]; the identity gets axis ``[1, 0, 0]``."""
        return _q.axis_angle_from_quat(self._a)

    def as_scipy(self) -> Any:
        """A :class:`scipy.spatial.transform.Rotation` of the same batch shape.  Imports scipy."""
        return _interop.scipy_from_quat(self._a)

    # -- algebra ------------------------------------------------------------------------------------------------
    def __pow__(self, t: ArrayLike) -> Quaternion:
        if isinstance(t, _Batch):
            return NotImplemented
        return Quaternion._wrap(_q.quat_pow(self._a, t))

    def apply(self, vectors: ArrayLike) -> NDArray[np.float64]:
        """Rotate vectors (..., 3) actively: ``q (x) v (x) q*`` (non-unit ``q`` is normalized)."""
        return _q.quat_rotate(self._a, vectors)

    def inv(self) -> Quaternion:
        """Inverse ``q* / |q|²``."""
        return Quaternion._wrap(_q.quat_inv(self._a))

    def conj(self) -> Quaternion:
        """Conjugate ``[-x, -y, -z, w]``."""
        return Quaternion._wrap(_q.quat_conj(self._a))

    def norm(self) -> NDArray[np.float64]:
        """Euclidean norms, shape ``self.shape``."""
        return _q.quat_norm(self._a)

    def normalize(self) -> Quaternion:
        """``q / |q|`` (zero raises ``ValueError``)."""
        return Quaternion._wrap(_q.quat_normalize(self._a))

    def canonical(self) -> Quaternion:
        """The sign representative with ``w > 0`` (see :func:`~dualpose.algebra.quat.quat_canonical`)."""
        return Quaternion._wrap(_q.quat_canonical(self._a))

    def slerp(self, other: Quaternion | ArrayLike, t: ArrayLike) -> Quaternion:
        """Shorter-arc spherical interpolation from ``self`` (t = 0) to ``other`` (t = 1)."""
        return Quaternion._wrap(_q.quat_slerp(self._a, _arr(other), t))

    def angle_to(self, other: Quaternion | ArrayLike) -> NDArray[np.float64]:
        """Rotation angle between ``self`` and ``other`` in [0, π] radians (sign-invariant, atan2 form)."""
        return _q.quat_angle(self._a, _arr(other))

    def integrate(self, omega: ArrayLike, dt: ArrayLike, frame: Literal["space", "body"] = "space") -> Quaternion:
        """Exact constant-rate step: ``exp(ω dt/2) (x) q`` (``frame="space"``) or ``q (x) exp(ω dt/2)`` ("body")."""
        return Quaternion._wrap(_q.quat_integrate(self._a, omega, dt, frame))

    def mean(self, weights: ArrayLike | None = None) -> Quaternion:
        """Weighted mean orientation over the last batch axis (Markley et al. 2007); ``w >= 0``."""
        return Quaternion._wrap(_q.quat_mean(self._a, weights))


class DualQuaternion(_Batch):
    """A batch of dual quaternions, ``(..., 8)`` = ``[real xyzw, dual xyzw]`` with ``dual = ½ t (x) real``.

    ``DualQuaternion(array, copy=True)`` wraps any ``(..., 8)`` array-like without normalizing it.  A unit dual
    quaternion is the rigid transform ``p -> R p + t`` mapping body (child) coordinates to world (parent)
    coordinates; ``a * b`` composes (apply ``b``, then ``a``), ``a ** t`` is the screw power.
    """

    __slots__ = ()
    _size = 8
    _layout = "[real xyzw, dual xyzw]"
    _noun = "dual quaternion"

    # -- constructors -------------------------------------------------------------------------------------------
    @classmethod
    def from_qt(cls, q: Quaternion | ArrayLike, t: ArrayLike) -> DualQuaternion:
        """From rotations ``q`` (..., 4, xyzw) and translations ``t`` (..., 3): ``[q, ½ t (x) q]``."""
        return cls._wrap(_dualquat.dualquat_from_qt(_arr(q), t))

    @classmethod
    def from_matrix(cls, matrix: ArrayLike) -> DualQuaternion:
        """From homogeneous transforms (..., 4, 4) ``[[R, t], [0, 1]]``."""
        return cls._wrap(_dualquat.dualquat_from_matrix(matrix))

    @classmethod
    def from_twist(cls, twist: ArrayLike) -> DualQuaternion:
        """From exponential coordinates ``[ω, v]`` (..., 6): ``exp([[ω×, v], [0, 0]])`` (scipy ``from_exp_coords``)."""
        return cls._wrap(_dualquat.dualquat_from_twist(twist))

    @classmethod
    def from_screw(
        cls, axis: ArrayLike, point: ArrayLike, pitch_distance: ArrayLike, angle: ArrayLike
    ) -> DualQuaternion:
        """From Walker's screw parameters (Walker 1991 eqs. (8)-(12)).

        ``axis`` n (..., 3, unit), ``point`` p (..., 3) on the axis, ``pitch_distance`` d (...; translation along n,
        length units -- not the pitch ratio d/θ), ``angle`` θ (..., radians).
        """
        return cls._wrap(_dualquat.dualquat_from_screw(axis, point, pitch_distance, angle))

    @classmethod
    def identity(cls, shape: int | tuple[int, ...] | None = None) -> DualQuaternion:
        """Identity ``[0, 0, 0, 1, 0, 0, 0, 0]``; ``shape=None`` gives a single element."""
        return cls._wrap(_dualquat.dualquat_identity(_shape(shape)))

    @classmethod
    def random(
        cls,
        shape: int | tuple[int, ...] | None = None,
        rng: np.random.Generator | int | None = None,
        translation_scale: float = 1.0,
    ) -> DualQuaternion:
        """Haar-random rotations with standard-normal translations times ``translation_scale``."""
        g = np.random.default_rng(rng)
        s = _shape(shape)
        q = _q.quat_normalize(g.standard_normal((*s, 4)))
        return cls._wrap(_dualquat.dualquat_from_qt(q, translation_scale * g.standard_normal((*s, 3))))

    @classmethod
    def from_scipy(cls, transform: Any) -> DualQuaternion:
        """From a :class:`scipy.spatial.transform.RigidTransform` (sign as scipy's matrix conversion picks it)."""
        return cls._wrap(_interop.dualquat_from_scipy(transform))

    # -- conversions --------------------------------------------------------------------------------------------
    def as_matrix(self) -> NDArray[np.float64]:
        """Homogeneous transforms (..., 4, 4)."""
        return _dualquat.matrix_from_dualquat(self._a)

    def as_qt(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Rotations (..., 4, xyzw) and translations (..., 3)."""
        return _dualquat.qt_from_dualquat(self._a)

    def as_twist(self) -> NDArray[np.float64]:
        """Exponential coordinates ``[ω, v]`` (..., 6) (scipy ``as_exp_coords`` order)."""
        return _dualquat.twist_from_dualquat(self._a)

    def as_screw(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Walker screw parameters ``(axis n, point p ⊥ n, distance d, angle θ)``.

        Shapes (..., 3), (..., 3), (...), (...); ``d`` is a length, θ in radians (Walker 1991 eqs. (8)-(12)).
        """
        return _dualquat.screw_from_dualquat(self._a)

    @property
    def rotation(self) -> Quaternion:
        """The real part as a :class:`Quaternion` (a view of the stored array, not a copy)."""
        return Quaternion._wrap(self._a[..., :4])

    @property
    def translation(self) -> NDArray[np.float64]:
        """Translations (..., 3), ``t = 2 vec(dual (x) real*)`` for unit input."""
        return _dualquat.qt_from_dualquat(self._a)[1]

    def as_scipy(self) -> Any:
        """A :class:`scipy.spatial.transform.RigidTransform` of the same batch shape.  Imports scipy."""
        return _interop.scipy_from_dualquat(self._a)

    # -- algebra ------------------------------------------------------------------------------------------------
    def __pow__(self, t: ArrayLike) -> DualQuaternion:
        if isinstance(t, _Batch):
            return NotImplemented
        return DualQuaternion._wrap(_dualquat.dualquat_pow(self._a, t))

    def apply(self, points: ArrayLike) -> NDArray[np.float64]:
        """Transform points (..., 3): ``R p + t``."""
        return _dualquat.dualquat_transform(self._a, points)

    def inv(self) -> DualQuaternion:
        """Multiplicative inverse (any nonzero real part); for unit input the inverse transform ``p -> Rᵀ(p − t)``."""
        return DualQuaternion._wrap(_dualquat.dualquat_inv(self._a))

    def conj(self) -> DualQuaternion:
        """Quaternion conjugate of both parts, ``[r*, s*]`` (the inverse of a unit dual quaternion)."""
        return DualQuaternion._wrap(_dualquat.dualquat_conj(self._a))

    def norm(self) -> NDArray[np.float64]:
        """Dual-number norms ``[|r|, r·d/|r|]``, shape ``self.shape + (2,)``; ``[1, 0]`` for unit input."""
        return _dualquat.dualquat_norm(self._a)

    def normalize(self) -> DualQuaternion:
        """``S / |S|`` (dual-number division): unit real part, dual part ⊥ real part, same rotation and translation."""
        return DualQuaternion._wrap(_dualquat.dualquat_normalize(self._a))

    def canonical(self) -> DualQuaternion:
        """The sign representative whose real part has ``w > 0``."""
        return DualQuaternion._wrap(_dualquat.dualquat_canonical(self._a))

    def sclerp(self, other: DualQuaternion | ArrayLike, t: ArrayLike) -> DualQuaternion:
        """Screw linear interpolation from ``self`` (t = 0) to ``other`` (t = 1)."""
        return DualQuaternion._wrap(_dualquat.dualquat_sclerp(self._a, _arr(other), t))

    def integrate(self, twist: ArrayLike, dt: ArrayLike, frame: Literal["space", "body"] = "space") -> DualQuaternion:
        """Exact constant-twist step: ``exp(Ω dt/2) (x) s`` ("space") or ``s (x) exp(Ω dt/2)`` ("body").

        See :func:`~dualpose.algebra.dualquat.dualquat_integrate` for the meaning of ``twist = [ω, v]`` per frame.
        """
        return DualQuaternion._wrap(_dualquat.dualquat_integrate(self._a, twist, dt, frame))

    def angle_to(self, other: DualQuaternion | ArrayLike) -> NDArray[np.float64]:
        """Rotation angle in [0, π] between the orientations (real parts) of ``self`` and ``other``."""
        return _q.quat_angle(self._a[..., :4], as_array(_arr(other), "other", 8)[..., :4])


# ``a * b``: the Hamilton / dual-quaternion product (``a`` applied after ``b``) of two objects of the class, in the
# native base; anything but two objects of the class is refused (NotImplemented, then TypeError).
Quaternion._set_product(_native.quat_mul, _q.quat_mul)
DualQuaternion._set_product(_native.dualquat_mul, _dualquat.dualquat_mul)
