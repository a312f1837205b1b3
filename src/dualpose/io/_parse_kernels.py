"""numba kernel of the fast text-table reader (not public API; used by :func:`dualpose.io._text.read_float_table`).

One pass over the bytes of a block of whole lines, writing the numbers straight into the output rows.  A number is
converted in the kernel only when the conversion is exact: a decimal mantissa ``m <= 2^53`` and a power of ten
``10^e`` with ``|e| <= 22`` are both exact doubles, so ``m * 10^e`` or ``m / 10^-e`` is one correctly rounded
IEEE operation (Clinger 1990, "How to read floating point numbers accurately", the fast path) -- the same double
Python's ``float()`` returns.  Other numbers (17 significant digits and more, huge exponents) are copied as
"slow" tokens, space-separated, into a byte buffer that the caller converts with ``float()`` afterwards.
Anything unusual -- a character that is not part of a plain decimal number, a wrong number of fields, a
non-ASCII byte -- stops the kernel with status 1, and the caller falls back to the line-by-line reader, which
reports the exact ``file:line`` problem.
"""

from __future__ import annotations

import numba as nb
import numpy as np

njit = nb.njit(cache=True, nogil=True, error_model="numpy")

_POW10 = np.array([10.0**k for k in range(23)])
_TWO53 = 9007199254740992

OK, BAD, OUT_FULL, SLOW_FULL = 0, 1, 2, 3


@nb.njit(cache=True, inline="always")
def _is_space(c):  # noqa: ANN001, ANN202
    return c == 32 or c == 9 or c == 13 or c == 11 or c == 12


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
        # end of this line and of its content (before a '#')
        lend = pos
        cend = -1
        while lend < n and buf[lend] != 10:
            c = buf[lend]
            if c >= 128:
                return BAD, pos, row, nslow, spos
            if c == 35 and cend < 0:
                cend = lend
            lend += 1
        if cend < 0:
            cend = lend
        i = pos
        while i < cend and _is_space(buf[i]):
            i += 1
        if i == cend:  # blank or comment line
            pos = lend + 1
            continue
        if row >= cap:
            return OUT_FULL, pos, row, nslow, spos
        if nslow + ncols > cap_slow:
            return SLOW_FULL, pos, row, nslow, spos
        nslow_line, spos_line = nslow, spos
        col = 0
        while True:
            if col == ncols:
                return BAD, pos, row, nslow, spos
            # one number: [+-] digits [. digits] [eE [+-] digits]
            start = i
            neg = False
            if i < cend and (buf[i] == 45 or buf[i] == 43):
                neg = buf[i] == 45
                i += 1
            m = 0
            ndig = 0  # significant digits kept in m
            nd = 0  # digits seen
            exp10 = 0
            overflow = False
            while i < cend and 48 <= buf[i] <= 57:
                d = buf[i] - 48
                if ndig < 18:
                    if m > 0 or d > 0:
                        m = m * 10 + d
                        ndig += 1
                else:
                    overflow = True
                    exp10 += 1
                nd += 1
                i += 1
            if i < cend and buf[i] == 46:
                i += 1
                while i < cend and 48 <= buf[i] <= 57:
                    d = buf[i] - 48
                    if ndig < 18:
                        if m > 0 or d > 0:
                            m = m * 10 + d
                            ndig += 1
                        exp10 -= 1
                    else:
                        overflow = True
                    nd += 1
                    i += 1
            if nd == 0:
                return BAD, pos, row, nslow, spos
            if i < cend and (buf[i] == 101 or buf[i] == 69):
                i += 1
                eneg = False
                if i < cend and (buf[i] == 45 or buf[i] == 43):
                    eneg = buf[i] == 45
                    i += 1
                ne = 0
                ev = 0
                while i < cend and 48 <= buf[i] <= 57:
                    if ev < 100000:
                        ev = ev * 10 + (buf[i] - 48)
                    ne += 1
                    i += 1
                if ne == 0:
                    return BAD, pos, row, nslow, spos
                exp10 += -ev if eneg else ev
            # the token must end here
            if i < cend and not (_is_space(buf[i]) or (comma and buf[i] == 44)):
                return BAD, pos, row, nslow, spos
            if m == 0 and not overflow:
                v = 0.0
                out[row, col] = -v if neg else v
            elif not overflow and m <= _TWO53 and -22 <= exp10 <= 22:
                v = float(m)
                v = v * pow10[exp10] if exp10 >= 0 else v / pow10[-exp10]
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
            while i < cend and _is_space(buf[i]):
                i += 1
            if i == cend:
                break
            if comma:
                if buf[i] != 44:
                    return BAD, pos, row, nslow, spos
                i += 1
                while i < cend and _is_space(buf[i]):
                    i += 1
                if i == cend:  # trailing comma
                    return BAD, pos, row, nslow, spos
        if col != ncols:
            return BAD, pos, row, nslow, spos
        row += 1
        pos = lend + 1
    return OK, n, row, nslow, spos
