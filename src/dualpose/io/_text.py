"""Parsing shared by the text readers, with ``file:line`` in every error, and safe output opening.

Two readers of delimited numeric tables: :func:`read_float_table` is the fast path for big files (the bytes are
read in blocks and parsed by the native kernel ``_native.io_parse_block``, ``src/native/io/text_table.cpp``, into
one preallocated array; no Python object per number), and :func:`read_table` + :func:`parse_float_columns` the
line-by-line reader that names the file and line of any problem.  The fast path hands anything it does not fully
understand to the line reader, so both accept the same files and give the same numbers and the same errors.

One number grammar for every text format (:func:`parse_number`, :data:`NUMBER`): ``[+-] digits [. digits]
[(e|E) [+-] digits]`` in ASCII, at least one digit before the exponent (``1``, ``-2.5``, ``.5``, ``5.``, ``1e-3``),
the grammar of the native kernel.  ``nan``, ``inf`` and ``infinity`` are recognised only to be reported as
non-finite; everything else Python's ``float()`` also takes (``1_000``, ``0x1p3`` via ``float.fromhex``, Unicode
digits, surrounding blanks inside a field) is not a number.

Inputs are opened through :func:`open_input`: a directory, a device (``/dev/zero``) or a socket is refused with its
kind named; a pipe (``/dev/stdin``, ``<(...)``, or ``-`` for standard input) is read once, up to
:data:`MAX_PIPE_BYTES`, and kept, so a reader that opens its input twice sees the same bytes and seeking works.
Streams read standard input through :func:`bounded_lines`: one line at a time, at most :data:`MAX_LINE_BYTES`
each, UTF-8 with an optional BOM like files.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import stat
import sys
from collections.abc import Iterator
from typing import IO

import numpy as np
from numpy.typing import NDArray

from dualpose import _native
from dualpose.io._output import atomic_text_file

__all__ = [
    "Table",
    "read_table",
    "split_fields",
    "read_float_table",
    "read_pose_rows",
    "parse_float_columns",
    "parse_int_column",
    "open_for_writing",
    "check_path",
    "NUMBER",
    "parse_number",
    "all_numbers",
    "open_input",
    "bounded_lines",
    "MAX_LINE_BYTES",
    "MAX_PIPE_BYTES",
]

#: one number of a text file (module docstring); ASCII only
NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_NONFINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)
#: the longest line a stream accepts, bytes
MAX_LINE_BYTES = 1 << 20
#: the most a pipe given as an input file may hold, bytes
MAX_PIPE_BYTES = 1 << 31

_BLOCK = 1 << 24  # bytes read and parsed at a time


def check_path(path: object, name: str = "path") -> str:
    """``path`` as a str; a ``TypeError`` naming ``name`` for anything that is not a str or ``os.PathLike[str]``."""
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"{name} must be a str or os.PathLike file path; got {type(path).__name__}")
    return os.fspath(path)


def parse_number(text: str) -> float:
    """The float of one field in the number grammar (module docstring); ``nan`` / ``inf`` words give NaN / inf
    (the caller reports them as non-finite).  ``ValueError("'x' is not a number")`` for anything else."""
    if NUMBER.fullmatch(text) or _NONFINITE.fullmatch(text):
        return float(text)
    raise ValueError(f"{text!r} is not a number")


_TOKEN = rf"(?:{NUMBER.pattern}|{_NONFINITE.pattern})"
_MANY = re.compile(rf"(?:{_TOKEN}\n)*{_TOKEN}", re.IGNORECASE)


def all_numbers(cells: list[str]) -> bool:
    """Whether every string of ``cells`` (none holds a line end) is in the number grammar or a non-finite word: one
    regex pass over them all."""
    return not cells or _MANY.fullmatch("\n".join(cells)) is not None


#: where the bytes of each pipe read as an input went, by (device, inode): a pipe can be read only once
_PIPES: dict[tuple[int, int] | str, bytes] = {}


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _read_pipe(f: IO[bytes] | io.BufferedReader, name: str) -> bytes:
    data = f.read(MAX_PIPE_BYTES + 1)
    if len(data) > MAX_PIPE_BYTES:
        raise ValueError(f"{name}: a pipe holding more than {MAX_PIPE_BYTES} bytes; give a regular file")
    return data


def open_input(path: str | os.PathLike[str], what: str = "a file") -> io.BufferedReader | io.BytesIO:
    """``path`` opened for reading bytes, refusing anything that is not a file of data.

    A regular file is opened as it is.  A pipe (``-`` is standard input; ``/dev/stdin``, ``<(...)``) is read once,
    up to :data:`MAX_PIPE_BYTES`, and its bytes are returned (again at every later call: a pipe can be read only
    once) as a seekable in-memory file.  A directory, a device (``/dev/zero``, a terminal) or a socket is a
    ``ValueError`` naming the path and its kind (``what`` says what was expected), before anything is read.
    """
    p = check_path(path)
    if p == "-":
        if "-" not in _PIPES:
            stdin = sys.stdin.buffer if sys.stdin is not None and hasattr(sys.stdin, "buffer") else io.BytesIO()
            _PIPES["-"] = _read_pipe(stdin, "standard input")
        return io.BytesIO(_PIPES["-"])
    try:
        mode = os.stat(p).st_mode
    except FileNotFoundError:
        raise FileNotFoundError(f"{p}: no such file") from None
    if stat.S_ISFIFO(mode):
        st = os.stat(p)
        key = (st.st_dev, st.st_ino)
        if key not in _PIPES:
            with open(p, "rb") as f:
                _PIPES[key] = _read_pipe(f, p)
        return io.BytesIO(_PIPES[key])
    if not stat.S_ISREG(mode):
        raise ValueError(f"{p}: {_kind(mode)}, not {what}")
    f = open(p, "rb")
    mode = os.fstat(f.fileno()).st_mode  # the file opened is the file checked
    if not stat.S_ISREG(mode):  # pragma: no cover - replaced between the two calls
        f.close()
        raise ValueError(f"{p}: {_kind(mode)}, not {what}")
    return f


def input_size(f: io.BufferedReader | io.BytesIO) -> int:
    """The number of bytes of an input opened by :func:`open_input`."""
    if isinstance(f, io.BytesIO):
        return len(f.getbuffer())
    return os.fstat(f.fileno()).st_size


def bounded_lines(stream: IO[str] | IO[bytes] | None = None, source: str = "stdin") -> Iterator[str]:
    """The lines of a stream (default standard input), read one at a time as they come, each at most
    :data:`MAX_LINE_BYTES` long, decoded as UTF-8 (a BOM at the start is dropped, as for files).

    Raises
    ------
    ValueError
        ``"{source} line N: ..."`` for a line that is too long or not UTF-8 text.
    """
    if stream is None:
        stream = sys.stdin
    raw = getattr(stream, "buffer", stream)
    lineno = 0
    while True:
        line = raw.readline(MAX_LINE_BYTES + 1)
        if not line:
            return
        lineno += 1
        if len(line) > MAX_LINE_BYTES:
            raise ValueError(f"{source} line {lineno}: longer than {MAX_LINE_BYTES} bytes (no line end)")
        if isinstance(line, bytes):
            if lineno == 1 and line.startswith(b"\xef\xbb\xbf"):
                line = line[3:]
            try:
                text = line.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise ValueError(f"{source} line {lineno}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
        else:
            text = line[1:] if lineno == 1 and line.startswith("\ufeff") else line
        yield text


class Table:
    """Data rows of a delimited text file: ``rows[k]`` is the list of fields of source line ``linenos[k]``.

    ``comments`` holds the comment lines (without the leading ``#``) in file order.
    """

    __slots__ = ("path", "rows", "linenos", "comments")

    def __init__(self, path: str, rows: list[list[str]], linenos: list[int], comments: list[str]) -> None:
        self.path, self.rows, self.linenos, self.comments = path, rows, linenos, comments

    def error(self, k: int, message: str) -> ValueError:
        return ValueError(f"{self.path}:{self.linenos[k]}: {message}")


def split_fields(line: str, delimiter: str | None) -> list[str] | None:
    """The fields of one line of a text table, or None for a blank or comment line.

    ``#`` starts a comment (a whole line, or the rest of a data line).  ``delimiter``: ``None`` splits on runs of
    whitespace, ``"auto"`` on commas when the line (without its comment) has one and on whitespace otherwise, any
    other string on that string (each field stripped of surrounding whitespace).
    """
    s = line.strip()
    if "#" in s:
        s = s[: s.index("#")].rstrip()
    if not s:
        return None
    if delimiter == "auto":
        delimiter = "," if "," in s else None
    return s.split(delimiter) if delimiter is None else [x.strip() for x in s.split(delimiter)]


def read_table(path: str | os.PathLike[str], delimiter: str | None, ncols: tuple[int, int], what: str) -> Table:
    """Read a text table: ``#`` starts a comment (a whole line, or the rest of a data line); blank lines are skipped.

    Parameters
    ----------
    path : path-like
    delimiter : str or None
        Field separator; ``None`` splits on runs of whitespace.
    ncols : (int, int)
        Allowed number of fields per row, inclusive.
    what : str
        The expected layout, quoted in error messages (e.g. ``"t tx ty tz qx qy qz qw"``).

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    ValueError
        ``path:line: ...`` for a row with the wrong number of fields, or a file without data rows.
    """
    p = check_path(path)
    rows: list[list[str]] = []
    linenos: list[int] = []
    comments: list[str] = []
    with open_input(p) as raw, io.TextIOWrapper(raw, encoding="utf-8-sig", newline=None) as f:
        try:
            lines = f.read().splitlines()
        except UnicodeDecodeError as exc:
            raise ValueError(f"{p}: not a UTF-8 text file ({exc})") from None
    lo, hi = ncols
    for i, line in enumerate(lines, start=1):
        s = line.strip()
        if s.startswith("#"):
            comments.append(s[1:].strip())
            continue
        fields = split_fields(s, delimiter)
        if fields is None:
            continue
        if not lo <= len(fields) <= hi:
            want = str(lo) if lo == hi else f"{lo} to {hi}"
            raise ValueError(f"{p}:{i}: expected {want} fields ({what}), found {len(fields)}: {s[:80]!r}")
        rows.append(fields)
        linenos.append(i)
    if not rows:
        raise ValueError(f"{p}: no data rows (expected {what})")
    return Table(p, rows, linenos, comments)


def _last_newline(buf: np.ndarray, start: int, stop: int) -> int:
    """Index of the last ``\\n`` in ``buf[start:stop]``, or -1."""
    hi = stop
    while hi > start:
        lo = max(start, hi - (1 << 16))
        hits = np.flatnonzero(buf[lo:hi] == 10)
        if hits.size:
            return lo + int(hits[-1])
        hi = lo
    return -1


def _float_table_fast(path: str, ncols: int, comma: bool) -> NDArray[np.float64] | None:
    """The numbers of a text table with exactly ``ncols`` fields per data line, or None when the kernel declines."""
    with open_input(path) as f:
        size = input_size(f)
        out = np.empty((max(min(size, _BLOCK) // (2 * ncols), 16), ncols))
        buf = np.empty(min(size, _BLOCK) + 1, dtype=np.uint8)  # the bytes being parsed, reused block after block
        have, row, first = 0, 0, True
        while True:
            if have == buf.shape[0]:  # one line longer than the block
                if have > MAX_LINE_BYTES:
                    start_of_line = f.tell() - have
                    f.seek(0)
                    lineno = f.read(start_of_line).count(b"\n") + 1
                    raise ValueError(f"{path}:{lineno}: line longer than {MAX_LINE_BYTES} bytes")
                buf = np.concatenate([buf, np.empty_like(buf)])
            got = f.readinto(buf.data[have:])
            eof = not got
            have += got or 0
            start = 0
            if first:
                first = False
                if have >= 3 and bytes(buf[:3]) == b"\xef\xbb\xbf":
                    start = 3
            if eof:
                stop = have
            else:
                stop = _last_newline(buf, start, have) + 1
                if stop == 0:
                    continue
            view = buf[start:stop]
            pos = 0
            while True:
                status, pos, row = _native.io_parse_block(view, pos, ncols, comma, out, row)
                if status == 1:
                    return None
                if status == 2:  # grow: estimate the rows of the whole file from the bytes per row so far
                    done = f.tell() - have + start + pos
                    estimate = int(row * size / max(done, 1) * 1.05) + 1024
                    bigger = np.empty((max(estimate, row + row // 4 + 16), ncols))
                    bigger[:row] = out[:row]
                    out = bigger
                elif status == 0:
                    break
            if eof:
                break
            rest = have - stop
            buf[:rest] = buf[stop:have]
            have = rest
    if row == 0:
        return None
    data = out[:row]
    return data if out.shape[0] <= row + row // 2 + 1024 else data.copy()


def read_float_table(path: str | os.PathLike[str], ncols: int, delimiter: str | None, what: str) -> NDArray[np.float64]:
    """All fields of a numeric text table with exactly ``ncols`` fields per data line, as finite float64 (N, ncols).

    ``delimiter`` is ``None`` (runs of whitespace) or ``","``.  Comments (``#`` to the end of a line), blank
    lines, a UTF-8 BOM and CRLF line ends are accepted as by :func:`read_table`.  Big files take the fast path
    (see the module docstring; ~1 pass over the bytes, peak memory the output plus a 16 MiB block); whatever it
    does not accept is read again by :func:`read_table` / :func:`parse_float_columns`, whose errors name the file
    and line.  The numbers are in the grammar of the module docstring (those ``float()`` gives for them).
    """
    p = check_path(path)
    if delimiter not in (None, ","):
        raise ValueError(f"delimiter must be None or ','; got {delimiter!r}")
    data = _float_table_fast(p, ncols, delimiter == ",")
    if data is not None:
        return data
    table = read_table(p, delimiter, (ncols, ncols), what)
    return parse_float_columns(table, slice(0, ncols), what)


def first_line_delimiter(path: str) -> str | None:
    """``","`` when the first data line of ``path`` has a comma before any comment, else None (whitespace)."""
    with open_input(path) as f:
        for raw in iter(lambda: f.readline(MAX_LINE_BYTES), b""):
            line = raw.split(b"#", 1)[0].strip()
            if line:
                return "," if b"," in line else None
    return None


def read_pose_rows(path: str | os.PathLike[str], what: str) -> NDArray[np.float64]:
    """The rows ``t x y z qx qy qz qw`` of a pose file (separator of its first data line), float64 (N, 8), in file
    order; ``path:line: ...`` errors as :func:`read_float_table`'s, and for a zero quaternion."""
    p = check_path(path)
    delimiter = first_line_delimiter(p)
    data = read_float_table(p, 8, delimiter, what)
    q = data[:, 4:8]
    if not np.einsum("ij,ij->i", q, q).all() and (zero := ~(q != 0.0).any(axis=1)).any():
        table = read_table(p, delimiter, (8, 8), what)  # for the line number
        raise table.error(int(np.argmax(zero)), "zero quaternion (qx qy qz qw all 0)")
    return data


def parse_float_columns(table: Table, columns: slice, what: str) -> NDArray[np.float64]:
    """Columns ``columns`` of every row as finite float64, shape (N, k); errors name the file and line."""
    cells = [r[columns] for r in table.rows]
    out = None
    if all_numbers([c for row in cells for c in row]):
        try:
            out = np.array(cells, dtype=np.float64)
        except ValueError:
            out = None
    if out is None or out.ndim != 2:
        for k, row in enumerate(cells):
            for c in row:
                try:
                    parse_number(c)
                except ValueError as exc:
                    raise table.error(k, f"{what}: {exc}") from None
        raise table.error(0, f"{what}: rows of unequal length")  # pragma: no cover - read_table prevents it
    bad = ~np.isfinite(out).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise table.error(k, f"{what}: non-finite value in {table.rows[k][columns]}")
    return out


def parse_int_column(table: Table, column: int, what: str) -> NDArray[np.int64]:
    """Column ``column`` as exact int64 (no float round trip), shape (N,); errors name the file and line."""
    cells = [r[column] for r in table.rows]
    try:
        return np.array(cells).astype(np.int64)
    except (ValueError, OverflowError):
        for k, c in enumerate(cells):
            try:
                v = int(c)
            except ValueError:
                raise table.error(k, f"{what}: {c!r} is not an integer") from None
            if not -(2**63) <= v < 2**63:
                raise table.error(k, f"{what}: {c!r} does not fit in int64") from None
        raise  # pragma: no cover


def open_for_writing(path: str | os.PathLike[str], overwrite: bool) -> contextlib.AbstractContextManager[IO[str]]:
    """Open ``path`` for text output, as a context manager: the file appears complete when the block ends, or not at
    all (written into a temporary sibling, :func:`dualpose.io._output.atomic_text_file`); an existing file is an
    error unless ``overwrite`` is true."""
    return atomic_text_file(check_path(path), overwrite)
