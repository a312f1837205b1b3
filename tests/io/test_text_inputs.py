"""Bounded reading and the one number grammar of the text readers (:mod:`dualpose.io._text`): a directory or a device
is refused before anything is read, a pipe is read once and can be read again, stream lines are bounded, and every
reader accepts exactly the grammar ``[+-] digits [. digits] [(e|E) [+-] digits]`` -- the native fast path and the
line-by-line reader alike."""

from __future__ import annotations

import io
import os
import re
import threading

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dualpose.io import _text, read_tum
from dualpose.io._text import MAX_LINE_BYTES, NUMBER, bounded_lines, open_input, parse_number

#: the grammar written independently of the module: optional sign, digits with an optional point (at least one
#: digit in all), optional exponent
_REFERENCE = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", re.ASCII)


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet=st.sampled_from(list("0123456789+-.eE_x ") + ["١", "٣", "\u00a0", "i", "n", "f", "a"]),
               min_size=1, max_size=10))  # fmt: skip
def test_parse_number_takes_exactly_the_grammar(text):
    if _REFERENCE.fullmatch(text):
        assert parse_number(text) == float(text)
    elif re.fullmatch(r"[+-]?(nan|inf|infinity)", text, re.IGNORECASE):
        assert not np.isfinite(parse_number(text))  # recognised, to be reported as non-finite
    else:
        with pytest.raises(ValueError, match="is not a number"):
            parse_number(text)


@settings(max_examples=200, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False), st.sampled_from(["{!r}", "{:.17g}", "{:.6e}", "{:.3f}"]))
def test_every_float_written_in_the_usual_ways_reads_back(x, fmt):
    text = fmt.format(x)
    assert NUMBER.fullmatch(text) and parse_number(text) == float(text)


@pytest.mark.parametrize("token", ["1_000", "0x10", "0x1p3", "١٢", "1e5_0", "--1", "1e", ".", "e5", "+-1", "1.2.3"])
def test_python_only_literals_are_refused_by_the_fast_and_the_line_reader(tmp_path, token):
    f = tmp_path / "t.tum"
    f.write_text("0 0 0 0 0 0 0 1\n" + f"1 0 0 0 0 0 0 {token}\n")
    with pytest.raises(ValueError, match=r"t\.tum:2: .*is not a number"):
        read_tum(f)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.text(alphabet="0123456789.eE+-", min_size=1, max_size=6), min_size=8, max_size=8))
def test_the_fast_path_and_the_line_reader_agree(tmp_path_factory, fields):
    """Whatever the native kernel accepts the grammar accepts, with the same numbers; what it refuses the line
    reader refuses with file:line, or reads to the same numbers."""
    f = tmp_path_factory.mktemp("agree") / "row.txt"
    f.write_text(" ".join(fields) + "\n")
    want = [parse_number(x) if _REFERENCE.fullmatch(x) else None for x in fields]
    if None in want or not np.isfinite(want).all():
        with pytest.raises(ValueError, match=r"row\.txt:1: "):
            _text.read_float_table(f, 8, None, "8 numbers")
    else:
        np.testing.assert_array_equal(_text.read_float_table(f, 8, None, "8 numbers")[0], want)


def test_directories_and_devices_are_refused_before_reading(tmp_path):
    with pytest.raises(ValueError, match="a directory, not a file"):
        read_tum(tmp_path)
    with pytest.raises(ValueError, match="/dev/zero: a character device, not a file"):
        read_tum("/dev/zero")
    with pytest.raises(FileNotFoundError, match="no such file"):
        open_input(tmp_path / "missing.txt")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes")
def test_a_pipe_is_read_once_and_kept_for_a_second_look(tmp_path):
    fifo = tmp_path / "est.fifo"
    os.mkfifo(fifo)
    text = "".join(f"{k}.0 {k} 0 0 0 0 0 1\n" for k in range(5))

    def feed() -> None:
        with open(fifo, "w") as w:
            w.write(text)

    writer = threading.Thread(target=feed)
    writer.start()
    traj = read_tum(fifo)  # the reader opens its input twice (delimiter sniff, then the table): seekable bytes
    writer.join(timeout=10)
    assert len(traj) == 5 and traj.positions[4, 0] == 4.0


def test_stream_lines_are_bounded_decoded_and_lose_a_leading_bom():
    lines = list(bounded_lines(io.BytesIO(b"\xef\xbb\xbf1, 2\n3, 4\n")))
    assert lines == ["1, 2\n", "3, 4\n"]
    assert list(bounded_lines(io.StringIO("\ufeffa\nb"))) == ["a\n", "b"]
    with pytest.raises(ValueError, match="stdin line 2: longer than"):
        list(bounded_lines(io.BytesIO(b"ok\n" + b"0" * (MAX_LINE_BYTES + 5))))
    with pytest.raises(ValueError, match="stdin line 1: not UTF-8 text"):
        list(bounded_lines(io.BytesIO(b"\xff\xfe1\n")))
