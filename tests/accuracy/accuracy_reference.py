"""mpmath reference implementations for the accuracy suite.

Every reference takes the *float64* inputs that dualpose receives, converts them exactly (``mpmath.mpf(float)``)
and evaluates the mathematical function at ``DPS`` = 50 significant digits, with formulas free of cancellation
(``1 - cos x`` is written ``2 sin²(x/2)``, ``sin x / x`` is ``mpmath.sinc``), so the result is the exact value
of the function at the float64 input to far more digits than the 4ε bar needs.  A reference returns a list of
*candidate* truths (flat lists of ``mpf``); there is more than one only where the function is discontinuous at
the input (the two arcs of a slerp between orientations exactly π apart, the sign of a quaternion of a 180°
rotation), and the error is then measured to the nearest candidate.

Maps whose documented input is a unit quaternion / rotation (rotation vectors, matrices, slerp) are evaluated at
the normalized exact input, as the documentation says; general quaternion maps (exp, log, pow) are evaluated at
the exact input itself (``log`` keeps ``ln|q|``, ``pow`` keeps ``|q|**t``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from mpmath import mp, mpf

DPS = 50
EPS = 2.0**-52  # 2.220446049250313e-16
BAR = 4.0  # the accuracy bar, in units of EPS

_hp = mp.workdps(DPS)

Vec = list  # a flat list of mpf


# ---------------------------------------------------------------------------------------------------------------
# conversions and the error metric
# ---------------------------------------------------------------------------------------------------------------


@_hp
def exact(x: object) -> Vec:
    """The float64 values of ``x`` (any shape), flattened, converted to mpf exactly."""
    return [mpf(float(v)) for v in np.asarray(x, dtype=np.float64).ravel()]


def to_f64(v: Sequence) -> np.ndarray:
    """Round mpf values to the nearest float64."""
    return np.array([float(x) for x in v], dtype=np.float64)


@_hp
def _norm(v: Sequence) -> mpf:
    return mp.sqrt(mp.fsum(x * x for x in v))


@_hp
def normwise_error(computed: object, candidates: Sequence[Vec], part: slice | None = None) -> float:
    """``‖computed − truth‖ / ‖truth‖`` in units of EPS (absolute, ``‖computed − truth‖ / EPS``, where the truth
    is 0), minimised over the candidate truths; ``part`` restricts both vectors to a slice.  Non-finite computed
    values give ``inf``."""
    c = np.asarray(computed, dtype=np.float64).ravel()
    if not np.all(np.isfinite(c)):
        return float("inf")
    ce = exact(c)
    best = mpf("inf")
    for t in candidates:
        if len(t) != len(ce):
            raise ValueError(f"reference has {len(t)} components, computed {len(ce)}")
        tt, cc = (t[part], ce[part]) if part is not None else (t, ce)
        diff = _norm([a - b for a, b in zip(cc, tt, strict=True)])
        scale = _norm(tt)
        err = diff / scale if scale != 0 else diff
        best = min(best, err)
    return float(best / EPS)


# ---------------------------------------------------------------------------------------------------------------
# quaternion arithmetic in mpmath (xyzw, Hamilton)
# ---------------------------------------------------------------------------------------------------------------


def qmul(a: Sequence, b: Sequence) -> Vec:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]


def qconj(a: Sequence) -> Vec:
    return [-a[0], -a[1], -a[2], a[3]]


def cross(a: Sequence, b: Sequence) -> Vec:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a: Sequence, b: Sequence) -> mpf:
    return mp.fsum(x * y for x, y in zip(a, b, strict=True))


def norm(v: Sequence) -> mpf:
    return mp.sqrt(mp.fsum(x * x for x in v))


def normalize(v: Sequence) -> Vec:
    n = norm(v)
    return [x / n for x in v]


def mp_qexp(q: Sequence) -> Vec:
    """e**q = e**w [sinc|v| v, cos|v|] (Dantam 2014 eqs. (22)-(23))."""
    v, w = q[:3], q[3]
    th = norm(v)
    ew = mp.exp(w)
    f = ew * mp.sinc(th)
    return [f * v[0], f * v[1], f * v[2], ew * mp.cos(th)]


def mp_qlog(q: Sequence) -> Vec:
    """Principal log [atan2(|v|, w) v/|v|, ln|q|]; on the negative real axis the axis x (documented)."""
    v, w = q[:3], q[3]
    s = norm(v)
    ln = mp.log(norm(q))
    if s == 0:
        return [mp.pi if w < 0 else mpf(0), mpf(0), mpf(0), ln]
    f = mp.atan2(s, w) / s
    return [f * v[0], f * v[1], f * v[2], ln]


def rot_quat(half_sin: mpf, half_cos: mpf, axis: Sequence) -> Vec:
    """[sin(θ/2) u, cos(θ/2)] for a unit axis u."""
    return [half_sin * axis[0], half_sin * axis[1], half_sin * axis[2], half_cos]


def rot_matrix(q: Sequence) -> list[Vec]:
    """Rotation matrix of a quaternion of any nonzero norm (that of q/|q|), rows as lists."""
    x, y, z, w = q
    s = 2 / (x * x + y * y + z * z + w * w)
    return [
        [1 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y)],
        [s * (x * y + w * z), 1 - s * (x * x + z * z), s * (y * z - w * x)],
        [s * (x * z - w * y), s * (y * z + w * x), 1 - s * (x * x + y * y)],
    ]


# ---------------------------------------------------------------------------------------------------------------
# references of the public quaternion functions (float64 inputs -> candidate truths)
# ---------------------------------------------------------------------------------------------------------------


@_hp
def quat_exp(q: np.ndarray) -> list[Vec]:
    return [mp_qexp(exact(q))]


@_hp
def quat_log(q: np.ndarray) -> list[Vec]:
    return [mp_qlog(exact(q))]


@_hp
def quat_pow(q: np.ndarray, t: float) -> list[Vec]:
    """exp(t ln q), principal log (|q|**t is kept: quat_pow takes any norm)."""
    tt = mpf(float(t))
    return [mp_qexp([tt * x for x in mp_qlog(exact(q))])]


@_hp
def quat_from_rotvec(rotvec: np.ndarray) -> list[Vec]:
    v = exact(rotvec)
    th = norm(v)
    f = mp.sinc(th / 2) / 2
    return [[f * v[0], f * v[1], f * v[2], mp.cos(th / 2)]]


@_hp
def rotvec_from_quat(q: np.ndarray) -> list[Vec]:
    """2 ln q with angle in [0, π] (scale invariant, so the normalization is implicit)."""
    x = exact(q)
    if x[3] < 0:
        x = [-c for c in x]
    s = norm(x[:3])
    if s == 0:
        return [[mpf(0)] * 3]
    f = 2 * mp.atan2(s, x[3]) / s
    return [[f * c for c in x[:3]]]


@_hp
def matrix_from_quat(q: np.ndarray) -> list[Vec]:
    return [[e for row in rot_matrix(exact(q)) for e in row]]


@_hp
def nearest_rotation_quat(m: np.ndarray) -> Vec:
    """Unit quaternion (w >= 0) of the rotation nearest (Frobenius) to the matrix ``m``.

    Bar-Itzhack (2000): maximise ``tr(Mᵀ R(q)) = qᵀ B q`` over unit q; ``B`` (4x4 symmetric) is obtained by
    polarising the homogeneous quadratic ``R(q)`` exactly, and the answer is the eigenvector of its largest
    eigenvalue (``mpmath.eigsy``).
    """
    mm = exact(m)
    rows = [mm[0:3], mm[3:6], mm[6:9]]

    def f(q: Sequence) -> mpf:
        x, y, z, w = q
        r = [
            [w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z],
        ]
        return mp.fsum(rows[a][b] * r[a][b] for a in range(3) for b in range(3))

    e = [[mpf(int(i == j)) for j in range(4)] for i in range(4)]
    b = mp.matrix(4, 4)
    for i in range(4):
        b[i, i] = f(e[i])
    for i in range(4):
        for j in range(i + 1, 4):
            b[i, j] = b[j, i] = (f([p + r for p, r in zip(e[i], e[j], strict=True)]) - b[i, i] - b[j, j]) / 2
    vals, vecs = mp.eigsy(b)
    k = max(range(4), key=lambda i: vals[i])
    q = normalize([vecs[i, k] for i in range(4)])
    if q[3] < 0:
        q = [-c for c in q]
    return q


@_hp
def quat_from_matrix(m: np.ndarray) -> list[Vec]:
    """Quaternion of the nearest rotation; both signs are candidates (the w >= 0 rule is asserted separately,
    and decides nothing when w = 0, at 180°)."""
    q = nearest_rotation_quat(m)
    return [q, [-c for c in q]]


@_hp
def slerp_mp(p: Vec, q: Vec, t: mpf) -> list[Vec]:
    """p (x) (p* (x) q)**t on the shorter arc, for unit p, q.  Both arcs are candidates when p, q are within
    16 ε of being exactly π apart (the function jumps there)."""
    r = qmul(qconj(p), q)
    out = []
    signs = [1, -1] if abs(r[3]) <= 16 * EPS else [1 if r[3] >= 0 else -1]
    for sg in signs:
        rr = [sg * c for c in r]
        s = norm(rr[:3])
        if s == 0:
            out.append(list(p))
            continue
        phi = mp.atan2(s, rr[3])
        f = mp.sin(t * phi) / s
        out.append(qmul(p, [f * rr[0], f * rr[1], f * rr[2], mp.cos(t * phi)]))
    return out


@_hp
def quat_slerp(q0: np.ndarray, q1: np.ndarray, t: float) -> list[Vec]:
    return slerp_mp(normalize(exact(q0)), normalize(exact(q1)), mpf(float(t)))


@_hp
def quat_angle(p: np.ndarray, q: np.ndarray) -> list[Vec]:
    """Rotation angle in [0, π] between the orientations p/|p| and q/|q|: 2 atan2(|r_v|, |r_w|), r = p* (x) q."""
    r = qmul(qconj(exact(p)), exact(q))
    return [[2 * mp.atan2(norm(r[:3]), abs(r[3]))]]


# ---------------------------------------------------------------------------------------------------------------
# dual quaternions in mpmath: [real xyzw, dual xyzw], dual = ½ t (x) real
# ---------------------------------------------------------------------------------------------------------------


def mp_dsinc(x: mpf) -> mpf:
    """(x cos x − sin x)/x³, exact to DPS digits for every x (extra digits absorb the cancellation)."""
    if x == 0:
        return mpf(-1) / 3
    extra = int(4 * max(0, -mp.log10(abs(x)))) + 10
    with mp.workdps(mp.dps + extra):
        return +((x * mp.cos(x) - mp.sin(x)) / x**3)


def mp_dqalpha(phi: mpf) -> mpf:
    """cos φ / sin²φ − φ / sin³φ (Dantam 2014 eq. (91)), exact to DPS digits; −2/3 at 0."""
    if phi == 0:
        return mpf(-2) / 3
    extra = int(4 * max(0, -mp.log10(abs(phi)))) + 10
    with mp.workdps(mp.dps + extra):
        s = mp.sin(phi)
        return +(mp.cos(phi) / s**2 - phi / s**3)


def dq_mul(a: Sequence, b: Sequence) -> Vec:
    """(a_r b_r, a_r b_d + a_d b_r) (Dantam 2014 eq. (79))."""
    ar, ad, br, bd = a[:4], a[4:], b[:4], b[4:]
    d1, d2 = qmul(ar, bd), qmul(ad, br)
    return qmul(ar, br) + [x + y for x, y in zip(d1, d2, strict=True)]


def dq_conj(a: Sequence) -> Vec:
    return qconj(a[:4]) + qconj(a[4:])


def dq_from_qt(q: Sequence, t: Sequence) -> Vec:
    """(q, ½ t (x) q) (Dantam 2014 eqs. (76)-(77))."""
    return list(q) + [c / 2 for c in qmul([t[0], t[1], t[2], mpf(0)], q)]


def dq_translation(s: Sequence) -> Vec:
    """t = 2 d (x) r* / |r|² (Dantam 2014 eq. (78), for any nonzero |r|)."""
    r, d = s[:4], s[4:]
    n2 = dot(r, r)
    return [2 * c / n2 for c in qmul(d, qconj(r))[:3]]


def dq_normalize(s: Sequence) -> Vec:
    """S / ‖S‖ with the dual norm ‖S‖ = |r| + ε (r·d)/|r|: (r/|r|, d/|r| − r (r·d)/|r|³)."""
    r, d = s[:4], s[4:]
    n = norm(r)
    k = dot(r, d) / n**3
    return [c / n for c in r] + [dc / n - rc * k for dc, rc in zip(d, r, strict=True)]


def mp_dqexp(s: Sequence) -> Vec:
    """e**S by dual arithmetic (Dantam 2014 eqs. (82)-(85)), for any dual quaternion."""
    rv, rw, dv, dw = s[0:3], s[3], s[4:7], s[7]
    phi = norm(rv)
    k = dot(rv, dv)
    e = mp.exp(rw)
    sc = mp.sinc(phi)
    real = [e * sc * c for c in rv] + [e * mp.cos(phi)]
    g = mp_dsinc(phi) * k
    dual = [e * (sc * a + g * b) for a, b in zip(dv, rv, strict=True)] + [-e * sc * k]
    dual = [x + dw * y for x, y in zip(dual, real, strict=True)]  # e**(r_w + ε d_w) = e**r_w (1 + ε d_w)
    return real + dual


def mp_dqlog(s: Sequence) -> Vec:
    """ln S by dual arithmetic (Dantam 2014 eqs. (86)-(91)), for a real part off the negative real axis."""
    rv, rw, dv, dw = s[0:3], s[3], s[4:7], s[7]
    sv = norm(rv)
    n2 = dot(s[:4], s[:4])
    n = mp.sqrt(n2)
    if sv == 0 and rw < 0:
        raise NotImplementedError("the negative real axis is a documented special value, tested separately")
    phi = mp.atan2(sv, rw)
    f = phi / sv if sv != 0 else 1 / rw
    k = dot(rv, dv)
    alpha = mp_dqalpha(phi) / n
    real = [f * c for c in rv] + [mp.log(n)]
    g = (k * alpha - dw) / n2
    dual = [g * a + f * b for a, b in zip(rv, dv, strict=True)] + [(k + rw * dw) / n2]
    return real + dual


# ---------------------------------------------------------------------------------------------------------------
# references of the public dual-quaternion functions (documented behaviour, see dualpose.algebra.dualquat)
# ---------------------------------------------------------------------------------------------------------------


def _canonical(s: Vec) -> Vec:
    """Both parts negated when the real part is not canonical (w > 0; ties by the first nonzero of x, y, z)."""
    x, y, z, w = s[:4]
    flip = w < 0 or (w == 0 and (x < 0 or (x == 0 and (y < 0 or (y == 0 and z < 0)))))
    return [-c for c in s] if flip else list(s)


@_hp
def dualquat_exp(s: np.ndarray) -> list[Vec]:
    """General exponential (any dual quaternion; documented)."""
    return [mp_dqexp(exact(s))]


@_hp
def dualquat_log(s: np.ndarray) -> list[Vec]:
    """General principal logarithm of the exact input (documented for any nonzero real part: ln|r| is kept)."""
    return [mp_dqlog(exact(s))]


@_hp
def dualquat_pow(s: np.ndarray, t: float) -> list[Vec]:
    """exp(t ln S) of the exact input, no canonicalisation (documented)."""
    tt = mpf(float(t))
    return [mp_dqexp([tt * c for c in mp_dqlog(exact(s))])]


@_hp
def dualquat_from_twist(xi: np.ndarray) -> list[Vec]:
    """exp(½(ω + ε v)): the transform exp([[ω×, v], [0, 0]]) (cross-checked against mpmath.expm in the tests)."""
    x = exact(xi)
    return [mp_dqexp([x[0] / 2, x[1] / 2, x[2] / 2, mpf(0), x[3] / 2, x[4] / 2, x[5] / 2, mpf(0)])]


@_hp
def twist_from_dualquat(s: np.ndarray) -> list[Vec]:
    """2 ln of the normalized, canonical (r_w >= 0) input; its scalar parts are exactly 0 (documented)."""
    lg = mp_dqlog(_canonical(dq_normalize(exact(s))))
    return [[2 * c for c in lg[0:3] + lg[4:7]]]


@_hp
def dualquat_from_screw(axis: np.ndarray, point: np.ndarray, dist: float, angle: float) -> list[Vec]:
    """Walker 1991 eqs. (11)-(12) with the axis normalized (documented); only p's component ⊥ n enters (p × n)."""
    n = normalize(exact(axis))
    p = exact(point)
    d = mpf(float(dist))
    th = mpf(float(angle))
    sh, ch = mp.sin(th / 2), mp.cos(th / 2)
    m = cross(p, n)
    return [[sh * c for c in n] + [ch] + [d / 2 * ch * a + sh * b for a, b in zip(n, m, strict=True)] + [-d / 2 * sh]]


