"""Dual-quaternion core: scipy cross-checks, hypothesis laws, mpmath spot checks, regressions and bad input."""

from __future__ import annotations

import warnings

import mpmath as mp
import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import RigidTransform, Rotation

from dualpose.algebra.dualquat import (
    dualquat_canonical,
    dualquat_conj,
    dualquat_exp,
    dualquat_from_matrix,
    dualquat_from_qt,
    dualquat_from_screw,
    dualquat_from_twist,
    dualquat_identity,
    dualquat_integrate,
    dualquat_inv,
    dualquat_log,
    dualquat_mul,
    dualquat_norm,
    dualquat_normalize,
    dualquat_pow,
    dualquat_sclerp,
    dualquat_transform,
    matrix_from_dualquat,
    qt_from_dualquat,
    screw_from_dualquat,
    twist_from_dualquat,
)
from dualpose.algebra.quat import quat_inv

EPS = np.finfo(float).eps
IDENTITY = np.array([0, 0, 0, 1.0, 0, 0, 0, 0])

finite = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
dquats = arrays(np.float64, 8, elements=finite).filter(lambda s: np.linalg.norm(s[:4]) > 1e-2)
vec3 = arrays(np.float64, 3, elements=finite)


def unit_dq(s):
    """Reference normalization (numpy): r/|r|, and the dual part made orthogonal to it."""
    s = np.asarray(s, float)
    n = np.linalg.norm(s[..., :4], axis=-1, keepdims=True)
    r, d = s[..., :4] / n, s[..., 4:] / n
    d = d - r * np.sum(r * d, axis=-1, keepdims=True)
    return np.concatenate([r, d], axis=-1)


def same_dq(a, b, atol):
    """a and b equal up to the overall sign (double cover)."""
    d = np.minimum(np.abs(a - b).max(axis=-1), np.abs(a + b).max(axis=-1))
    return np.all(d <= atol)


@pytest.fixture
def transforms(rng):
    """Random rigid transforms incl. rotation angles near 0 and near pi (not exactly pi)."""
    n = 2000
    rot = Rotation.random(n, rng=rng).as_rotvec()
    ax = rng.normal(size=(n, 3))
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    rot[:100] = ax[:100] * 10.0 ** rng.uniform(-12, -3, size=(100, 1))
    rot[100:200] = ax[100:200] * (np.pi - 10.0 ** rng.uniform(-9, -3, size=(100, 1)))
    t = rng.normal(size=(n, 3)) * 3.0
    t[200:250] = 0.0
    return RigidTransform.from_components(t, Rotation.from_rotvec(rot))


# ---------------------------------------------------------------------------------------------------------------
# mpmath references (independent of the kernels' formulas)
# ---------------------------------------------------------------------------------------------------------------


def mp_qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]


def mp_dqmul(a, b):
    e = mp_qmul(a[:4], b[4:])
    f = mp_qmul(a[4:], b[:4])
    return mp_qmul(a[:4], b[:4]) + [x + y for x, y in zip(e, f, strict=True)]


def mp_dqexp(s, terms=90):
    """exp(S) = sum S**n / n!  (power series, 60 digits)."""
    with mp.workdps(60):
        s = [mp.mpf(float(x)) for x in s]
        term = [mp.mpf(0)] * 8
        term[3] = mp.mpf(1)
        total = list(term)
        for n in range(1, terms):
            term = [x / n for x in mp_dqmul(term, s)]
            total = [a + b for a, b in zip(total, term, strict=True)]
        return np.array([float(x) for x in total])


def mp_dqlog(s, dps=700):
    """Dantam eqs. (86)-(90) evaluated at ``dps`` digits (enough to absorb the cancellation in alpha)."""
    with mp.workdps(dps):
        rx, ry, rz, rw, dx, dy, dz, dw = (mp.mpf(float(x)) for x in s)
        n2 = rx * rx + ry * ry + rz * rz + rw * rw
        sv = mp.sqrt(rx * rx + ry * ry + rz * rz)
        phi = mp.atan2(sv, rw)
        f = phi / sv
        k = rx * dx + ry * dy + rz * dz
        alpha = (rw - f * n2) / sv**2
        c = (k * alpha - dw) / n2
        out = [f * rx, f * ry, f * rz, mp.log(n2) / 2, c * rx + f * dx, c * ry + f * dy, c * rz + f * dz]
        out.append((k + rw * dw) / n2)
        return np.array([float(x) for x in out])


# ---------------------------------------------------------------------------------------------------------------


