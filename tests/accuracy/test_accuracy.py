"""The 4ε accuracy bar, per function and per input case, against mpmath (see docs/accuracy.md for the method).

Each case is one float64 input (a rotation built in mpmath from an angle in ``ANGLES`` and a seeded random axis,
and for dual quaternions a translation of norm 1e-6, 1 or 1e6, rounded once); the truth is the exact value of the
function at that input (``accuracy_reference``), and the error is normwise relative, ``‖computed − truth‖ /
‖truth‖``, in units of ε = 2**-52.  The references themselves are cross-checked at the end of this module.
"""

from __future__ import annotations

import accuracy_cases as cases
import accuracy_reference as ref
import numpy as np
import pytest
from mpmath import mp, mpf

ALL = cases.all_cases()
CASES = [c for c in ALL if c.in_bar]


@pytest.mark.parametrize("case", CASES, ids=[c.cid for c in CASES])
def test_within_bar(case: cases.Case) -> None:
    computed = case.computed()
    err = ref.normwise_error(computed, case.truth())
    parts = ", ".join(f"{n} {ref.normwise_error(computed, case.truth(), sl):.3g} ε" for n, sl in case.parts)
    assert err <= ref.BAR, (
        f"{case.cid}: error {err:.4g} ε exceeds the {ref.BAR:g} ε bar" + (f" (parts: {parts})" if parts else "")
    )


def test_matrix_to_quat_sign() -> None:
    """quat_from_matrix returns w >= 0 (the error above is measured up to sign; the sign rule is checked here)."""
    mats = [c for c in CASES if c.func == "quat_from_matrix"]
    assert len(mats) == len(cases.ANGLES) * cases.AXES_PER_ANGLE
    w = np.array([c.computed()[3] for c in mats])
    assert np.all(w >= 0.0), [c.cid for c, wi in zip(mats, w, strict=True) if wi < 0]


def test_case_coverage() -> None:
    """Every function of the bar has every angle (and translation norm where applicable), and the truth of a
    tiny-angle input is not flushed (guards the suite itself against a degenerate case generator)."""
    for func in cases.ALL_FUNCS:
        mine = [c for c in CASES if c.func == func]
        assert {c.angle for c in mine} == {a[0] for a in cases.ANGLES}, func
        if func in cases.DQ_FUNCS:
            assert {c.tnorm for c in mine} == {t[0] for t in cases.TNORMS}, func
    assert len({c.cid for c in ALL}) == len(ALL)  # ids are unique (the truths are cached by id)
    tiny = next(c for c in CASES if c.func == "quat_from_rotvec" and c.angle == "1e-300")
    assert 0 < float(abs(tiny.truth()[0][0])) < 1e-299


# ---------------------------------------------------------------------------------------------------------------
# the references, checked against independent constructions
# ---------------------------------------------------------------------------------------------------------------


def _close(a: list, b: list, tol: float = 1e-40) -> bool:
    with mp.workdps(ref.DPS):
        return ref.norm([x - y for x, y in zip(a, b, strict=True)]) <= tol * max(ref.norm(b), mpf(1))


@pytest.mark.parametrize("angle", ["1e-8", "1", "pi-1e-4"])
def test_reference_twist_is_matrix_exponential(angle: str) -> None:
    """exp(½(ω + ε v)) of the reference equals the SE(3) matrix exponential exp([[ω×, v], [0, 0]]) (mpmath.expm):
    rotation exp(ω/2) and translation J_l(ω) v."""
    c = next(c for c in ALL if c.func == "dualquat_from_twist" and c.angle == angle and c.tnorm == "1")
    dq = c.truth()[0]
    with mp.workdps(ref.DPS):
        w0, w1, w2, v0, v1, v2 = ref.exact(c.args[0])
        m = mp.matrix([[0, -w2, w1, v0], [w2, 0, -w0, v1], [-w1, w0, 0, v2], [0, 0, 0, 0]])
        e = mp.expm(m)
        t = [e[i, 3] for i in range(3)]
        assert _close(ref.dq_translation(dq), t)
        r = ref.rot_matrix(dq[:4])
        assert _close([x for row in r for x in row], [e[i, j] for i in range(3) for j in range(3)])


def test_reference_nearest_rotation() -> None:
    """Bar-Itzhack's eigenvector gives back q for an exact rotation matrix, and is the nearest rotation of a
    perturbed one (no rotation near it is closer in Frobenius norm)."""
    rng = np.random.default_rng(3)
    with mp.workdps(ref.DPS):
        q = cases.random_rotation(rng)
        if q[3] < 0:
            q = [-x for x in q]
        m = ref.rot_matrix(q)
        got = ref.nearest_rotation_quat(np.array([[float(x) for x in row] for row in m]))
        assert ref.norm([a - b for a, b in zip(got, q, strict=True)]) < 1e-15  # float64 rounding of m only
        pert = np.array([[float(x) for x in row] for row in m]) + 1e-3 * rng.normal(size=(3, 3))
        best = ref.nearest_rotation_quat(pert)

        def dist(qq: list) -> mpf:
            r = ref.rot_matrix(qq)
            return mp.fsum((mpf(float(pert[i, j])) - r[i][j]) ** 2 for i in range(3) for j in range(3))

        d0 = dist(best)
        for _ in range(20):
            nb = ref.normalize([x + mpf(float(e)) for x, e in zip(best, 1e-4 * rng.normal(size=4), strict=True)])
            assert dist(nb) > d0


def test_reference_screw_round_trip() -> None:
    """The screw reference inverts the Walker-form reference (eqs. (11)-(12)) on an exactly unit input."""
    rng = np.random.default_rng(5)
    for _ in range(5):
        n = cases.random_unit(rng)
        with mp.workdps(ref.DPS):
            p = ref.cross(n, cases.random_unit(rng))  # ⊥ n
            d, th = mpf(float(rng.normal())), mpf(float(rng.uniform(0.1, 3.0)))
            n_f, p_f = ref.to_f64(n), ref.to_f64(p)
            s = ref.dualquat_from_screw(n_f, p_f, float(d), float(th))[0]
            back = ref.screw_from_dualquat(ref.to_f64(s))[0]  # rounding s to float64 costs ~1e-16
            want = ref.normalize(ref.exact(n_f)) + ref.exact(p_f) + [d, th]
            assert ref.norm([a - b for a, b in zip(back, want, strict=True)]) < 1e-14
