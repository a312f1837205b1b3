"""Quaternion / DualQuaternion facade: container semantics, agreement with scipy, delegation, bad input."""

from __future__ import annotations

import copy
import pickle
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import RigidTransform, Rotation, Slerp

from dualpose.algebra import quat as fq
from dualpose.algebra.classes import DualQuaternion, Quaternion
from dualpose.algebra.dualquat import dualquat_mul as dq_mul

TOL = 1e-12


def same_up_to_sign(a, b, atol):
    a, b = np.asarray(a), np.asarray(b)
    d = np.minimum(np.abs(a - b).max(axis=-1), np.abs(a + b).max(axis=-1))
    return bool(np.all(d <= atol))


@pytest.fixture
def qs(rng):
    return Quaternion(Rotation.random(300, rng=rng).as_quat())


@pytest.fixture
def dqs(rng):
    r = Rotation.random(300, rng=rng)
    t = rng.normal(size=(300, 3)) * 3
    return RigidTransform.from_components(t, r)


# ------------------------------------------------------------------------------------------------------------------
# container semantics (shared base class; exercised on both classes)
# ------------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("cls,size", [(Quaternion, 4), (DualQuaternion, 8)])
class TestContainer:
    def test_single_element(self, cls, size):
        x = cls(np.arange(size, dtype=float))
        assert x.shape == ()
        assert x.single
        with pytest.raises(TypeError, match="no len"):
            len(x)
        with pytest.raises(TypeError, match="not subscriptable"):
            x[0]
        with pytest.raises(TypeError, match="not iterable"):
            iter(x)
        assert bool(x)

    def test_batch_shape_len_iter(self, cls, size):
        a = np.arange(5 * 3 * size, dtype=float).reshape(5, 3, size)
        x = cls(a)
        assert x.shape == (5, 3) and len(x) == 5 and not x.single
        rows = list(x)
        assert len(rows) == 5 and all(type(r) is cls and r.shape == (3,) for r in rows)
        np.testing.assert_array_equal(rows[4].array, a[4])
        assert bool(cls(np.zeros((0, size))))  # truthy even when empty, like scipy

    def test_indexing_touches_batch_axes_only(self, cls, size):
        a = np.arange(5 * 3 * size, dtype=float).reshape(5, 3, size)
        x = cls(a)
        cases = [
            (1, a[1]),
            ((1, 2), a[1, 2]),
            ((Ellipsis, 0), a[:, 0]),
            ((slice(None), slice(1, None)), a[:, 1:]),
            ((slice(None, None, -2),), a[::-2]),
            ((None,), a[None]),
            ((0, Ellipsis), a[0]),
            (np.int64(2), a[2]),
        ]
        for key, ref in cases:
            out = x[key]
            assert type(out) is cls
            np.testing.assert_array_equal(out.array, ref)
            assert out.shape == ref.shape[:-1]
        np.testing.assert_array_equal(x[[0, 4]].array, a[[0, 4]])
        mask = np.array([True, False, True, False, False])
        np.testing.assert_array_equal(x[mask].array, a[mask])
        assert x[1, 2].single
        with pytest.raises(IndexError):
            x[0, 0, 0]
        with pytest.raises(IndexError):
            x[7]

    def test_array_is_not_copied(self, cls, size):
        a = np.zeros((4, size))
        x = cls(a)  # copies by default
        assert not np.shares_memory(x.array, a)
        y = cls(a, copy=False)
        assert y.array is a
        assert np.asarray(y) is a
        assert y.array is y.array
        assert np.shares_memory(y[1:].array, a)  # basic slicing returns views
        assert np.asarray(y, dtype=np.float32).dtype == np.float32
        assert np.asarray(y, dtype=np.float64) is a
        with pytest.raises(ValueError, match="without a copy"):
            np.array(y, dtype=np.float32, copy=False)
        assert not np.shares_memory(np.array(y, copy=True), a)
        z = cls(y)  # from an object: copied
        assert not np.shares_memory(z.array, a)
        assert cls(y, copy=False).array is a
        c = y.copy()
        assert type(c) is cls and not np.shares_memory(c.array, a)

    def test_inputs_converted_to_float64(self, cls, size):
        x = cls(list(range(size)))
        assert x.array.dtype == np.float64
        assert cls(np.ones(size, np.float32)).array.dtype == np.float64

    def test_bad_input(self, cls, size):
        with pytest.raises(ValueError, match=rf"{cls.__name__} array must have shape \(\.\.\., {size}\); got shape"):
            cls(np.zeros((3, size + 1)))
        with pytest.raises(ValueError, match="must have shape"):
            cls(1.0)
        with pytest.raises(TypeError, match="real numeric"):
            cls(np.zeros(size, complex))
        with pytest.raises(TypeError, match="real numeric"):
            cls(["a"] * size)

    def test_no_componentwise_arithmetic_with_arrays(self, cls, size):
        x = cls(np.ones((2, size)))
        with pytest.raises(TypeError):
            np.ones(size) * x
        with pytest.raises(TypeError):
            x * np.ones(size)
        with pytest.raises(TypeError):
            x * 2.0
        with pytest.raises(TypeError):
            x + x
        with pytest.raises(TypeError):
            x**x
        other = DualQuaternion if cls is Quaternion else Quaternion
        with pytest.raises(TypeError):
            x * other(np.ones((2, 12 - size)))

    def test_eq_is_identity_and_approx_equal_is_double_cover_aware(self, cls, size, rng):
        a = rng.normal(size=(6, size))
        x, y = cls(a), cls(a)
        assert x == x and x != y  # == is Python identity (not overloaded)
        flipped = a.copy()
        flipped[::2] *= -1
        assert x.approx_equal(cls(flipped)).all()
        bumped = a.copy()
        bumped[3, 1] += 1e-9
        np.testing.assert_array_equal(x.approx_equal(bumped), [True, True, True, False, True, True])
        assert x.approx_equal(bumped, atol=2e-9).all()
        assert x.approx_equal(a[0]).shape == (6,)  # broadcasting against a single element
        with pytest.raises(ValueError, match="other must have shape"):
            x.approx_equal(np.zeros(size + 1))

    def test_repr(self, cls, size):
        x = cls(np.arange(size, dtype=float) / 8)
        r = repr(x)
        assert r.startswith(f"{cls.__name__}(shape=(), layout=")
        assert "xyzw" in r and "0.125" in r
        big = repr(cls(np.arange(1000 * size, dtype=float).reshape(10, 100, size)))
        assert "shape=(10, 100)" in big and "\n    ...,\n" in big and len(big) < 800
        assert np.array2string(np.arange(size, dtype=float), separator=", ") in big  # whole first element
        assert f"{1000 * size - 1}.]" in big  # last element shown
        assert repr(cls(np.zeros((0, size)))).endswith("shape=(0,), layout=" + cls._layout + ")")


