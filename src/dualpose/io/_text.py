"""Line-oriented parsing shared by the text readers, with ``file:line`` in every error, and safe output opening."""

from __future__ import annotations

import os
from pathlib import Path
from typing import IO

import numpy as np

__all__ = ["Table", "read_table", "parse_float_columns", "parse_int_column", "open_for_writing"]


class Table:
    """Data rows of a delimited text file: ``rows[k]`` is the list of fields of source line ``linenos[k]``.

    ``comments`` holds the comment lines (without the leading ``#``) in file order.
    """

    __slots__ = ("path", "rows", "linenos", "comments")

    def __init__(self, path: str, rows: list[list[str]], linenos: list[int], comments: list[str]) -> None:
        self.path, self.rows, self.linenos, self.comments = path, rows, linenos, comments

    def error(self, k: int, message: str) -> ValueError:
        return ValueError(f"{self.path}:{self.linenos[k]}: {message}")


def read_table(path: str | os.PathLike, delimiter: str | None, ncols: tuple[int, int], what: str) -> Table:
    """Read a text table: ``#`` starts a comment line, blank lines are skipped.

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
    p = str(path)
    rows: list[list[str]] = []
    linenos: list[int] = []
    comments: list[str] = []
    with open(p, encoding="utf-8-sig", newline=None) as f:
        try:
            lines = f.read().splitlines()
        except UnicodeDecodeError as exc:
            raise ValueError(f"{p}: not a UTF-8 text file ({exc})") from None
    lo, hi = ncols
    for i, line in enumerate(lines, start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            comments.append(s[1:].strip())
            continue
        fields = s.split(delimiter) if delimiter is None else [x.strip() for x in s.split(delimiter)]
        if not lo <= len(fields) <= hi:
            want = str(lo) if lo == hi else f"{lo} to {hi}"
            raise ValueError(f"{p}:{i}: expected {want} fields ({what}), found {len(fields)}: {s[:80]!r}")
        rows.append(fields)
        linenos.append(i)
    if not rows:
        raise ValueError(f"{p}: no data rows (expected {what})")
    return Table(p, rows, linenos, comments)


def parse_float_columns(table: Table, columns: slice, what: str) -> np.ndarray:
    """Columns ``columns`` of every row as finite float64, shape (N, k); errors name the file and line."""
    cells = [r[columns] for r in table.rows]
    try:
        out = np.array(cells, dtype=np.float64)
    except ValueError:
        out = None
    if out is None or out.ndim != 2:
        for k, row in enumerate(cells):
            for c in row:
                try:
                    float(c)
                except ValueError:
                    raise table.error(k, f"{what}: {c!r} is not a number") from None
        raise table.error(0, f"{what}: rows of unequal length")  # pragma: no cover - read_table prevents it
    bad = ~np.isfinite(out).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise table.error(k, f"{what}: non-finite value in {table.rows[k][columns]}")
    return out


def parse_int_column(table: Table, column: int, what: str) -> np.ndarray:
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


def open_for_writing(path: str | os.PathLike, overwrite: bool) -> IO[str]:
    """Open ``path`` for text output; an existing file is an error unless ``overwrite`` is true."""
    p = Path(path)
    try:
        return open(p, "w" if overwrite else "x", encoding="utf-8", newline="\n")
    except FileExistsError:
        raise FileExistsError(f"{p}: file exists; pass overwrite=True (CLI: --force) to replace it") from None