class TestAgainstScipy:
    def test_layout_matches_scipy_dual_quat(self, transforms):
        q, t = transforms.rotation.as_quat(), transforms.translation
        assert same_dq(dualquat_from_qt(q, t), transforms.as_dual_quat(), 1e-15)
        q2, t2 = qt_from_dualquat(transforms.as_dual_quat())
        np.testing.assert_allclose(t2, t, atol=1e-14)
        assert same_dq(np.concatenate([q2, 0 * q2], axis=-1), np.concatenate([q, 0 * q], axis=-1), 1e-15)

    def test_matrices(self, transforms):
        dq = transforms.as_dual_quat()
        np.testing.assert_allclose(matrix_from_dualquat(dq), transforms.as_matrix(), atol=1e-14)
        out = dualquat_from_matrix(transforms.as_matrix())
        assert np.all(out[:, 3] >= 0)
        np.testing.assert_allclose(out, dualquat_canonical(dq), atol=1e-14)

    def test_apply_and_compose(self, transforms, rng):
        dq = transforms.as_dual_quat()
        p = rng.normal(size=(len(dq), 3)) * 5
        np.testing.assert_allclose(dualquat_transform(dq, p), transforms.apply(p), atol=1e-13)
        other = RigidTransform.from_dual_quat(np.roll(dq, 11, axis=0))
        prod = dualquat_mul(other.as_dual_quat(), dq)
        np.testing.assert_allclose(matrix_from_dualquat(prod), (other * transforms).as_matrix(), atol=1e-13)
        np.testing.assert_allclose(matrix_from_dualquat(dualquat_inv(dq)), transforms.inv().as_matrix(), atol=1e-13)
        np.testing.assert_allclose(dualquat_conj(dq), dualquat_inv(dq), atol=1e-15)

    def test_exp_coords(self, transforms):
        dq = transforms.as_dual_quat()
        xi = transforms.as_exp_coords()
        np.testing.assert_allclose(twist_from_dualquat(dq), xi, rtol=0, atol=1e-12)
        np.testing.assert_allclose(twist_from_dualquat(-dq), xi, rtol=0, atol=1e-12)
        assert same_dq(dualquat_from_twist(xi), dq, 1e-13)

    def test_from_exp_coords_large_and_tiny(self, rng):
        xi = rng.normal(size=(3000, 6)) * 2.0  # |ω| up to ~10: wraps past pi
        xi[:300, :3] *= 10.0 ** rng.uniform(-300, -6, size=(300, 1))
        ref = RigidTransform.from_exp_coords(xi).as_dual_quat()
        assert same_dq(dualquat_from_twist(xi), ref, 1e-12)

    def test_normalize_matches_scipy(self, rng):
        s = rng.normal(size=(500, 8))
        ref = RigidTransform.from_dual_quat(s).as_dual_quat()
        assert same_dq(dualquat_normalize(s), ref, 1e-14)
        q, t = qt_from_dualquat(s)  # scale invariant, reads the same translation as scipy's normalization
        np.testing.assert_allclose(t, RigidTransform.from_dual_quat(s).translation, atol=1e-14)
        q3, t3 = qt_from_dualquat(s * 1e-200)
        np.testing.assert_allclose(t3, t, atol=1e-14)

    def test_sclerp_is_the_constant_screw(self, transforms, rng):
        dq0 = transforms.as_dual_quat()
        t1 = RigidTransform.from_dual_quat(np.roll(dq0, 5, axis=0))
        tt = rng.uniform(-0.5, 1.5, size=len(dq0))
        rel = transforms.inv() * t1
        ref = transforms * RigidTransform.from_exp_coords(tt[:, None] * rel.as_exp_coords())
        out = dualquat_sclerp(dq0, t1.as_dual_quat(), tt)
        np.testing.assert_allclose(matrix_from_dualquat(out), ref.as_matrix(), atol=1e-12)

    def test_sclerp_matches_pytransform3d(self):
        # Golden values from pytransform3d 3.17.0 ``transformations.dual_quaternion_sclerp`` (a benchmark-only
        # extra, not a test dependency: it pulls in matplotlib), converted from its wxyz layout to xyzw.
        dq0 = [0.09584447857884668, -0.19168895715769335, 0.43130015360481, 0.8763842519866569,
               -0.06023131935969481, -0.5569800067301194, 0.3354878317689839, -0.2803450998431265]
        dq1 = [-0.5823441701177549, 0.3583656431493876, 0.22397852696836723, 0.6944659479031853,
               0.5163433875277723, 0.1612910422774738, 0.13995345077991786, 0.3046107966769795]
        golden = {
            0.25: [-0.09145944272871658, -0.05039162776766158, 0.411500151598193, 0.9054079077528217,
                   0.10416212553179434, -0.4017581773787283, 0.30457007860818913, -0.15026295985167346],
            0.5: [-0.27361583390329314, 0.09374184860342805, 0.36854005406854473, 0.8834732988636224,
                  0.2618751891164496, -0.22437520125597177, 0.26019050589972725, -0.003626684271440663],
            0.9: [-0.5290780399496275, 0.310104473924144, 0.2581086524166517, 0.7465196356713937,
                  0.47449398466894616, 0.08351613273905956, 0.1666310771362939, 0.2439811218563838],
        }
        for t, ref in golden.items():
            assert same_dq(dualquat_sclerp(dq0, dq1, t), np.array(ref), 1e-13)