# ------------------------------------------------------------------------------------------------------------------
# Quaternion
# ------------------------------------------------------------------------------------------------------------------
class TestQuaternion:
    def test_constructors_against_scipy(self, rng):
        rv = rng.normal(size=(200, 3)) * 2
        ref = Rotation.from_rotvec(rv)
        assert same_up_to_sign(Quaternion.from_rotvec(rv).array, ref.as_quat(), TOL)
        assert same_up_to_sign(Quaternion.from_matrix(ref.as_matrix()).array, ref.as_quat(), TOL)
        assert (Quaternion.from_matrix(ref.as_matrix()).array[:, 3] >= 0).all()
        ang = np.linalg.norm(rv, axis=-1)
        q = Quaternion.from_axis_angle(rv * 5.0, ang)  # axis is normalized
        assert same_up_to_sign(q.array, ref.as_quat(), TOL)

    def test_conversions_against_scipy(self, qs):
        r = Rotation.from_quat(qs.array)
        np.testing.assert_allclose(qs.as_rotvec(), r.as_rotvec(), atol=TOL)
        np.testing.assert_allclose(qs.as_matrix(), r.as_matrix(), atol=TOL)
        axis, angle = qs.as_axis_angle()
        np.testing.assert_allclose(axis * angle[:, None], r.as_rotvec(), atol=TOL)

    def test_product_apply_inverse_against_scipy(self, qs, rng):
        p = qs[::-1]
        rp, rq = Rotation.from_quat(p.array), Rotation.from_quat(qs.array)
        pq = p * qs
        assert type(pq) is Quaternion and pq.shape == (300,)
        assert same_up_to_sign(pq.array, (rp * rq).as_quat(), TOL)
        v = rng.normal(size=(300, 3))
        np.testing.assert_allclose(qs.apply(v), rq.apply(v), atol=TOL)
        np.testing.assert_allclose(pq.apply(v), p.apply(qs.apply(v)), atol=TOL)  # q first, then p
        assert same_up_to_sign(qs.inv().array, rq.inv().as_quat(), TOL)
        np.testing.assert_array_equal(qs.conj().array, qs.array * [-1, -1, -1, 1])
        np.testing.assert_allclose((qs * qs.inv()).array, fq.quat_identity(300), atol=TOL)

    def test_broadcasting_product(self, rng):
        p = Quaternion.random((4, 1), rng)
        q = Quaternion.random(5, rng)
        out = p * q
        assert out.shape == (4, 5)
        np.testing.assert_array_equal(out[2, 3].array, (p[2, 0] * q[3]).array)

    def test_power_slerp_angle(self, qs, rng):
        half = qs**0.5
        np.testing.assert_allclose((half * half).array, qs.array, atol=TOL)
        t = rng.uniform(0, 1, size=300)
        np.testing.assert_allclose((qs**t).array, fq.quat_pow(qs.array, t))
        key = Rotation.random(2, rng=rng)
        a, b = Quaternion(key[0].as_quat()), Quaternion(key[1].as_quat())
        ts = np.linspace(0, 1, 9)
        out = a.slerp(b, ts)
        assert out.shape == (9,)
        assert same_up_to_sign(out.array, Slerp([0, 1], key)(ts).as_quat(), TOL)
        assert same_up_to_sign(a.slerp(b.array, ts).array, out.array, 0.0)  # arrays accepted too
        p = qs[::-1]
        ref = (Rotation.from_quat(p.array).inv() * Rotation.from_quat(qs.array)).magnitude()
        np.testing.assert_allclose(p.angle_to(qs), ref, atol=TOL)
        np.testing.assert_allclose(p.angle_to(qs.array), ref, atol=TOL)

    def test_norm_normalize_canonical(self, rng):
        a = rng.normal(size=(50, 4)) * 3
        x = Quaternion(a)
        np.testing.assert_allclose(x.norm(), np.linalg.norm(a, axis=-1), rtol=1e-15)
        np.testing.assert_allclose(x.normalize().norm(), 1.0, rtol=1e-15)
        c = x.canonical()
        assert (c.array[:, 3] > 0).all() and x.approx_equal(c).all()
        with pytest.raises(ValueError, match="zero"):
            Quaternion([0.0, 0, 0, 0]).normalize()

    def test_integrate_and_mean(self, qs, rng):
        w = rng.normal(size=(300, 3))
        step = Rotation.from_rotvec(w * 0.1)
        r = Rotation.from_quat(qs.array)
        assert same_up_to_sign(qs.integrate(w, 0.1).array, (step * r).as_quat(), TOL)
        assert same_up_to_sign(qs.integrate(w, 0.1, frame="body").array, (r * step).as_quat(), TOL)
        with pytest.raises(ValueError, match="frame"):
            qs.integrate(w, 0.1, frame="world")
        small = Quaternion.from_rotvec(rng.normal(size=(2, 20, 3)) * 0.2)
        m = small.mean()
        assert m.shape == (2,)
        assert same_up_to_sign(m[1].array, Rotation.from_quat(small[1].array).mean().as_quat(), TOL)

    def test_identity_and_random(self):
        assert Quaternion.identity().shape == ()
        np.testing.assert_array_equal(Quaternion.identity().array, [0, 0, 0, 1])
        assert Quaternion.identity(3).shape == (3,)
        assert Quaternion.identity((2, 3)).array.shape == (2, 3, 4)
        r1, r2 = Quaternion.random(1000, rng=7), Quaternion.random(1000, rng=np.random.default_rng(7))
        np.testing.assert_array_equal(r1.array, r2.array)
        np.testing.assert_allclose(r1.norm(), 1.0, rtol=1e-15)
        assert Quaternion.random().shape == ()
        # Haar measure: E[R] = 0 and the rotation angle has density (1 - cos θ)/π, mean π/2 + 2/π
        assert np.abs(r1.as_matrix().mean(axis=0)).max() < 0.1
        assert abs(r1.angle_to(Quaternion.identity()).mean() - (np.pi / 2 + 2 / np.pi)) < 0.05

    def test_methods_delegate_to_functional_api(self, qs, rng):
        v = rng.normal(size=3)
        np.testing.assert_array_equal(qs.apply(v), fq.quat_rotate(qs.array, v))
        np.testing.assert_array_equal(qs.as_matrix(), fq.matrix_from_quat(qs.array))
        np.testing.assert_array_equal((qs * qs[0]).array, fq.quat_mul(qs.array, qs.array[0]))
        np.testing.assert_array_equal(qs.inv().array, fq.quat_inv(qs.array))

    def test_functional_api_accepts_objects(self, qs):
        np.testing.assert_array_equal(fq.quat_mul(qs, qs), (qs * qs).array)


