"""Calibration-target corner files (AprilGrid / checkerboard detections, one file per camera).

Layout (comma-separated, ``#`` comment or header lines, blank lines skipped)::

    timestamp [ns], u [px], v [px], X [m], Y [m], Z [m], tag_id, corner_idx

one row per detected corner: the measured (distorted) pixel and the corner's position in the target frame.  A
frame without detections is one row holding only its timestamp (the other fields absent or all empty,
``t,,,,,,,``).  The rows of one frame are contiguous and the
frames strictly increasing in time.  Timestamps are kept exactly as int64 nanoseconds.
"""

from __future__ import annotations

import os

import numpy as np
from numpy.typing import NDArray

from dualpose import _native
from dualpose.io._text import check_path, open_input, parse_number
from dualpose.io.recording import RecordingError
from dualpose.types.target import TargetDetections
from dualpose.types.trajectory import seconds_from_ns

__all__ = ["read_target_detections", "TARGET_LAYOUT"]

TARGET_LAYOUT = "timestamp [ns], u [px], v [px], X [m], Y [m], Z [m], tag_id, corner_idx"


def _parse_numbers(path: str, rest: list[str], linenos: list[int]) -> NDArray[np.float64]:
    """The 7 numbers after the timestamp of each corner row (float64 (M, 7)); errors name the file and line."""
    out = np.empty((len(rest), 7))
    if rest:
        buf = np.frombuffer(("\n".join(rest) + "\n").encode("ascii", "replace"), dtype=np.uint8)
        status, _, row = _native.io_parse_block(buf, 0, 7, True, out, 0)
        if status == 0 and row == len(rest):
            if np.isfinite(out).all():
                return out
    for k, s in enumerate(rest):  # slow path: find the first bad row
        fields = [f.strip() for f in s.split(",")]
        if len(fields) != 7:
            raise RecordingError(
                f"{path}:{linenos[k]}: expected 8 fields ({TARGET_LAYOUT}) or only the timestamp, "
                f"found {len(fields) + 1}"
            )
        try:
            values = [parse_number(f) for f in fields]
        except ValueError:
            raise RecordingError(f"{path}:{linenos[k]}: not a number in {s!r} ({TARGET_LAYOUT})") from None
        if not all(np.isfinite(values)):
            raise RecordingError(f"{path}:{linenos[k]}: non-finite value in {s!r}")
        out[k] = values
    return out


#: byte classes of the fast path: 0 other printable ASCII, 1 newline, 2 comma, 3 blank or '#', 4 carriage return,
#: 5 anything else (non-ASCII, other control bytes)
_BYTE_CLASS = np.full(256, 5, dtype=np.uint8)
_BYTE_CLASS[32:127] = 0
_BYTE_CLASS[[10, 44, 32, 9, 35, 13]] = [1, 2, 3, 3, 3, 4]


#: the data rows: stamps ns (R,), whether the row has a corner (R,), the corners' numbers (M, 7), line numbers (R,)
_Rows = tuple[NDArray[np.int64], NDArray[np.bool_], NDArray[np.float64], NDArray[np.int64]]