class TestLaws:
    @given(dquats, dquats, dquats)
    def test_associative(self, a, b, c):
        lhs = dualquat_mul(dualquat_mul(a, b), c)
        rhs = dualquat_mul(a, dualquat_mul(b, c))
        scale = np.linalg.norm(a) * np.linalg.norm(b) * np.linalg.norm(c)
        assert np.abs(lhs - rhs).max() <= 32 * EPS * scale

    @given(dquats)
    def test_inverse(self, s):
        nr = np.linalg.norm(s[:4])
        cond = (1 + np.linalg.norm(s[4:]) / nr) ** 2
        np.testing.assert_allclose(dualquat_mul(s, dualquat_inv(s)), IDENTITY, atol=64 * EPS * cond)
        np.testing.assert_allclose(dualquat_mul(dualquat_inv(s), s), IDENTITY, atol=64 * EPS * cond)

    @given(dquats, dquats)
    def test_norm_is_multiplicative_dual_number(self, a, b):
        na, nb = dualquat_norm(a), dualquat_norm(b)
        ref = [na[0] * nb[0], na[0] * nb[1] + na[1] * nb[0]]
        scale = np.linalg.norm(a) * np.linalg.norm(b)
        np.testing.assert_allclose(dualquat_norm(dualquat_mul(a, b)), ref, atol=64 * EPS * scale)

    @given(dquats)
    def test_normalize(self, s):
        u = dualquat_normalize(s)
        assert abs(np.linalg.norm(u[:4]) - 1) <= 4 * EPS
        assert abs(u[:4] @ u[4:]) <= 16 * EPS * (1 + np.linalg.norm(u[4:]))
        np.testing.assert_allclose(u, unit_dq(s), atol=16 * EPS * (1 + np.linalg.norm(u[4:])))
        np.testing.assert_allclose(dualquat_norm(u), [1, 0], atol=16 * EPS * (1 + np.linalg.norm(u[4:])))

    @given(dquats)
    def test_exp_log(self, s):
        nr = np.linalg.norm(s[:4])
        sv = np.linalg.norm(s[:3] / nr)
        # near r_w/|r| = -1 the log is ~|d|/|r_v| (the double cover's 2π rotation) and exp is ill-conditioned
        # there by the same factor; below |r_v| ~ 1e-150 the log itself overflows
        assume(s[3] >= 0 or sv > 1e-150 or not np.any(s[4:7]))
        cond = 1 + (0.0 if s[3] >= 0 or sv == 0 else 1 / sv)
        out = dualquat_exp(dualquat_log(s))
        np.testing.assert_allclose(out[:4], s[:4], atol=32 * EPS * nr)
        np.testing.assert_allclose(out[4:], s[4:], atol=64 * EPS * np.linalg.norm(s) * cond)

    @given(arrays(np.float64, 8, elements=st.floats(-1.5, 1.5)))
    def test_log_exp_principal_branch(self, x):
        # |x_r,v| <= 1.5 sqrt(3) < pi lies on the principal branch
        cond = 1 / max(np.sinc(np.linalg.norm(x[:3]) / np.pi), 1e-3)
        np.testing.assert_allclose(dualquat_log(dualquat_exp(x)), x, atol=64 * EPS * cond)

    @given(dquats, vec3)
    def test_transform_matches_matrix_and_qt(self, s, p):
        out = dualquat_transform(s, p)
        m = matrix_from_dualquat(s)
        q, t = qt_from_dualquat(s)
        scale = 1 + np.linalg.norm(p) + np.linalg.norm(t)
        np.testing.assert_allclose(m[:3, :3] @ p + m[:3, 3], out, atol=32 * EPS * scale)
        np.testing.assert_allclose(Rotation.from_quat(q).apply(p) + t, out, atol=32 * EPS * scale)
        np.testing.assert_array_equal(m[3], [0, 0, 0, 1])

    @given(dquats, dquats, vec3)
    def test_product_composes_transforms(self, a, b, p):
        a, b = unit_dq(a), unit_dq(b)
        lhs = dualquat_transform(dualquat_mul(a, b), p)
        rhs = dualquat_transform(a, dualquat_transform(b, p))
        scale = 1 + np.linalg.norm(p) + np.linalg.norm(a[4:]) + np.linalg.norm(b[4:])
        np.testing.assert_allclose(lhs, rhs, atol=64 * EPS * scale)

    @given(dquats)
    def test_canonical(self, s):
        c = dualquat_canonical(s)
        assert c[3] >= 0
        assert same_dq(c, s, 0.0)
        np.testing.assert_array_equal(qt_from_dualquat(c)[1], qt_from_dualquat(s)[1])

    @given(dquats, dquats, st.floats(0, 1))
    def test_sclerp_endpoints_and_double_cover(self, a, b, t):
        ua, ub = unit_dq(a), unit_dq(b)
        scale = 1 + np.linalg.norm(ua[4:]) + np.linalg.norm(ub[4:])
        np.testing.assert_allclose(dualquat_sclerp(a, b, 0.0), ua, atol=32 * EPS * scale)
        assert same_dq(dualquat_sclerp(a, b, 1.0), ub, 1e-12 * scale)
        np.testing.assert_array_equal(dualquat_sclerp(a, -b, t), dualquat_sclerp(a, b, t))
        np.testing.assert_allclose(
            matrix_from_dualquat(dualquat_sclerp(a, -3.0 * b, t)),
            matrix_from_dualquat(dualquat_sclerp(a, b, t)),
            atol=1e-13 * scale,
        )

    @given(dquats, st.floats(-2, 2), st.floats(-2, 2))
    def test_pow_adds_exponents(self, s, a, b):
        s = dualquat_canonical(unit_dq(s))  # r_w >= 0: away from the log's pole at r_w = -1
        lhs = dualquat_mul(dualquat_pow(s, a), dualquat_pow(s, b))
        np.testing.assert_allclose(lhs, dualquat_pow(s, a + b), atol=128 * EPS * (1 + np.linalg.norm(s[4:])))

    @given(dquats)
    def test_screw_round_trip(self, s):
        n, p, d, th = screw_from_dualquat(s)
        u = dualquat_canonical(unit_dq(s))
        scale = 1 + np.linalg.norm(u[4:])
        assert abs(np.linalg.norm(n) - 1) <= 4 * EPS
        assert 0 <= th <= np.pi
        pmax = np.abs(p).max()  # ~|t|/θ: huge for tiny rotations (the foot point is ill-conditioned there)
        assert abs(n @ p) <= 1e-12 * (1 + pmax)
        np.testing.assert_allclose(dualquat_from_screw(n, p, d, th), u, atol=1e-13 * scale)
        # the screw describes the same motion: t = (I - R) p + d n (Walker Appendix eq. (61))
        m = matrix_from_dualquat(s)
        tol = 1e-12 * scale + 16 * EPS * pmax
        np.testing.assert_allclose((np.eye(3) - m[:3, :3]) @ p + d * n, m[:3, 3], atol=tol)
        np.testing.assert_allclose(m[:3, :3] @ n, n, atol=1e-14)

    @given(vec3, vec3, st.floats(-5, 5), st.floats(-7, 7))
    def test_from_screw_matches_walker_translation(self, n, p, d, th):
        if np.linalg.norm(n) < 1e-3:
            n = np.array([0.0, 0.0, 1.0])
        s = dualquat_from_screw(n, p, d, th)
        nn = n / np.linalg.norm(n)
        r = Rotation.from_rotvec(th * nn)
        m = matrix_from_dualquat(s)
        np.testing.assert_allclose(m[:3, :3], r.as_matrix(), atol=1e-14)
        np.testing.assert_allclose(m[:3, 3], p - r.apply(p) + d * nn, atol=1e-13 * (1 + np.linalg.norm(p) + abs(d)))


