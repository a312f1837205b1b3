"""scipy / pytransform3d interop, and executable checks of every peer mapping stated in docs/conventions.md."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial.transform import RigidTransform, Rotation

from dualpose.algebra import quat as fq
from dualpose.algebra.classes import DualQuaternion, Quaternion
from dualpose.algebra.interop import (
    dualquat_from_pq,
    dualquat_from_scipy,
    pq_from_dualquat,
    quat_from_scipy,
    scipy_from_dualquat,
    scipy_from_quat,
)

TOL = 1e-12
WXYZ = [3, 0, 1, 2]
XYZW = [1, 2, 3, 0]

# Golden values produced by pytransform3d 3.17.0 (not a test dependency):
#   pq = [1, -2, 0.5, q] with q = normalize([0.5, 0.1, -0.7, 0.3]) (wxyz)
#   pytransform3d.transformations.dual_quaternion_from_pq(pq)
#   pytransform3d.transformations.screw_parameters_from_dual_quaternion(dq) -> (point, axis, pitch h, θ)
PT3D_PQ = np.array([1.0, -2.0, 0.5, 0.5455447255899809, 0.1091089451179962, -0.7637626158259733, 0.32732683535398854])
PT3D_DQ = np.array(
    [
        0.5455447255899809,
        0.1091089451179962,
        -0.7637626158259733,
        0.32732683535398854,
        -0.9001487972234685,
        0.13638618139749523,
        -0.6819309069874762,
        -0.13638618139749523,
    ]
)
PT3D_SCREW_POINT = np.array([0.46610169491525444, 0.08474576271186443, 0.042372881355932125])
PT3D_SCREW_AXIS = np.array([0.1301889109808239, -0.9113223768657671, 0.3905667329424717])
PT3D_SCREW_PITCH = 1.0808055715923937  # ratio d/θ
PT3D_SCREW_ANGLE = 1.9875147645831328


def same_up_to_sign(a, b, atol):
    d = np.minimum(np.abs(a - b).max(axis=-1), np.abs(a + b).max(axis=-1))
    return bool(np.all(d <= atol))


@pytest.fixture
def rots(rng):
    return Rotation.random(500, rng=rng)


@pytest.fixture
def tfs(rng):
    return RigidTransform.from_components(rng.normal(size=(500, 3)) * 4, Rotation.random(500, rng=rng))


class TestScipyQuaternion:
    def test_round_trip_keeps_sign(self, rots):
        q = quat_from_scipy(rots)
        assert q.shape == (500, 4) and q.dtype == np.float64
        np.testing.assert_array_equal(q, rots.as_quat())
        neg = -q
        back = quat_from_scipy(scipy_from_quat(neg))  # scipy renormalizes (last-bit changes) but keeps the sign
        np.testing.assert_allclose(back, neg, rtol=0, atol=4e-16)

    def test_apply_and_matrix_agree(self, rots, rng):
        q = quat_from_scipy(rots)
        v = rng.normal(size=(500, 3))
        np.testing.assert_allclose(fq.quat_rotate(q, v), rots.apply(v), atol=TOL)
        np.testing.assert_allclose(fq.matrix_from_quat(q), rots.as_matrix(), atol=TOL)
        r = scipy_from_quat(q)
        np.testing.assert_allclose(r.as_matrix(), fq.matrix_from_quat(q), atol=TOL)

    def test_normalizes_like_scipy(self):
        r = scipy_from_quat([0.0, 0.0, 0.0, 2.0])
        np.testing.assert_array_equal(r.as_quat(), [0, 0, 0, 1])

    def test_single_and_nd_batches(self, rng):
        assert quat_from_scipy(Rotation.identity()).shape == (4,)
        assert scipy_from_quat([0, 0, 0, 1.0]).single
        q = Quaternion.random((3, 4), rng).array
        r = scipy_from_quat(q)
        assert r.shape == (3, 4)
        np.testing.assert_allclose(quat_from_scipy(r), q, rtol=0, atol=4e-16)

    def test_class_methods(self, rots, rng):
        x = Quaternion.from_scipy(rots)
        assert type(x) is Quaternion and x.shape == (500,)
        v = rng.normal(size=3)
        np.testing.assert_allclose(x.apply(v), rots.apply(v), atol=TOL)
        back = x.as_scipy()
        assert isinstance(back, Rotation)
        np.testing.assert_allclose(back.as_quat(), rots.as_quat(), rtol=0, atol=4e-16)
        assert Quaternion.identity().as_scipy().single

    def test_bad_input(self):
        with pytest.raises(TypeError, match="rotation must be a scipy.spatial.transform.Rotation"):
            quat_from_scipy(np.array([0, 0, 0, 1.0]))
        with pytest.raises(ValueError, match=r"q must have shape \(\.\.\., 4\)"):
            scipy_from_quat([0, 0, 1.0])
        with pytest.raises(ValueError, match=r"q must be a nonzero quaternion; element \(1,\) is zero"):
            scipy_from_quat([[0, 0, 0, 1.0], [0, 0, 0, 0]])
        with pytest.raises(ValueError, match="q contains NaN"):
            scipy_from_quat([np.nan, 0, 0, 1])
        with pytest.raises(TypeError, match="real numeric"):
            scipy_from_quat(["a", "b", "c", "d"])


class TestScipyDualQuaternion:
    def test_layout_is_scipy_default(self, tfs):
        dq = dualquat_from_scipy(tfs)
        np.testing.assert_array_equal(dq, tfs.as_dual_quat())
        t, r = tfs.as_components()
        tq = np.concatenate([t, np.zeros((500, 1))], axis=1)
        np.testing.assert_allclose(dq[:, 4:], 0.5 * fq.quat_mul(tq, dq[:, :4]), atol=TOL)  # dual = ½ t ⊗ real
        # scipy stores a matrix, so the sign comes from its matrix -> quaternion step (scipy 1.17: the real part's
        # largest-magnitude component is positive), not from the rotation it was built with
        real = dq[:, :4]
        assert (real[np.arange(500), np.abs(real).argmax(axis=1)] > 0).all()
        assert (real[:, 3] < 0).any()
        assert same_up_to_sign(dq[:, :4], r.as_quat(), TOL)

    def test_round_trip_and_apply(self, tfs, rng):
        dq = dualquat_from_scipy(tfs)
        back = scipy_from_dualquat(dq)
        assert isinstance(back, RigidTransform) and back.shape == (500,)
        np.testing.assert_allclose(back.as_matrix(), tfs.as_matrix(), atol=TOL)
        np.testing.assert_allclose(dualquat_from_scipy(back), dq, atol=TOL)
        p = rng.normal(size=(500, 3)) * 3
        x = DualQuaternion(dq)
        np.testing.assert_allclose(x.apply(p), tfs.apply(p), atol=TOL)
        np.testing.assert_allclose(x.as_matrix(), tfs.as_matrix(), atol=TOL)

    def test_negative_sign_same_transform(self, tfs):
        dq = dualquat_from_scipy(tfs)
        np.testing.assert_allclose(scipy_from_dualquat(-dq).as_matrix(), tfs.as_matrix(), atol=TOL)

    def test_single_and_nd(self, rng):
        assert dualquat_from_scipy(RigidTransform.identity()).shape == (8,)
        assert scipy_from_dualquat([0, 0, 0, 1.0, 0, 0, 0, 0]).single
        x = DualQuaternion.random((2, 5), rng)
        tf = x.as_scipy()
        assert tf.shape == (2, 5)
        np.testing.assert_allclose(tf.as_matrix(), x.as_matrix(), atol=TOL)

    def test_class_methods(self, tfs, rng):
        x = DualQuaternion.from_scipy(tfs)
        assert type(x) is DualQuaternion and x.shape == (500,)
        y = x.as_scipy()
        np.testing.assert_allclose(y.as_matrix(), tfs.as_matrix(), atol=TOL)
        np.testing.assert_allclose((x * x[0]).as_matrix(), (tfs * tfs[0]).as_matrix(), atol=TOL)

    def test_bad_input(self):
        with pytest.raises(TypeError, match="transform must be a scipy.spatial.transform.RigidTransform"):
            dualquat_from_scipy(Rotation.identity())
        with pytest.raises(ValueError, match=r"dq must have shape \(\.\.\., 8\)"):
            scipy_from_dualquat(np.zeros(7))
        # scipy's from_dual_quat would silently return the identity rotation here
        with pytest.raises(ValueError, match="the real part of dq must be a nonzero quaternion"):
            scipy_from_dualquat([0, 0, 0, 0, 1.0, 2, 3, 4])
        with pytest.raises(ValueError, match="dq contains NaN"):
            scipy_from_dualquat([0, 0, 0, 1.0, np.inf, 0, 0, 0])


class TestPytransform3d:
    def test_golden_pq_to_dualquat(self):
        dq = dualquat_from_pq(PT3D_PQ)
        np.testing.assert_allclose(dq[..., [3, 0, 1, 2, 7, 4, 5, 6]], PT3D_DQ, atol=1e-15)

    def test_golden_dualquat_to_pq(self):
        dq = PT3D_DQ[[1, 2, 3, 0, 5, 6, 7, 4]]
        np.testing.assert_allclose(pq_from_dualquat(dq), PT3D_PQ, atol=1e-15)

    def test_round_trip_batch_keeps_sign(self, rng):
        q = Quaternion.random((4, 5), rng).array
        t = rng.normal(size=(4, 5, 3))
        pq = np.concatenate([t, q[..., WXYZ]], axis=-1)
        dq = dualquat_from_pq(pq)
        assert dq.shape == (4, 5, 8)
        np.testing.assert_allclose(dq[..., :4], q, rtol=0, atol=4e-16)  # renormalized, sign kept
        np.testing.assert_allclose(pq_from_dualquat(dq), pq, atol=TOL)
        np.testing.assert_allclose(pq_from_dualquat(-dq)[..., 3:], -pq[..., 3:], atol=0)

    def test_golden_screw_parameters(self):
        dq = PT3D_DQ[[1, 2, 3, 0, 5, 6, 7, 4]]
        n, p, d, th = DualQuaternion(dq).as_screw()
        np.testing.assert_allclose(n, PT3D_SCREW_AXIS, atol=1e-13)
        np.testing.assert_allclose(p, PT3D_SCREW_POINT, atol=1e-13)
        np.testing.assert_allclose(d, PT3D_SCREW_PITCH * PT3D_SCREW_ANGLE, atol=1e-13)  # Walker d = h θ
        np.testing.assert_allclose(th, PT3D_SCREW_ANGLE, atol=1e-13)

    def test_bad_input(self):
        with pytest.raises(ValueError, match=r"pq must have shape \(\.\.\., 7\)"):
            dualquat_from_pq(np.zeros(8))


class TestConventionsDocument:
    """Each claim in docs/conventions.md that can be executed without the peer installed."""

    def test_walker_q_w_matrices(self, rng):
        a, b = rng.normal(size=(2, 4))
        Q, W = fq.quat_left_matrix, fq.quat_right_matrix
        np.testing.assert_allclose(Q(a) @ b, fq.quat_mul(a, b), atol=1e-15)  # Q(a) b = a ⊗ b
        np.testing.assert_allclose(W(b) @ a, fq.quat_mul(a, b), atol=1e-15)  # W(b) a = a ⊗ b
        # Walker eq. (4)/(17)/(18): diag(R, 1) = W(r)^T Q(r), R the active rotation matrix (scalar-last r)
        r = fq.quat_normalize(a)
        m = W(r).T @ Q(r)
        np.testing.assert_allclose(m[:3, :3], Rotation.from_quat(r).as_matrix(), atol=1e-15)
        np.testing.assert_allclose(m[3], [0, 0, 0, 1], atol=1e-15)

    def test_walker_dual_part(self, tfs):
        # s = W(r) t_q with t_q = ½[t; 0] (eqs. (20), (25)) is dualpose's (and scipy's) dual part; t_q = W(r)^T s (19)
        dq = dualquat_from_scipy(tfs)
        t = tfs.translation
        tq = 0.5 * np.concatenate([t, np.zeros((len(t), 1))], axis=1)
        W = fq.quat_right_matrix(dq[:, :4])
        np.testing.assert_allclose(np.einsum("nij,nj->ni", W, tq), dq[:, 4:], atol=TOL)
        np.testing.assert_allclose(np.einsum("nji,nj->ni", W, dq[:, 4:]), tq, atol=TOL)
        # unit constraints (13)-(14)
        np.testing.assert_allclose(np.sum(dq[:, :4] ** 2, axis=1), 1.0, atol=TOL)
        np.testing.assert_allclose(np.sum(dq[:, :4] * dq[:, 4:], axis=1), 0.0, atol=TOL)

    @staticmethod
    def hol_odot(p, q):
        """Hol's ⊙ (scalar first), eq. (10a) with the notes' transcription typos fixed (p0 q0, p0 q)."""
        p0, pv, q0, qv = p[0], p[1:], q[0], q[1:]
        return np.concatenate([[p0 * q0 - pv @ qv], p0 * qv + q0 * pv + np.cross(pv, qv)])

    @staticmethod
    def hol_exp(v):
        n = np.linalg.norm(v)
        return np.concatenate([[np.cos(n)], v / n * np.sin(n)])

    def test_hol_product_is_hamilton_scalar_first(self, rng):
        p, q = rng.normal(size=(2, 4))  # xyzw
        np.testing.assert_allclose(self.hol_odot(p[WXYZ], q[WXYZ]), fq.quat_mul(p, q)[WXYZ], atol=1e-15)
        v = rng.normal(size=3)
        np.testing.assert_allclose(self.hol_exp(v), fq.quat_exp(np.r_[v, 0.0])[WXYZ], atol=1e-15)

    def test_hol_q_be_is_the_conjugate_of_dualpose_orientation(self, rng):
        # Hol (9d): q^{be}_{t+1} = exp(-T/2 ω^b) ⊙ q^{be}_t.  With q = conj(q^{be}) (body -> earth, dualpose's frame)
        # this is exactly quat_integrate(q, ω^b, T, frame="body").
        q = Quaternion.random(rng=rng).array
        omega, T = rng.normal(size=3), 0.01
        hol_be = fq.quat_conj(q)[WXYZ]
        hol_next = self.hol_odot(self.hol_exp(-T / 2 * omega), hol_be)
        ours = fq.quat_integrate(q, omega, T, frame="body")
        np.testing.assert_allclose(fq.quat_conj(hol_next[XYZW]), ours, atol=1e-15)
        # and R^{be} (earth -> body, used in (11a)) is the transpose of dualpose's matrix (body -> earth)
        np.testing.assert_allclose(fq.matrix_from_quat(hol_be[XYZW]), fq.matrix_from_quat(q).T, atol=1e-15)

    def test_scipy_scalar_first_options(self, tfs):
        r = tfs.rotation
        np.testing.assert_array_equal(r.as_quat(scalar_first=True), r.as_quat()[:, WXYZ])
        np.testing.assert_array_equal(
            tfs.as_dual_quat(scalar_first=True), tfs.as_dual_quat()[:, [3, 0, 1, 2, 7, 4, 5, 6]]
        )
        q = r.as_quat()
        np.testing.assert_allclose(Rotation.from_quat(q[:, WXYZ], scalar_first=True).as_quat(), q, atol=1e-16)

    def test_scipy_exp_coords_order(self, rng):
        # as_exp_coords = [ω, v] with R = exp(ω×), t = J_l(ω) v
        xi = rng.normal(size=6)
        tf = RigidTransform.from_exp_coords(xi)
        w, v = xi[:3], xi[3:]
        th = np.linalg.norm(w)
        K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        J = np.eye(3) + (1 - np.cos(th)) / th**2 * K + (th - np.sin(th)) / th**3 * K @ K
        np.testing.assert_allclose(tf.translation, J @ v, atol=1e-14)
        np.testing.assert_allclose(tf.rotation.as_rotvec(), w, atol=1e-14)

    def test_ros_and_eigen_snippets(self, rng):
        # ROS geometry_msgs/Quaternion (x, y, z, w) and Eigen coeffs() are dualpose's order; Eigen's 4-scalar
        # constructor takes (w, x, y, z).
        q = Quaternion.random(rng=rng).array
        ros_xyzw = dict(zip("xyzw", q, strict=True))
        np.testing.assert_array_equal([ros_xyzw[k] for k in "xyzw"], q)
        eigen_ctor_args = (q[3], q[0], q[1], q[2])  # Eigen::Quaterniond(w, x, y, z)
        np.testing.assert_array_equal(np.array(eigen_ctor_args)[XYZW], q)


def test_import_does_not_load_scipy_or_numba():
    code = (
        "import sys, dualpose.algebra.classes, dualpose.algebra.interop\n"
        "bad = [m for m in ('scipy', 'numba') if m in sys.modules]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
