"""Text lines of the streaming jobs (``dualpose ahrs --stream``, ``dualpose fuse --stream``): numbers in, exact
numbers out.

Input fields are separated by commas or by whitespace (:func:`dualpose.io._text.split_fields` with ``"auto"``);
``#`` starts a comment; numbers are in the grammar of the file readers (:func:`dualpose.io._text.parse_number`).
Output numbers are Python's ``repr`` of the float64 (the shortest text that reads back to the same value), so a
line read back gives the filter's numbers bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence

from dualpose.io._text import all_numbers, parse_number, split_fields

__all__ = ["format_numbers", "parse_numbers", "split_fields"]


def parse_numbers(fields: Sequence[str], names: Sequence[str] | Callable[[int], str], first: int = 1) -> list[float]:
    """The finite float values of ``fields``.

    Parameters
    ----------
    fields : sequence of str
        The fields to convert (the caller checks their count).
    names : sequence of str, or callable
        Their names (``names[k]`` or ``names(k)`` for field ``k``), for the messages.
    first : int
        Number of the first field on its line (1-based), for the messages.

    Raises
    ------
    ValueError
        ``field K (name): 'x' is not a number`` or ``field K (name): non-finite value 'inf'``.
    """
    if all_numbers(list(fields)):
        values = list(map(float, fields))
        if all(map(math.isfinite, values)):
            return values
    name = names if callable(names) else names.__getitem__
    for k, text in enumerate(fields):  # the first bad field, for the message
        try:
            v = parse_number(text)
        except ValueError:
            raise ValueError(f"field {first + k} ({name(k)}): {text!r} is not a number") from None
        if not math.isfinite(v):
            raise ValueError(f"field {first + k} ({name(k)}): non-finite value {text!r}")
    raise AssertionError("unreachable: every field converted")


def format_numbers(values: Iterable[float]) -> str:
    """One output line: the values' ``repr`` separated by ``", "``, with its newline."""
    return ", ".join(map(repr, map(float, values))) + "\n"