class TestMpmath:
    AXIS = np.array([2.0, -3.0, 6.0]) / 7.0
    DUAL = np.array([0.3, -1.1, 0.7, 0.45])

    @pytest.mark.parametrize("angle", [1e-300, 1e-20, 1e-8, 0.7, np.pi - 1e-8, np.pi - 1e-3])
    def test_exp(self, angle):
        s = np.concatenate([self.AXIS * angle, [0.25], self.DUAL])
        ref = mp_dqexp(s)
        out = dualquat_exp(s)
        # near phi = pi the real vector part sin(phi) r_v/phi has relative condition ~1/sin(phi): one ulp of
        # phi = |r_v| (which no float64 algorithm avoids) moves it by 2 eps/sin(phi)
        np.testing.assert_allclose(out[:3], ref[:3], rtol=8 * EPS * (1 + 1 / np.sin(angle)), atol=0)
        np.testing.assert_allclose(out[3:], ref[3:], rtol=8 * EPS, atol=0)

    @pytest.mark.parametrize("angle", [1e-300, 1e-20, 1e-8, 0.7, 2.0, np.pi - 1e-3, np.pi - 1e-8])
    @pytest.mark.parametrize("scale", [1.0, 3.5])
    def test_log(self, angle, scale):
        s = np.concatenate([np.sin(angle) * self.AXIS, [np.cos(angle)], self.DUAL]) * scale
        ref = mp_dqlog(s)
        out = dualquat_log(s)
        np.testing.assert_allclose(out[[0, 1, 2, 4, 5, 6, 7]], ref[[0, 1, 2, 4, 5, 6, 7]], rtol=16 * EPS, atol=0)
        np.testing.assert_allclose(out[3], ref[3], rtol=0, atol=2 * EPS)  # ln|r|: absolute accuracy
        # exp(log s) = s up to the conditioning of exp at a log of size ~1/sin(angle) (see test_exp)
        cond = 1 + 1 / np.sin(angle)
        np.testing.assert_allclose(dualquat_exp(out), s, rtol=0, atol=16 * EPS * scale * cond)
        if angle < 1:
            np.testing.assert_allclose(dualquat_exp(out), s, rtol=16 * EPS, atol=0)

    def test_inverse(self):
        # S^-1 = (r^-1, -r^-1 d r^-1), r^-1 = r*/|r|**2, in 40 digits; rows of every magnitude (ordinary ones take the
        # one-reciprocal formula, extreme ones the exactly rescaled one).  Error bounds: |r^-1| = 1/|r| and
        # |r^-1 d r^-1| = |d|/|r|**2 times 2 and 5 eps (the error analysis gives about 1.5 and 4)
        rng = np.random.default_rng(11)
        s = rng.normal(size=(240, 8)) * 10.0 ** rng.uniform(-3, 3, size=(240, 1))
        s[:, 4:] *= 10.0 ** rng.uniform(-3, 3, size=(240, 1))
        s[::8] *= 1e-200
        s[1::8] *= 1e200
        out = dualquat_inv(s)
        np.testing.assert_array_equal(out[:, :4], quat_inv(s[:, :4]))
        with mp.workdps(40):
            for row, got in zip(s, out, strict=True):
                r, d = [mp.mpf(float(x)) for x in row[:4]], [mp.mpf(float(x)) for x in row[4:]]
                n2 = sum(x * x for x in r)
                i = [-r[0] / n2, -r[1] / n2, -r[2] / n2, r[3] / n2]
                ref = i + [-x for x in mp_qmul(mp_qmul(i, d), i)]
                err = [abs(mp.mpf(float(g)) - x) for g, x in zip(got, ref, strict=True)]
                nr, nd = mp.sqrt(n2), mp.sqrt(sum(x * x for x in d))
                assert max(err[:4]) <= 2 * EPS / nr
                assert max(err[4:]) <= 5 * EPS * nd / n2

    @pytest.mark.parametrize("w", [1e-300, 1e-20, 1e-6, 1e-2])
    def test_twist_left_jacobian(self, w):
        # jaxlie's trap: the translation of exp([ω, v]) is J_l(ω) v, not R v (they differ by ~|ω| |v| / 2)
        omega = self.AXIS * w
        v = np.array([0.6, 0.0, -0.8])
        out = dualquat_from_twist(np.concatenate([omega, v]))
        _, t = qt_from_dualquat(out)
        with mp.workdps(60):
            om = mp.matrix([mp.mpf(float(x)) for x in omega])
            th = mp.norm(om)
            k = mp.matrix([[0, -om[2], om[1]], [om[2], 0, -om[0]], [-om[1], om[0], 0]])
            jl = mp.eye(3) + (1 - mp.cos(th)) / th**2 * k + (th - mp.sin(th)) / th**3 * (k * k)
            ref = jl * mp.matrix([mp.mpf(float(x)) for x in v])
            ref = np.array([float(x) for x in ref])
        np.testing.assert_allclose(t, ref, rtol=0, atol=2 * EPS)
        if w >= 1e-6:
            rv = Rotation.from_rotvec(omega).apply(v)
            assert np.abs(rv - ref).max() > 1e3 * EPS  # R v would fail the check above
        xi = twist_from_dualquat(out)
        np.testing.assert_allclose(xi[:3], omega, rtol=4 * EPS, atol=0)
        np.testing.assert_allclose(xi[3:], v, rtol=0, atol=4 * EPS)