# ------------------------------------------------------------------------------------------------------------------
# DualQuaternion
# ------------------------------------------------------------------------------------------------------------------
class TestDualQuaternion:
    def test_from_qt_layout_and_round_trip(self, dqs):
        t, r = dqs.as_components()
        x = DualQuaternion.from_qt(r.as_quat(), t)
        # layout: [real xyzw, dual xyzw], dual = ½ t ⊗ real
        np.testing.assert_allclose(x.array[:, :4], r.as_quat(), rtol=0, atol=4e-16)
        tq = np.concatenate([t, np.zeros((len(t), 1))], axis=1)
        np.testing.assert_allclose(x.array[:, 4:], 0.5 * fq.quat_mul(tq, r.as_quat()), atol=TOL)
        q2, t2 = x.as_qt()
        np.testing.assert_allclose(q2, r.as_quat(), atol=TOL)
        np.testing.assert_allclose(t2, t, atol=TOL)
        np.testing.assert_allclose(x.translation, t, atol=TOL)
        assert type(x.rotation) is Quaternion and np.shares_memory(x.rotation.array, x.array)
        # Quaternion objects are accepted as the rotation argument
        np.testing.assert_array_equal(DualQuaternion.from_qt(Quaternion(r.as_quat()), t).array, x.array)

    def test_matrix_apply_against_scipy(self, dqs, rng):
        x = DualQuaternion.from_matrix(dqs.as_matrix())
        assert same_up_to_sign(x.array, dqs.as_dual_quat(), TOL)
        np.testing.assert_allclose(x.as_matrix(), dqs.as_matrix(), atol=TOL)
        p = rng.normal(size=(300, 3)) * 5
        np.testing.assert_allclose(x.apply(p), dqs.apply(p), atol=TOL)

    def test_product_inverse_against_scipy(self, dqs):
        x = DualQuaternion.from_scipy(dqs)
        y = x[::-1]
        ref = dqs[::-1] * dqs
        np.testing.assert_allclose((y * x).as_matrix(), ref.as_matrix(), atol=TOL)
        np.testing.assert_allclose(x.inv().as_matrix(), dqs.inv().as_matrix(), atol=TOL)
        np.testing.assert_allclose(x.conj().as_matrix(), dqs.inv().as_matrix(), atol=TOL)  # unit: conj = inverse
        np.testing.assert_allclose((x * x.inv()).array, DualQuaternion.identity(300).array, atol=TOL)

    def test_twist_against_scipy(self, rng):
        xi = rng.normal(size=(300, 6))
        xi[:, :3] *= 0.9  # |ω| < π: principal branch, so the round trip is exact
        x = DualQuaternion.from_twist(xi)
        ref = RigidTransform.from_exp_coords(xi)
        np.testing.assert_allclose(x.as_matrix(), ref.as_matrix(), atol=TOL)
        np.testing.assert_allclose(x.as_twist(), xi, atol=TOL)
        np.testing.assert_allclose(x.as_twist(), ref.as_exp_coords(), atol=TOL)

    def test_screw_walker_eqs_11_12(self, rng):
        n = rng.normal(size=(200, 3))
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        p = rng.normal(size=(200, 3))
        p -= np.sum(p * n, axis=-1, keepdims=True) * n  # p ⊥ n
        d = rng.normal(size=200)
        th = rng.uniform(0.1, 3.0, size=200)
        x = DualQuaternion.from_screw(n, p, d, th)
        s, c = np.sin(th / 2)[:, None], np.cos(th / 2)[:, None]
        r_ref = np.concatenate([s * n, c], axis=1)
        s_ref = np.concatenate([d[:, None] / 2 * c * n + s * np.cross(p, n), -d[:, None] / 2 * s], axis=1)
        np.testing.assert_allclose(x.array, np.concatenate([r_ref, s_ref], axis=1), atol=TOL)
        # Walker eq. (61): t = (I - R) p + d n
        R = Rotation.from_rotvec(n * th[:, None]).as_matrix()
        t_ref = p - np.einsum("nij,nj->ni", R, p) + d[:, None] * n
        np.testing.assert_allclose(x.translation, t_ref, atol=TOL)
        n2, p2, d2, th2 = x.as_screw()
        np.testing.assert_allclose(n2, n, atol=1e-11)
        np.testing.assert_allclose(p2, p, atol=1e-11)
        np.testing.assert_allclose(d2, d, atol=1e-11)
        np.testing.assert_allclose(th2, th, atol=1e-11)

    def test_power_sclerp_angle(self, dqs, rng):
        x = DualQuaternion.from_scipy(dqs)
        half = x**0.5
        np.testing.assert_allclose((half * half).as_matrix(), x.as_matrix(), atol=1e-11)
        a, b = x[0], x[1]
        ts = np.linspace(0, 1, 5)
        path = a.sclerp(b, ts)
        assert path.shape == (5,)
        np.testing.assert_allclose(path[0].as_matrix(), a.as_matrix(), atol=TOL)
        np.testing.assert_allclose(path[-1].as_matrix(), b.as_matrix(), atol=TOL)
        # ScLERP is a (a⁻¹ b)^t: the screw motion with constant twist
        np.testing.assert_allclose(path[2].as_matrix(), (a * (a.inv() * b) ** 0.5).as_matrix(), atol=1e-11)
        ref = (dqs[::-1].rotation.inv() * dqs.rotation).magnitude()
        np.testing.assert_allclose(x[::-1].angle_to(x), ref, atol=TOL)
        np.testing.assert_allclose(x[::-1].angle_to(x.array), ref, atol=TOL)

    def test_normalize_canonical(self, dqs, rng):
        x = DualQuaternion.from_scipy(dqs)
        scaled = DualQuaternion(x.array * 3.0)
        np.testing.assert_allclose(scaled.normalize().as_matrix(), x.as_matrix(), atol=TOL)
        c = DualQuaternion(-x.array).canonical()
        assert (c.array[:, 3] > 0).all()
        np.testing.assert_allclose(c.array, x.canonical().array, atol=0)

    def test_integrate_and_norm(self, dqs, rng):
        x = DualQuaternion.from_scipy(dqs)
        xi = rng.normal(size=(300, 6))
        step = DualQuaternion.from_twist(xi * 0.05)
        np.testing.assert_allclose(x.integrate(xi, 0.05).as_matrix(), (step * x).as_matrix(), atol=TOL)
        np.testing.assert_allclose(x.integrate(xi, 0.05, frame="body").as_matrix(), (x * step).as_matrix(), atol=TOL)
        with pytest.raises(ValueError, match="frame"):
            x.integrate(xi, 0.05, frame="world")
        n = DualQuaternion(x.array * 2.5).norm()
        assert n.shape == (300, 2)
        np.testing.assert_allclose(n, np.broadcast_to([2.5, 0.0], (300, 2)), atol=TOL)

    def test_identity_and_random(self):
        np.testing.assert_array_equal(DualQuaternion.identity().array, [0, 0, 0, 1, 0, 0, 0, 0])
        assert DualQuaternion.identity().shape == ()
        assert DualQuaternion.identity((2, 3)).shape == (2, 3)
        a = DualQuaternion.random(500, rng=3, translation_scale=10.0)
        b = DualQuaternion.random(500, rng=np.random.default_rng(3), translation_scale=10.0)
        np.testing.assert_array_equal(a.array, b.array)
        np.testing.assert_allclose(a.rotation.norm(), 1.0, rtol=1e-15)
        np.testing.assert_allclose(np.sum(a.array[:, :4] * a.array[:, 4:], axis=-1), 0.0, atol=1e-14)
        assert 8.0 < a.translation.std() < 12.0
        assert DualQuaternion.random().shape == ()

    def test_bad_arguments_name_themselves(self):
        with pytest.raises(ValueError, match="must have shape"):
            DualQuaternion.from_qt([0, 0, 0, 1], [1, 2])
        with pytest.raises(ValueError, match="must have shape"):
            DualQuaternion.identity().apply([1, 2, 3, 4])