def _rows_fast(raw: bytes) -> _Rows | None:
    """``(stamps_ns (R,), has_corner (R,), numbers (M, 7), linenos (R,))`` of the data rows, parsed on whole arrays
    (the numbers by the native table kernel of ``io._text``), or None for anything but the plain layout (ASCII,
    ``\\n`` or CRLF line ends, ``#`` only in whole-line comments, no blanks in data rows, unsigned timestamps below
    9e18, 0 or 7 commas per data row); the line-by-line reader takes those."""
    buf = np.frombuffer(raw, dtype=np.uint8)
    if raw.startswith(b"\xef\xbb\xbf"):
        buf = buf[3:]
    if buf.size == 0:
        return None
    cls = _BYTE_CLASS[buf]
    if cls.max() >= 4:
        cr = cls == 4
        if cr[-1] or not (buf[1:][cr[:-1]] == 10).all() or (cls == 5).any():
            return None
        buf, cls = buf[~cr], cls[~cr]
    if buf[-1] != 10:
        buf = np.concatenate([buf, np.array([10], dtype=np.uint8)])
        cls = np.concatenate([cls, np.array([1], dtype=np.uint8)])
    ends = np.flatnonzero(cls == 1)
    starts = np.concatenate([[0], ends[:-1] + 1])
    nonempty = ends > starts
    comment = np.zeros(len(starts), dtype=bool)
    comment[nonempty] = buf[starts[nonempty]] == 35
    data = nonempty & ~comment
    if not data.any():
        return None
    special = np.flatnonzero(cls == 3)
    if not comment[np.searchsorted(ends, special)].all():
        return None
    commas = np.flatnonzero(cls == 2)
    before = np.searchsorted(commas, ends)  # commas before each line's end
    ncomma = np.diff(before, prepend=0)[data]
    if not ((ncomma == 0) | (ncomma == 7)).all():
        return None
    first_of_line = np.concatenate([[0], before[:-1]])[data]
    starts, ends = starts[data], ends[data]
    first_comma = np.where(ncomma > 0, commas[np.minimum(first_of_line, len(commas) - 1)], ends)
    width = first_comma - starts
    if width.min() < 1 or width.max() > 19 or (buf[starts[width == 19]] > ord("8")).any():  # int64 holds 19 digits
        return None
    ns = np.zeros(len(starts), dtype=np.int64)
    for c in range(int(width.max())):
        inside = c < width
        digit = buf[np.where(inside, starts + c, 0)].astype(np.int64) - 48
        if ((digit < 0) | (digit > 9))[inside].any():
            return None
        ns = np.where(inside, ns * 10 + digit, ns)
    has_corner = (ncomma == 7) & (ends - first_comma > 7)
    # the whole rows go to the table kernel with 8 columns; timestamp-only rows become comments for it
    table = buf.copy()
    table[starts[~has_corner]] = 35
    numbers = np.empty((int(has_corner.sum()), 8))
    if len(numbers):
        status, _, row = _native.io_parse_block(table, 0, 8, True, numbers, 0)
        if status != 0 or row != len(numbers) or not np.isfinite(numbers).all():
            return None
    return ns, has_corner, numbers[:, 1:], np.flatnonzero(data) + 1


def _rows_lines(p: str, raw: bytes) -> _Rows:
    """What :func:`_rows_fast` returns, line by line, with ``path:line`` errors for anything malformed."""
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise RecordingError(f"{p}: not a UTF-8 text file ({exc})") from None
    stamps: list[str] = []
    linenos: list[int] = []
    rest: list[str] = []
    rest_rows: list[int] = []
    for i, line in enumerate(text.splitlines(), start=1):
        s = line.split("#", 1)[0].strip() if "#" in line else line.strip()
        if not s:
            continue
        head, _, tail = s.partition(",")
        if tail.replace(",", "").strip():  # "t" or "t,,,,,,," (all fields empty) is a frame without detections
            rest_rows.append(len(stamps))
            rest.append(tail)
        stamps.append(head.strip())
        linenos.append(i)
    if not stamps:
        raise RecordingError(f"{p}: no data rows (expected {TARGET_LAYOUT})")
    try:
        ns = np.array(stamps).astype(np.int64)
    except (ValueError, OverflowError):
        for k, v in enumerate(stamps):
            try:
                if not -(2**63) <= int(v) < 2**63:
                    raise ValueError
            except ValueError:
                raise RecordingError(f"{p}:{linenos[k]}: timestamp [ns] {v!r} is not an int64 integer") from None
        raise  # pragma: no cover
    numbers = _parse_numbers(p, rest, [linenos[k] for k in rest_rows])
    has_corner = np.zeros(len(ns), dtype=bool)
    has_corner[rest_rows] = True
    return ns, has_corner, numbers, np.array(linenos)