class TestRegressions:
    def test_canonical_flips_the_dual_part(self, rng):
        # spatialmath negates only the real part, which negates the translation of about half of random products
        a = RigidTransform.from_components(rng.normal(size=(1000, 3)), Rotation.random(1000, rng=rng))
        b = RigidTransform.from_components(rng.normal(size=(1000, 3)), Rotation.random(1000, rng=rng))
        prod = dualquat_mul(a.as_dual_quat(), b.as_dual_quat())
        flipped = prod[:, 3] < 0
        assert 0.3 < flipped.mean() < 0.7  # the case is exercised
        canon = dualquat_canonical(prod)
        np.testing.assert_array_equal(canon[~flipped], prod[~flipped])
        np.testing.assert_array_equal(canon[flipped], -prod[flipped])
        t_ref = (a * b).translation
        np.testing.assert_allclose(qt_from_dualquat(canon)[1], t_ref, atol=1e-13)
        naive = prod.copy()
        naive[flipped, :4] *= -1  # the bug
        wrong = np.abs(qt_from_dualquat(naive)[1] - t_ref).max(axis=1) > 1e-6
        np.testing.assert_array_equal(wrong, flipped & (np.linalg.norm(t_ref, axis=1) > 1e-6))

    @pytest.mark.parametrize("scale", [1.0, 0.3, 7.0])
    @pytest.mark.parametrize("t", [[0.0, 0.0, 0.0], [1.0, -2.0, 0.5], [0.0, 0.0, 1e-300]])
    def test_log_at_minus_one_is_finite(self, scale, t):
        # amino's dual-quaternion log returns NaN at r_v = 0, r_w < 0; a logarithm exists there
        s = dualquat_from_qt([0, 0, 0, -1.0], t) * scale
        s[7] += 0.25  # a general (non-unit) dual scalar too
        out = dualquat_log(s)
        assert np.all(np.isfinite(out))
        np.testing.assert_allclose(np.linalg.norm(out[:3]), np.pi, rtol=EPS)
        np.testing.assert_allclose(out[3], np.log(scale), atol=EPS)
        np.testing.assert_allclose(dualquat_exp(out), s, atol=8 * EPS * scale)
        np.testing.assert_allclose(mp_dqexp(out), s, atol=8 * EPS * scale)
        h = dualquat_pow(s, 0.5)
        np.testing.assert_allclose(dualquat_mul(h, h), s, atol=16 * EPS * scale)
        if np.any(t):  # the rotation axis is along the translation (the only choice with a finite log)
            tn = np.asarray(t) / max(np.abs(t))
            tn /= np.linalg.norm(tn)
            np.testing.assert_allclose(out[:3], np.pi * tn, atol=4 * EPS)

    def test_pow_half_is_float64(self, transforms):
        # scipy's RigidTransform.__pow__ evaluates fractional powers in float32
        s = transforms.as_dual_quat()
        s = s[np.linalg.norm(transforms.translation, axis=1) > 0]  # keep the pure-rotation rows too small to matter
        h = dualquat_pow(s, 0.5)
        assert np.abs(dualquat_mul(h, h) - s).max() <= 1e-15 * (1 + np.abs(s[:, 4:]).max())
        c = dualquat_canonical(s)
        hc = dualquat_pow(c, 0.5)
        assert np.abs(dualquat_mul(hc, hc) - c).max() <= 1e-15 * (1 + np.abs(s[:, 4:]).max())
        # the principal half screw has half the angle, sign kept (no canonicalisation)
        np.testing.assert_allclose(twist_from_dualquat(hc), 0.5 * twist_from_dualquat(c), atol=1e-13)

    def test_pow_half_squared_to_1e_15(self, rng):
        s = dualquat_from_twist(rng.normal(size=(5000, 6)))  # |t| ~ 1, every rotation angle
        for x in (s, dualquat_canonical(s)):
            h = dualquat_pow(x, 0.5)
            assert np.abs(dualquat_mul(h, h) - x).max() <= 1e-15


