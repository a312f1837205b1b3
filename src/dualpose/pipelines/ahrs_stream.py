"""The AHRS on a stream of text lines: one IMU sample per input line in, one orientation per input line out.

The job behind ``dualpose ahrs --stream`` (docs/broad.md, "Streaming"; the line formats are defined there and in
:data:`INPUT_FIELDS` / :func:`format_row`).  :func:`stream_ahrs_lines` parses each line, feeds it to
:class:`~dualpose.estimation.ahrs.stream.AhrsStream` and yields the output lines as soon as they are known:

* input: ``t, gx, gy, gz, ax, ay, az[, mx, my, mz]`` (s, rad/s, m/s², any field unit), separated by commas or by
  whitespace; ``#`` starts a comment, blank and comment lines give no output;
* output: ``t, qx, qy, qz, qw`` (orientation IMU → earth, ENU, xyzw), every number as Python's ``repr`` (the shortest
  text that reads back to the same float64, at most 17 significant digits);
* every output line comes at its own input line (the filter is strictly causal): inside the rest period (its first
  ``n_rest`` samples) the orientation of the running mean specific force and field so far; at its last sample the
  filter is initialised from the rest statistics and its output follows from then on.

Errors (a malformed line, a time that does not increase, a sample beyond the plausible IMU range, a state the filter
cannot continue from) are ``ValueError`` s naming the source and line, raised after every output line of the earlier
input lines was yielded; a gap in the time stamps or stamps that contradict ``rate`` are
:class:`~dualpose.types.recording.RecordingWarning` s naming the line (docs/refusals.md).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

from dualpose.estimation.ahrs.stream import AhrsStream
from dualpose.pipelines._lines import StreamTimes, format_numbers, parse_numbers, split_fields

__all__ = ["INPUT_FIELDS", "OUTPUT_FIELDS", "format_row", "parse_imu_line", "stream_ahrs_lines"]

#: the fields of an input line, 9D (``True``) and 6D (``False``)
INPUT_FIELDS: dict[bool, tuple[str, ...]] = {
    True: ("t", "gx", "gy", "gz", "ax", "ay", "az", "mx", "my", "mz"),
    False: ("t", "gx", "gy", "gz", "ax", "ay", "az"),
}

#: the fields of an output line
OUTPUT_FIELDS: tuple[str, ...] = ("t", "qx", "qy", "qz", "qw")


def parse_imu_line(line: str, use_mag: bool) -> list[float] | None:
    """The numbers of one input line, or None for a blank or comment line.

    Parameters
    ----------
    line : str
        ``t, gx, gy, gz, ax, ay, az[, mx, my, mz]``, comma or whitespace separated, optional ``#`` comment.
    use_mag : bool
        10 fields (9D) or 7 (6D).

    Returns
    -------
    list of float or None
        The 7 or 10 values, all finite.

    Raises
    ------
    ValueError
        On a wrong number of fields, a field that is not a number, or a non-finite value (the message names the
        field; the caller adds the line).
    """
    fields = split_fields(line, "auto")
    if fields is None:
        return None
    names = INPUT_FIELDS[use_mag]
    if len(fields) != len(names):
        raise ValueError(f"expected {len(names)} fields ({', '.join(names)}), got {len(fields)}")
    return parse_numbers(fields, names)


def format_row(t: float, quat: np.ndarray) -> str:
    """One output line ``t, qx, qy, qz, qw`` with its newline; each number is ``repr`` of the float64 (exact)."""
    return format_numbers([t, *quat.tolist()])


def stream_ahrs_lines(
    lines: Iterable[str], rate: float, *, use_mag: bool = True, n_rest: int = 0, source: str = "stdin"
) -> Iterator[str]:
    """Filter the IMU samples of ``lines`` and yield one output line per sample, as soon as it is known.

    Parameters
    ----------
    lines : iterable of str
        Input lines (module docstring); read one at a time, so a pipe or ``sys.stdin`` is consumed as it comes.
    rate : float
        Sampling rate, Hz (the filter's step is ``1 / rate``, as in the batch estimator).
    use_mag : bool
        9D (10 fields per line) or 6D (7 fields).
    n_rest : int
        Samples of the rest period the filter is initialised from (0, or at least 10); their outputs are the running
        mean directions so far until the last of them.
    source : str
        Name of the input in error messages.

    Yields
    ------
    str
        ``t, qx, qy, qz, qw`` plus a newline (:func:`format_row`), one per sample, in input order, each as soon as
        its input line was read.  The orientations are those of
        :meth:`AhrsStream.update_imu <dualpose.estimation.ahrs.stream.AhrsStream.update_imu>` (default settings:
        online magnetometer time offset), bit for bit.

    Raises
    ------
    ValueError
        ``"{source} line N: ..."`` for a malformed line (wrong number of fields, not a number, non-finite) or a time
        stamp that does not increase.  Everything before the bad line has been yielded by then.
    """
    stream = AhrsStream(rate, use_mag=use_mag, n_rest=n_rest)
    times = StreamTimes(1.0 / stream.rate, source, "rate", stream.gap_watch)
    for lineno, line in enumerate(lines, start=1):
        try:
            v = parse_imu_line(line, use_mag)
            if v is None:
                continue
            t = v[0]
            times.check(t, lineno)
            q = stream.update_imu(t, v[1:4], v[4:7], v[7:10] if use_mag else None)
            if not np.isfinite(q).all():  # never a NaN line: the filter cannot go on from here
                raise ValueError("the filter's orientation is not finite; it cannot continue from this sample")
        except ValueError as exc:
            raise ValueError(f"{source} line {lineno}: {exc}") from None
        yield format_row(t, q)