def read_target_detections(path: str | os.PathLike[str]) -> TargetDetections:
    """Read a target-corner file (layout in the module docstring) into a
    :class:`~dualpose.types.target.TargetDetections` (180 000 rows in about 0.1 s: the plain layout is parsed on
    whole arrays, anything else line by line).

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    RecordingError
        ``path:line: ...`` for a row with neither 8 fields nor only a timestamp, a non-integer timestamp, a
        non-number, a non-integer tag or corner index, a timestamp earlier than the row before (frames out of order
        or not contiguous), a timestamp-only row inside a frame with corners, a corner (tag_id, corner_idx) twice in
        one frame, or a file without rows.
    """
    p = check_path(path)
    with open_input(p) as f:
        raw = f.read()
    rows = _rows_fast(raw)
    ns, has_corner, numbers, linenos = rows if rows is not None else _rows_lines(p, raw)
    rest_rows = np.flatnonzero(has_corner)
    back = np.flatnonzero(np.diff(ns) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise RecordingError(
            f"{p}:{linenos[k]}: timestamp {ns[k]} is earlier than the row before ({ns[k - 1]}); frames must be in "
            "time order with the rows of a frame contiguous"
        )
    first = np.concatenate([[True], ns[1:] != ns[:-1]])  # the first row of each frame
    frame_of_row = np.cumsum(first) - 1
    n_frames = int(frame_of_row[-1]) + 1
    corners_per_frame = np.bincount(frame_of_row, weights=has_corner, minlength=n_frames).astype(np.int64)
    rows_per_frame = np.bincount(frame_of_row, minlength=n_frames)
    mixed = (~has_corner) & (corners_per_frame[frame_of_row] > 0)
    if mixed.any():
        k = int(np.argmax(mixed))
        raise RecordingError(f"{p}:{linenos[k]}: a timestamp-only row (no detection) in a frame that has corners")
    dup = (corners_per_frame == 0) & (rows_per_frame > 1)
    if dup.any():
        k = int(np.argmax(first & dup[frame_of_row])) + 1
        raise RecordingError(f"{p}:{linenos[k]}: repeated timestamp-only row for one frame")
    ids = numbers[:, 5:7]
    bad = (ids != np.round(ids)).any(axis=1) | (np.abs(ids) > 2**53).any(axis=1)
    if bad.any():
        k = rest_rows[int(np.argmax(bad))]
        raise RecordingError(f"{p}:{linenos[k]}: tag_id and corner_idx must be whole numbers")
    frame_c, tag_c, corner_c = frame_of_row[rest_rows], ids[:, 0], ids[:, 1]
    order = np.lexsort((corner_c, tag_c, frame_c))  # stable: of two equal rows the later one comes second
    same = np.flatnonzero((np.diff(frame_c[order]) == 0) & (np.diff(tag_c[order]) == 0)
                          & (np.diff(corner_c[order]) == 0))  # fmt: skip
    if same.size:
        j = int(order[same[0] + 1])
        raise RecordingError(f"{p}:{linenos[rest_rows[j]]}: tag {int(tag_c[j])} corner {int(corner_c[j])} appears "
                             f"twice in the frame at {ns[rest_rows[j]]} ns")  # fmt: skip
    stamps_ns = ns[first]
    offsets = np.concatenate([[0], np.cumsum(corners_per_frame)]).astype(np.int64)
    return TargetDetections(
        stamps_ns=stamps_ns,
        t=seconds_from_ns(stamps_ns),
        offsets=offsets,
        pixels=np.ascontiguousarray(numbers[:, 0:2]),
        points=np.ascontiguousarray(numbers[:, 2:5]),
        tag_id=ids[:, 0].astype(np.int64),
        corner_id=ids[:, 1].astype(np.int64),
        path=p,
    )
