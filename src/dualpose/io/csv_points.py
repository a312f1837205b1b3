"""Read numeric columns (points, directions, weights) from CSV files, with line-numbered errors.

Format: comma-separated values, one correspondence per line; an optional header line (recognised when any of its
cells is not a number); blank lines and lines starting with ``#`` are skipped; spaces around cells are ignored.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dualpose.io._text import open_input, parse_number

__all__ = ["CsvFormatError", "read_columns"]


class CsvFormatError(ValueError):
    """A CSV file that does not hold the expected numeric table; the message names the file and line."""


def _number(cell: str) -> float | None:
    try:
        value = parse_number(cell)
    except ValueError:
        return None
    return value


def read_columns(path: str | Path, ncols: int, what: str = "values") -> NDArray[np.float64]:
    """Rows of ``ncols`` numbers from the CSV file ``path``: shape ``(n, ncols)`` (``(n,)`` when ``ncols == 1``).

    Parameters
    ----------
    path : str or Path
    ncols : int
        Expected number of columns (3 for points ``x, y, z`` or directions, 1 for weights).
    what : str
        What the columns are, for error messages (e.g. ``"points (x, y, z)"``).

    Raises
    ------
    CsvFormatError
        Missing or unreadable file, ragged rows, non-numeric or non-finite cells, or no data rows; the message gives
        the file name and the 1-based line number.
    """
    path = Path(path)
    try:
        with open_input(path) as f:
            text = f.read().decode("utf-8-sig")
    except ValueError as exc:
        raise CsvFormatError(str(exc)) from None
    except OSError as exc:
        raise CsvFormatError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise CsvFormatError(f"{path}: not a UTF-8 text file") from None
    rows: list[list[float]] = []
    first_data_seen = False
    for lineno, cells in enumerate(csv.reader(text.splitlines()), start=1):
        cells = [c.strip() for c in cells]
        if not cells or all(c == "" for c in cells) or cells[0].startswith("#"):
            continue
        values = [_number(c) for c in cells]
        if not first_data_seen and not rows and any(v is None for v in values):
            first_data_seen = True  # header line
            if len(cells) != ncols:
                raise CsvFormatError(
                    f"{path}, line {lineno}: header has {len(cells)} column(s); expected {ncols} for {what}"
                )
            continue
        first_data_seen = True
        if len(cells) != ncols:
            raise CsvFormatError(f"{path}, line {lineno}: expected {ncols} column(s) of {what}, got {len(cells)}")
        for col, (cell, v) in enumerate(zip(cells, values, strict=True), start=1):
            if v is None:
                raise CsvFormatError(f"{path}, line {lineno}, column {col}: {cell!r} is not a number")
            if not np.isfinite(v):
                raise CsvFormatError(f"{path}, line {lineno}, column {col}: {cell!r} is not finite")
        rows.append([v for v in values if v is not None])  # all of them: each was checked above
    if not rows:
        raise CsvFormatError(f"{path}: no data rows of {what}")
    arr = np.array(rows, dtype=np.float64)
    return arr[:, 0] if ncols == 1 else arr