class TestSpecialPoints:
    def test_identity(self):
        np.testing.assert_array_equal(dualquat_identity(), IDENTITY)
        out = dualquat_identity((2, 3))
        assert out.shape == (2, 3, 8)
        np.testing.assert_array_equal(out[1, 2], IDENTITY)
        assert dualquat_identity(4).shape == (4, 8)
        np.testing.assert_array_equal(dualquat_log(IDENTITY), np.zeros(8))
        np.testing.assert_array_equal(twist_from_dualquat(IDENTITY), np.zeros(6))

    def test_screw_of_identity_and_pure_translation(self):
        n, p, d, th = screw_from_dualquat(IDENTITY)
        np.testing.assert_array_equal(n, [1, 0, 0])
        np.testing.assert_array_equal(p, [0, 0, 0])
        assert d == 0 and th == 0
        s = dualquat_from_qt([0, 0, 0, -2.0], [0.0, 3.0, -4.0])
        n, p, d, th = screw_from_dualquat(s)
        np.testing.assert_allclose(n, [0, 0.6, -0.8], atol=EPS)
        np.testing.assert_array_equal(p, [0, 0, 0])
        np.testing.assert_allclose(d, 5.0, rtol=EPS)
        assert th == 0
        np.testing.assert_allclose(dualquat_from_screw(n, p, d, th), -s, atol=2 * EPS)

    @pytest.mark.parametrize("angle", [np.pi, 2.0, 1e-8, 1e-300])
    def test_screw_at_half_turn_and_tiny_angles(self, angle):
        n0, p0 = np.array([0.0, 0.6, 0.8]), np.array([1.0, 2.0, -1.5])
        p0 = p0 - (p0 @ n0) * n0
        # pure rotation about an offset axis: the foot point is recovered to full accuracy at any angle
        n, p, d, th = screw_from_dualquat(dualquat_from_screw(n0, p0, 0.0, angle))
        np.testing.assert_allclose(n, n0, atol=EPS)
        np.testing.assert_allclose(th, angle, rtol=2 * EPS)
        assert abs(d) <= 4 * EPS * angle
        np.testing.assert_allclose(p, p0, rtol=0, atol=8 * EPS)
        # with a translation along the axis, the foot point is ill-conditioned as angle -> 0 (an axis tilt of one
        # ulp is a translation eps*d across the axis, i.e. a foot shift eps*d/angle)
        n, p, d, th = screw_from_dualquat(dualquat_from_screw(n0, p0, 0.75, angle))
        np.testing.assert_allclose(n, n0, atol=EPS)
        np.testing.assert_allclose(th, angle, rtol=2 * EPS)
        np.testing.assert_allclose(d, 0.75, rtol=8 * EPS)
        np.testing.assert_allclose(p, p0, rtol=0, atol=8 * EPS * (1 + 1 / angle))

    def test_twist_at_half_turn(self):
        xi = np.array([0.0, 0.0, np.pi, 1.0, 2.0, 3.0])
        s = dualquat_from_twist(xi)
        out = twist_from_dualquat(s)
        np.testing.assert_allclose(matrix_from_dualquat(dualquat_from_twist(out)), matrix_from_dualquat(s), atol=1e-15)
        assert np.linalg.norm(out[:3]) <= np.pi
        ref = RigidTransform.from_exp_coords(xi).as_matrix()
        np.testing.assert_allclose(matrix_from_dualquat(s), ref, atol=1e-15)

    def test_log_zero_dual_and_negative_real_quaternion(self):
        out = dualquat_log([0, 0, 0, -2.0, 0, 0, 0, 0])
        np.testing.assert_allclose(out, [np.pi, 0, 0, np.log(2.0), 0, 0, 0, 0])

    def test_nonunit_inverse(self, rng):
        s = rng.normal(size=(100, 8))
        i = dualquat_inv(s)
        np.testing.assert_allclose(dualquat_mul(s, i), np.broadcast_to(IDENTITY, s.shape), atol=1e-13)
        np.testing.assert_allclose(dualquat_mul(i, s), np.broadcast_to(IDENTITY, s.shape), atol=1e-13)
        tiny = s * 1e-200  # no overflow in 1/|r|**2
        np.testing.assert_allclose(dualquat_inv(tiny) * 1e-200, i, rtol=0, atol=1e-14 * np.abs(i).max())

    def test_from_matrix_tolerates_roundoff_in_bottom_row(self):
        m = np.eye(4)
        m[3, 0] = 1e-13
        np.testing.assert_array_equal(dualquat_from_matrix(m), IDENTITY)

    def test_broadcasting(self, rng):
        a = rng.normal(size=(5, 1, 8))
        b = rng.normal(size=(1, 7, 8))
        out = dualquat_mul(a, b)
        assert out.shape == (5, 7, 8)
        np.testing.assert_allclose(out[3, 4], dualquat_mul(a[3, 0], b[0, 4]))
        assert dualquat_transform(a, rng.normal(size=(7, 3))).shape == (5, 7, 3)
        assert dualquat_sclerp(a[0, 0], b[0, 0], np.linspace(0, 1, 3)).shape == (3, 8)
        assert dualquat_pow(a, np.ones((5, 4))).shape == (5, 4, 8)
        n, p, d, th = screw_from_dualquat(a)
        assert n.shape == p.shape == (5, 1, 3) and d.shape == th.shape == (5, 1)
        assert dualquat_from_screw([0, 0, 1], np.zeros((4, 3)), [1.0, 2.0, 3.0, 4.0], 0.5).shape == (4, 8)
        q, t = qt_from_dualquat(a)
        assert q.shape == (5, 1, 4) and t.shape == (5, 1, 3)
        assert matrix_from_dualquat(a).shape == (5, 1, 4, 4)
        assert dualquat_norm(a).shape == (5, 1, 2)
        assert twist_from_dualquat(a).shape == (5, 1, 6)
        assert dualquat_from_twist(np.zeros((2, 6))).shape == (2, 8)
        assert dualquat_integrate(a, np.zeros(6), np.ones(3)).shape == (5, 3, 8)

    @pytest.mark.parametrize(
        "call",
        [
            lambda: dualquat_log([0, 0, 0, -1.0, 0, 0, 0, 0.25]),
            lambda: dualquat_log(dualquat_from_qt([0, 0, 0, -1.0], [1, 2, 3])),
            lambda: dualquat_pow([0, 0, 0, -1.0, 0, 0, 0, 0.25], 0.5),
            lambda: dualquat_log(IDENTITY),
            lambda: dualquat_exp(np.zeros(8)),
            lambda: dualquat_pow(IDENTITY, 0.3),
            lambda: twist_from_dualquat(IDENTITY),
            lambda: twist_from_dualquat([1.0, 0, 0, 0, 0, 1, 0, 0]),
            lambda: dualquat_from_twist(np.zeros(6)),
            lambda: screw_from_dualquat(IDENTITY),
            lambda: screw_from_dualquat(dualquat_from_qt([0, 0, 0, 1.0], [1, 2, 3])),
            lambda: screw_from_dualquat([1.0, 0, 0, 0, 0, 1, 0, 0]),
            lambda: dualquat_from_screw([0, 0, 1.0], [1, 2, 3], 0.0, 0.0),
            lambda: dualquat_sclerp(IDENTITY, IDENTITY, 0.3),
            lambda: dualquat_sclerp(IDENTITY, -IDENTITY, 0.3),
            lambda: dualquat_log([1e-300, 0, 0, 1.0, 0, 1, 0, 0]),
        ],
    )
    def test_special_points_raise_no_floating_point_warnings(self, call):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            out = call()
        assert all(np.all(np.isfinite(o)) for o in (out if isinstance(out, tuple) else (out,)))

    def test_float32_and_lists_accepted(self):
        out = dualquat_mul(np.array(IDENTITY, np.float32), [1, 2, 3, 4, 5, 6, 7, 8])
        assert out.dtype == np.float64
        np.testing.assert_array_equal(out, [1, 2, 3, 4, 5, 6, 7, 8])

    def test_nan_propagates_in_algebra(self):
        assert np.isnan(dualquat_mul([np.nan, 0, 0, 1, 0, 0, 0, 0], IDENTITY)).any()
        assert np.isnan(dualquat_transform([0, 0, 0, 1, np.nan, 0, 0, 0], [1, 2, 3])).any()


