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

from dualpose.estimation._stream import GapWatch
from dualpose.io._text import all_numbers, parse_number, split_fields
from dualpose.types._inputs import Doubt

__all__ = ["StreamTimes", "format_numbers", "parse_numbers", "split_fields"]


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


class StreamTimes:
    """The time stamps of a stream's IMU lines: refuses one that is not finite or does not increase, and shows each
    to the stream's :class:`~dualpose.estimation._stream.GapWatch` with its line number, which warns
    (:class:`~dualpose.types.recording.RecordingWarning`, naming the line) about a gap longer than five sample
    ``period`` s (None: the median spacing of the first ``GapWatch.RATE_SAMPLES`` stamps) and, once that many stamps
    are in, about stamps whose median spacing contradicts the stated rate (``rate_name``).  ``doubts`` keeps them.

    ``watch`` is the stream's own (the ``gap_watch`` of :class:`~dualpose.estimation.eskf.EskfStream`,
    :class:`~dualpose.estimation.hol22.Hol22Stream`, :class:`~dualpose.estimation.ahrs.stream.AhrsStream`): this
    shows it each stamp first, with its line number, so the stream reports a doubt once, named by the line; without
    one a watch of its own is made."""

    def __init__(self, period: float | None, source: str, rate_name: str, watch: GapWatch | None = None) -> None:
        self.watch = GapWatch(period) if watch is None else watch
        self.watch.source, self.watch.rate_name = source, rate_name
        if period is not None:
            self.watch.set_period(period)
        self.last = -math.inf

    @property
    def doubts(self) -> list[Doubt]:
        """The gaps (the first :data:`GapWatch.MAX_REPORTED <dualpose.estimation._stream.GapWatch.MAX_REPORTED>`)
        and the rate doubt, in the order they were seen."""
        return list(self.watch.doubts)

    @property
    def gaps(self) -> int:
        """The number of gaps seen."""
        return self.watch.count

    def check(self, t: float, lineno: int) -> None:
        """Refuse (ValueError) or note (warning) the stamp ``t`` of input line ``lineno``."""
        if not (math.isfinite(t) and t > self.last):
            raise ValueError(f"t must be finite and increase strictly: got {t!r} after {self.last!r}")
        self.watch.see(t, lineno)
        self.last = t
