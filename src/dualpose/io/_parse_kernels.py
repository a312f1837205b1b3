"""numba kernel of the fast text-table reader (not public API; used by :func:`dualpose.io._text.read_float_table`).

One pass over the bytes of a block of whole lines, writing the numbers straight into the output rows.  A number is
converted in the kernel only when the result is certainly the correctly rounded double, the one Python's
``float()`` returns: a decimal mantissa ``m <= 2^53`` and a power of ten ``10^e`` with ``|e| <= 22`` are both
exact doubles, so ``m * 10^e`` or ``m / 10^-e`` is one correctly rounded IEEE operation (Clinger 1990, "How to
read floating point numbers accurately", the fast path); longer mantissas (up to 33 digits, as ``%.17g`` and
``%.18e`` write them) are formed in double-double arithmetic and rounded, unless the value is too close to a
rounding boundary to be sure.  Other numbers (that rare case, more digits, huge exponents) are copied as "slow"
tokens, space-separated, into a byte buffer that the caller converts with ``float()`` afterwards.
Anything unusual -- a character that is not part of a plain decimal number, a wrong number of fields, a
non-ASCII byte -- stops the kernel with status 1, and the caller falls back to the line-by-line reader, which
reports the exact ``file:line`` problem.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

njit = nb.njit(cache=True, nogil=True, error_model="numpy")

_POW10 = np.array([10.0**k for k in range(23)])
_TWO53 = 9007199254740992

OK, BAD, OUT_FULL, SLOW_FULL = 0, 1, 2, 3


@nb.njit(cache=True, inline="always")
def _is_space(c):  # noqa: ANN001, ANN202
    return c == 32 or c == 9 or c == 13 or c == 11 or c == 12


@nb.njit(cache=True, inline="always")
def _two_sum(a, b):  # noqa: ANN001, ANN202
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@nb.njit(cache=True, inline="always")
def _two_prod(a, b):  # noqa: ANN001, ANN202
    # Dekker's exact product a * b = p + e (Veltkamp splitting; no FMA needed)
    p = a * b
    c = 134217729.0 * a
    ah = c - (c - a)
    al = a - ah
    c = 134217729.0 * b
    bh = c - (c - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


@nb.njit(cache=True)
def _double_double(m, m2, n2, exp10):  # noqa: ANN001, ANN202
    """Correctly rounded ``(m 10^n2 + m2) 10^exp10`` (``m`` < 10^18, ``n2`` <= 15, ``|exp10|`` <= 22), or -1.

    The value is formed in double-double arithmetic (Dekker 1971; relative error below 2^-100) and rounded to
    the nearest double; when it lies within 2^-90 (relative) of a rounding boundary the rounding is not certain
    and -1 sends the token to ``float()``.  Such tokens are rare (about one in 10^11 of random 17-digit numbers).
    """
    pow10 = _POW10
    mh = float(m)
    ml = float(m - np.int64(mh))
    if n2 > 0:
        ph, pl = _two_prod(mh, pow10[n2])
        pl += ml * pow10[n2]
        s, e = _two_sum(ph, float(m2))
        mh, ml = _two_sum(s, e + pl)
    if exp10 >= 0:
        p, pe = _two_prod(mh, pow10[exp10])
        hi, lo = _two_sum(p, pe + ml * pow10[exp10])
    else:
        d = pow10[-exp10]
        q1 = mh / d
        p, pe = _two_prod(q1, d)
        q2 = (((mh - p) - pe) + ml) / d
        hi, lo = _two_sum(q1, q2)
    if not (2.0**-1000 < hi < 2.0**1000):
        return -1.0
    f, e2 = math.frexp(hi)
    half = math.ldexp(1.0, e2 - 54)  # half an ulp of hi
    if abs(half - abs(lo)) <= hi * 2.0**-90 or (f == 0.5 and lo < 0.0):
        return -1.0
    return hi


@njit
def parse_block(buf, pos, ncols, comma, out, row, slow, sbuf, nslow, spos):  # noqa: ANN001, ANN201
    """Parse the lines of ``buf[pos:]`` (which ends with a whole line) into ``out[row:]``.

    ``comma``: fields separated by ``,`` (spaces around it allowed) instead of runs of whitespace.  ``#`` starts a
    comment that runs to the end of the line; blank lines are skipped.  ``slow[k] = row * ncols + col`` records a
    token left to the caller, whose bytes are appended to ``sbuf[spos:]`` followed by a space.  Returns
    ``(status, pos, row, nslow, spos)``: on ``OUT_FULL`` / ``SLOW_FULL`` ``pos`` is the start of the line not yet
    stored (grow ``out`` / convert the slow tokens, then call again); on ``BAD`` the start of the offending line.
    """
    n = buf.shape[0]
    cap = out.shape[0]
    cap_slow = slow.shape[0]
    cap_sbuf = sbuf.shape[0]
    pow10 = _POW10
    while pos < n:
        i = pos
        while i < n and _is_space(buf[i]):
            i += 1
        if i >= n:
            break
        if buf[i] == 10:  # blank line
            pos = i + 1
            continue
        if buf[i] == 35:  # comment line
            while i < n and buf[i] != 10:
                if buf[i] >= 128:
                    return BAD, pos, row, nslow, spos
                i += 1
            pos = i + 1
            continue
        if row >= cap:
            return OUT_FULL, pos, row, nslow, spos
        if nslow + ncols > cap_slow:
            return SLOW_FULL, pos, row, nslow, spos
        nslow_line, spos_line = nslow, spos
        col = 0
        while True:
            if col == ncols:
                return BAD, pos, row, nslow_line, spos_line
            # one number: [+-] digits [. digits] [eE [+-] digits]
            start = i
            neg = False
            if i < n and (buf[i] == 45 or buf[i] == 43):
                neg = buf[i] == 45
                i += 1
            m = 0  # the first 18 digits (leading zeros included), exact in int64
            m2 = 0  # the next up to 18 digits
            nd = 0  # digits seen
            exp10 = 0
            # digits: value = (m * 10^(nd - 18) + m2) * 10^exp10 once nd > 18
            while i < n and 48 <= buf[i] <= 57:
                if nd < 18:
                    m = m * 10 + (buf[i] - 48)
                else:
                    m2 = m2 * 10 + (buf[i] - 48)
                nd += 1
                i += 1
            if i < n and buf[i] == 46:
                i += 1
                while i < n and 48 <= buf[i] <= 57:
                    if nd < 18:
                        m = m * 10 + (buf[i] - 48)
                    else:
                        m2 = m2 * 10 + (buf[i] - 48)
                    nd += 1
                    exp10 -= 1
                    i += 1
            if nd == 0:
                return BAD, pos, row, nslow_line, spos_line
            if i < n and (buf[i] == 101 or buf[i] == 69):
                i += 1
                eneg = False
                if i < n and (buf[i] == 45 or buf[i] == 43):
                    eneg = buf[i] == 45
                    i += 1
                ne = 0
                ev = 0
                while i < n and 48 <= buf[i] <= 57:
                    if ev < 100000:
                        ev = ev * 10 + (buf[i] - 48)
                    ne += 1
                    i += 1
                if ne == 0:
                    return BAD, pos, row, nslow_line, spos_line
                exp10 += -ev if eneg else ev
            # the token must end here
            if i < n:
                c = buf[i]
                if not (_is_space(c) or c == 10 or c == 35 or (comma and c == 44)):
                    return BAD, pos, row, nslow_line, spos_line
            v = -1.0
            if nd <= 18 and m <= _TWO53 and -22 <= exp10 <= 22:
                v = float(m)
                v = v * pow10[exp10] if exp10 >= 0 else v / pow10[-exp10]
            elif nd <= 33 and -22 <= exp10 <= 22 and m > 0:
                v = _double_double(m, m2, max(nd - 18, 0), exp10)
            elif m == 0 and m2 == 0 and nd <= 36:
                v = 0.0
            if v >= 0.0:
                out[row, col] = -v if neg else v
            else:
                if spos + (i - start) + 1 > cap_sbuf:
                    if nslow_line == 0:  # a line longer than the buffer: let the line reader have it
                        return BAD, pos, row, nslow_line, spos_line
                    return SLOW_FULL, pos, row, nslow_line, spos_line
                slow[nslow] = row * ncols + col
                nslow += 1
                for k in range(start, i):
                    sbuf[spos] = buf[k]
                    spos += 1
                sbuf[spos] = 32
                spos += 1
            col += 1
            while i < n and _is_space(buf[i]):
                i += 1
            if i >= n or buf[i] == 10:
                break
            if buf[i] == 35:  # trailing comment
                while i < n and buf[i] != 10:
                    if buf[i] >= 128:
                        return BAD, pos, row, nslow_line, spos_line
                    i += 1
                break
            if comma:
                if buf[i] != 44:
                    return BAD, pos, row, nslow_line, spos_line
                i += 1
                while i < n and _is_space(buf[i]):
                    i += 1
                if i >= n or buf[i] == 10 or buf[i] == 35:  # trailing comma
                    return BAD, pos, row, nslow_line, spos_line
        if col != ncols:
            return BAD, pos, row, nslow_line, spos_line
        row += 1
        pos = i + 1
    return OK, n, row, nslow, spos