class TestIntegrate:
    def test_constant_screw_motion(self, rng):
        # rotation at rate w0 about the line through c with direction n, translation at rate h along n
        n = np.array([1.0, 2.0, 2.0]) / 3.0
        c = np.array([0.5, -1.0, 2.0])
        w0, h = 1.3, 0.4
        s0 = dualquat_from_qt(Rotation.random(rng=rng).as_quat(), rng.normal(size=3))
        omega = w0 * n
        v_space = np.cross(c, omega) + h * n  # velocity of the body point at the world origin
        for tau in (1e-3, 0.5, 2.0, 7.0):
            ref = dualquat_mul(dualquat_from_screw(n, c, h * tau, w0 * tau), s0)
            out = dualquat_integrate(s0, np.concatenate([omega, v_space]), tau, frame="space")
            assert same_dq(out, ref, 1e-14 * (1 + tau))

    def test_many_small_steps_equal_one_step(self, rng):
        s0 = dualquat_from_qt(Rotation.random(rng=rng).as_quat(), rng.normal(size=3))
        xi = rng.normal(size=6)
        for frame in ("space", "body"):
            s = s0
            for _ in range(1000):
                s = dualquat_integrate(s, xi, 1e-3, frame=frame)
            np.testing.assert_allclose(s, dualquat_integrate(s0, xi, 1.0, frame=frame), atol=1e-12)

    def test_matches_the_velocity_ode(self, rng):
        # space: Rdot = [ω]x R, tdot = ω x t + v ;  body: Rdot = R [ω]x, tdot = R v.  RK4 on the 4x4 matrix.
        s0 = dualquat_from_qt(Rotation.random(rng=rng).as_quat(), rng.normal(size=3))
        xi = rng.normal(size=6)
        hat = np.zeros((4, 4))
        hat[:3, :3] = [[0, -xi[2], xi[1]], [xi[2], 0, -xi[0]], [-xi[1], xi[0], 0]]
        hat[:3, 3] = xi[3:]
        for frame, f in (("space", lambda m: hat @ m), ("body", lambda m: m @ hat)):
            m = matrix_from_dualquat(s0)
            dt = 1e-3
            for _ in range(1000):
                k1 = f(m)
                k2 = f(m + dt / 2 * k1)
                k3 = f(m + dt / 2 * k2)
                k4 = f(m + dt * k3)
                m = m + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            out = matrix_from_dualquat(dualquat_integrate(s0, xi, 1.0, frame=frame))
            np.testing.assert_allclose(out, m, atol=1e-11)

    def test_body_equals_space_with_adjoint(self, rng):
        s0 = dualquat_from_qt(Rotation.random(rng=rng).as_quat(), rng.normal(size=3))
        xi_b = rng.normal(size=6)
        q, t = qt_from_dualquat(s0)
        r = Rotation.from_quat(q)
        w_s = r.apply(xi_b[:3])
        v_s = r.apply(xi_b[3:]) + np.cross(t, w_s)  # Ad_T [ω_b, v_b]
        out_b = dualquat_integrate(s0, xi_b, 0.8, frame="body")
        out_s = dualquat_integrate(s0, np.concatenate([w_s, v_s]), 0.8, frame="space")
        np.testing.assert_allclose(out_b, out_s, atol=1e-14)