@_hp
def screw_from_dualquat(s: np.ndarray) -> list[Vec]:
    """(n, p, d, θ) of the normalized, canonical input, concatenated (8 values), from the translation t:
    θ = 2 atan2(|r_v|, r_w), n = r_v/|r_v|, d = t·n and p = ½(t_⊥ + cot(θ/2) n × t), the point of the axis
    nearest the origin (it solves (I − R) p = t_⊥, Walker Appendix eq. (61)).  A pure translation gives
    (t/|t|, 0, |t|, 0), the identity ([1, 0, 0], 0, 0, 0) (documented)."""
    u = _canonical(dq_normalize(exact(s)))
    t = dq_translation(u)
    rv = u[:3]
    sv = norm(rv)
    zero = [mpf(0)] * 3
    if sv == 0:
        tn = norm(t)
        if tn == 0:
            return [[mpf(1), mpf(0), mpf(0)] + zero + [mpf(0), mpf(0)]]
        return [[c / tn for c in t] + zero + [tn, mpf(0)]]
    n = [c / sv for c in rv]
    half = mp.atan2(sv, u[3])
    d = dot(t, n)
    tp = [a - d * b for a, b in zip(t, n, strict=True)]
    nt = cross(n, t)
    cot = u[3] / sv
    p = [(a + cot * b) / 2 for a, b in zip(tp, nt, strict=True)]
    return [n + p + [d, 2 * half]]


