"""CSV reader: header detection, comments, and line-numbered errors."""

from __future__ import annotations

import numpy as np
import pytest

from dualpose.io.csv_points import CsvFormatError, read_columns


def test_header_comments_blank_lines(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("x, y, z\n# a comment\n1, 2, 3\n\n4.5,-5e-1, 6\n")
    assert np.array_equal(read_columns(f, 3), [[1, 2, 3], [4.5, -0.5, 6]])
    g = tmp_path / "w.csv"
    g.write_text("1\n2\n")
    assert np.array_equal(read_columns(g, 1), [1.0, 2.0])


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("1,2,3\n4,5\n", r"line 2: expected 3 column\(s\) of points, got 2"),
        ("x,y,z\n1,2,3\n4,abc,6\n", r"line 3, column 2: 'abc' is not a number"),
        ("1,2,3\n1,2,nan\n", r"line 2, column 3: 'nan' is not finite"),
        ("x,y\n1,2\n", r"line 1: header has 2 column"),
        ("# only a comment\n", "no data rows"),
        ("1,2,3\nx,y,z\n", r"line 2, column 1: 'x' is not a number"),
    ],
)
def test_errors_name_the_line(tmp_path, text, match):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(CsvFormatError, match=match):
        read_columns(f, 3, "points")


def test_missing_file(tmp_path):
    with pytest.raises(CsvFormatError, match="cannot read"):
        read_columns(tmp_path / "nope.csv", 3)
