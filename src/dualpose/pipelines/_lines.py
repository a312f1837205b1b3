"""Text lines of the streaming jobs (``dualpose ahrs --stream``, ``dualpose fuse --stream``): numbers in, exact
numbers out.

Input fields are separated by commas or by whitespace (:func:`dualpose.io._text.split_fields` with ``"auto"``);
``#`` starts a comment.  Output numbers are Python's ``repr`` of the float64 (the shortest text that reads back to
the same value), so a line read back gives the filter's numbers bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

from dualpose.io._text import split_fields

__all__ = ["format_numbers", "parse_numbers", "split_fields"]


def parse_numbers(fields: Sequence[str], names: Sequence[str], first: int = 1) -> list[float]:
    """The finite float values of ``fields``.

    Parameters
    ----------
    fields : sequence of str
        The fields to convert (as many as ``names``; the caller checks the count).
    names : sequence of str
        Their names, for the messages.
    first : int
        Number of the first field on its line (1-based), for the messages.

    Raises
    ------
    ValueError
        ``field K (name): 'x' is not a number`` or ``field K (name): non-finite value 'inf'``.
    """
    values = []
    for k, (text, name) in enumerate(zip(fields, names, strict=True)):
        try:
            v = float(text)
        except ValueError:
            raise ValueError(f"field {first + k} ({name}): {text!r} is not a number") from None
        if not math.isfinite(v):
            raise ValueError(f"field {first + k} ({name}): non-finite value {text!r}")
        values.append(v)
    return values


def format_numbers(values: Iterable[float]) -> str:
    """One output line: the values' ``repr`` separated by ``", "``, with its newline."""
    return ", ".join(repr(float(v)) for v in values) + "\n"