@_hp
def dualquat_sclerp(s0: np.ndarray, s1: np.ndarray, t: float) -> list[Vec]:
    """a (x) (canonical(a* (x) b))**t with a, b the normalized inputs; both screws are candidates when the
    relative rotation is within 16 ε of π (the canonical sign jumps there)."""
    a = dq_normalize(exact(s0))
    b = dq_normalize(exact(s1))
    c = dq_mul(dq_conj(a), b)
    tt = mpf(float(t))
    signs = [1, -1] if abs(c[3]) <= 16 * EPS else [1 if _canonical(c) == c else -1]
    out = []
    for sg in signs:
        cc = [sg * x for x in c]
        out.append(dq_mul(a, mp_dqexp([tt * x for x in mp_dqlog(cc)])))
    return out


REFERENCES = {
    "quat_exp": quat_exp,
    "quat_log": quat_log,
    "quat_pow": quat_pow,
    "quat_from_rotvec": quat_from_rotvec,
    "rotvec_from_quat": rotvec_from_quat,
    "quat_from_matrix": quat_from_matrix,
    "matrix_from_quat": matrix_from_quat,
    "quat_slerp": quat_slerp,
    "quat_angle": quat_angle,
    "dualquat_exp": dualquat_exp,
    "dualquat_log": dualquat_log,
    "dualquat_pow": dualquat_pow,
    "dualquat_from_twist": dualquat_from_twist,
    "twist_from_dualquat": twist_from_dualquat,
    "dualquat_from_screw": dualquat_from_screw,
    "screw_from_dualquat": screw_from_dualquat,
    "dualquat_sclerp": dualquat_sclerp,
}

__all__ = ["DPS", "EPS", "BAR", "REFERENCES", "exact", "to_f64", "normwise_error"]