class TestBadInput:
    def test_wrong_trailing_size_names_argument(self):
        with pytest.raises(ValueError, match=r"b must have shape \(\.\.\., 8\)"):
            dualquat_mul(IDENTITY, np.ones(7))
        with pytest.raises(ValueError, match=r"matrix must have shape \(\.\.\., 4, 4\)"):
            dualquat_from_matrix(np.eye(3))
        with pytest.raises(ValueError, match=r"xi must have shape \(\.\.\., 6\)"):
            dualquat_from_twist([1, 2, 3])
        with pytest.raises(ValueError, match=r"points must have shape \(\.\.\., 3\)"):
            dualquat_transform(IDENTITY, [1, 2, 3, 4])
        with pytest.raises(ValueError, match=r"t must have shape \(\.\.\., 3\)"):
            dualquat_from_qt([0, 0, 0, 1], [1, 2])

    def test_mismatched_batches_name_both(self):
        with pytest.raises(ValueError, match=r"a has batch shape \(2,\), b has batch shape \(3,\)"):
            dualquat_mul(np.ones((2, 8)), np.ones((3, 8)))
        with pytest.raises(ValueError, match=r"s has batch shape \(2,\), points has batch shape \(3,\)"):
            dualquat_transform(np.ones((2, 8)), np.ones((3, 3)))
        with pytest.raises(ValueError, match=r"s0 has batch shape \(2,\), s1 has batch shape \(3,\)"):
            dualquat_sclerp(np.ones((2, 8)), np.ones((3, 8)), 0.5)
        with pytest.raises(ValueError, match=r"axis has batch shape \(2,\), point has batch shape \(3,\)"):
            dualquat_from_screw(np.ones((2, 3)), np.ones((3, 3)), 1.0, 1.0)

    @pytest.mark.parametrize("bad", ["abcdefgh", [1, 2, 3, 4, 5, 6, 7, 8j], [[1, 2], [3]], [True] * 8])
    def test_non_numeric_is_type_error(self, bad):
        with pytest.raises(TypeError, match="s must be"):
            dualquat_normalize(bad)

    @pytest.mark.parametrize(
        "fn",
        [
            dualquat_inv,
            dualquat_norm,
            dualquat_normalize,
            dualquat_log,
            matrix_from_dualquat,
            twist_from_dualquat,
            screw_from_dualquat,
            qt_from_dualquat,
            lambda s: dualquat_transform(s, [1, 2, 3]),
            lambda s: dualquat_pow(s, 0.5),
        ],
    )
    def test_zero_real_part_raises(self, fn):
        s = np.array([IDENTITY, [0, 0, 0, 0, 1.0, 2.0, 3.0, 4.0]])
        msg = r"s must be a dual quaternion with a nonzero real part; element \(1,\)"
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a clean ValueError, no RuntimeWarning on the way
            with pytest.raises(ValueError, match=msg):
                fn(s)

    def test_zero_in_sclerp_from_qt_and_screw(self):
        z = [0, 0, 0, 0, 1.0, 0, 0, 0]
        with pytest.raises(ValueError, match="s1 must be a dual quaternion with a nonzero real part"):
            dualquat_sclerp(IDENTITY, z, 0.5)
        with pytest.raises(ValueError, match="s0 must be a dual quaternion with a nonzero real part"):
            dualquat_sclerp(z, IDENTITY, 0.5)
        with pytest.raises(ValueError, match="q must be a nonzero quaternion"):
            dualquat_from_qt([0, 0, 0, 0], [1, 2, 3])
        with pytest.raises(ValueError, match="axis must be a nonzero"):
            dualquat_from_screw([0, 0, 0], [1, 2, 3], 1.0, 0.5)

    def test_bad_matrices(self):
        m = np.eye(4)
        m[1, 3] = np.nan
        with pytest.raises(ValueError, match="matrix contains NaN or infinity"):
            dualquat_from_matrix(m)
        m = np.eye(4)
        m[3, 2] = 1e-9
        with pytest.raises(ValueError, match=r"bottom row is not \[0, 0, 0, 1\]"):
            dualquat_from_matrix(m)
        m = np.stack([np.eye(4), 2 * np.eye(4)])
        with pytest.raises(ValueError, match="bottom row"):
            dualquat_from_matrix(m)

    def test_bad_frame(self):
        with pytest.raises(ValueError, match="frame must be"):
            dualquat_integrate(IDENTITY, np.zeros(6), 0.1, frame="world")