# ------------------------------------------------------------------------------------------------------------------
# products of single elements held inline by the native base (no array until one is read)
# ------------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("cls,size,mul", [(Quaternion, 4, fq.quat_mul), (DualQuaternion, 8, dq_mul)])
class TestInlineProducts:
    def test_chain_equals_the_functional_product_bit_for_bit(self, cls, size, mul, rng):
        xs = rng.normal(size=(20, size))
        acc, ref = cls(xs[0]), xs[0]
        for x in xs[1:]:  # inline results multiplied again: array-held and inline operands mixed
            acc = acc * cls(x)
            ref = mul(ref, x)
            acc = cls(x) * acc
            ref = mul(x, ref)
        assert acc.array.tobytes() == ref.tobytes()
        assert acc.shape == () and acc.single

    def test_array_is_created_once_and_then_stored(self, cls, size, mul, rng):
        a, b = cls(rng.normal(size=size)), cls(rng.normal(size=size))
        c = a * b
        arr = c.array
        assert arr is c.array and arr.shape == (size,) and arr.dtype == np.float64 and arr.flags.writeable
        arr[0] = 7.0  # the stored array, as for any object: later products read it
        assert (c * b).array.tobytes() == mul(arr, b.array).tobytes()
        assert np.asarray(c) is arr

    def test_copy_pickle_and_batches(self, cls, size, mul, rng):
        c = cls(rng.normal(size=size)) * cls(rng.normal(size=size))
        for d in (pickle.loads(pickle.dumps(c)), copy.deepcopy(c), copy.copy(c), c.copy()):
            assert type(d) is cls and d.array.tobytes() == c.array.tobytes()
        batch = cls(rng.normal(size=(3, 2, size)))
        assert (batch * c).array.tobytes() == mul(batch.array, c.array).tobytes()  # broadcast: the functional path
        view = batch[:, 1]  # strided view: the functional path
        assert (view * view).array.tobytes() == mul(view.array, view.array).tobytes()
        assert (batch[1, 0] * c).array.tobytes() == mul(batch.array[1, 0], c.array).tobytes()

    def test_subclass_operands_give_the_base_class(self, cls, size, mul, rng):
        class Sub(cls):
            __slots__ = ()

        s = Sub(rng.normal(size=size))
        for r in (s * s, s * cls(s.array), cls(s.array) * s):
            assert type(r) is cls and r.array.tobytes() == mul(s.array, s.array).tobytes()

    def test_overflow_warns_as_the_functional_product(self, cls, size, mul):
        x = cls(np.full(size, 1e200))
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            r = x * x
        with warnings.catch_warnings(record=True) as want:
            warnings.simplefilter("always")
            ref = mul(x.array, x.array)
        assert [str(w.message) for w in got] == [str(w.message) for w in want]
        assert any("overflow" in str(w.message) for w in got)
        assert r.array.tobytes() == ref.tobytes()
