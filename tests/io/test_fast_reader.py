"""The fast numeric-table reader (``io/_text.py::read_float_table``) gives the numbers ``float()`` gives and hands
whatever it does not accept to the line reader, whose errors name the file and line."""

from __future__ import annotations

import numpy as np
import pytest

from dualpose.io import _text, read_tum


def _tokens(rng: np.random.Generator, n: int) -> list[str]:
    x = rng.normal(size=n) * 10.0 ** rng.integers(-12, 12, size=n)
    fmts = ["{:.17g}", "{:.6f}", "{:.4f}", "{:.9e}", "{:.3E}", "{:.0f}", "{:.15g}", "{:.20f}", "{:+.5f}"]
    out = [fmts[k % len(fmts)].format(v) for k, v in enumerate(x)]
    out[:6] = ["-0", "-0.0", "0.000", ".5", "7.", "1e-300"]
    return out


def test_fast_path_equals_float_on_every_token(tmp_path):
    rng = np.random.default_rng(7)
    toks = _tokens(rng, 8 * 5000)
    rows = [" ".join(toks[i : i + 8]) for i in range(0, len(toks), 8)]
    f = tmp_path / "t.txt"
    f.write_text("# header\n" + "\n".join(rows) + "\n")
    data = _text.read_float_table(f, 8, None, "8 numbers")
    want = np.array([float(t) for t in toks]).reshape(-1, 8)
    assert data.shape == want.shape
    assert np.array_equal(data.view(np.int64), want.view(np.int64))  # bit for bit, signs of zeros included


def test_block_boundaries_comments_crlf_bom_and_growth(tmp_path, monkeypatch):
    monkeypatch.setattr(_text, "_BLOCK", 64)
    rng = np.random.default_rng(8)
    vals = rng.normal(size=(300, 8))
    lines = []
    for k, r in enumerate(vals):
        line = " ".join(f"{v:.17g}" if k % 3 else f"{v:.6f}" for v in r)
        lines.append(line + ("  # trailing comment" if k % 7 == 0 else ""))
        if k % 50 == 0:
            lines.append("# a comment line")
            lines.append("")
    f = tmp_path / "t.txt"
    f.write_bytes(b"\xef\xbb\xbf" + "\r\n".join(lines).encode() + b"\r\n")
    data = _text.read_float_table(f, 8, None, "8 numbers")
    want = np.array([[float(x) for x in ln.split("#")[0].split()] for ln in lines if ln and not ln.startswith("#")])
    assert np.array_equal(data, want)


def test_comma_separated_and_trailing_comments(tmp_path):
    f = tmp_path / "c.txt"
    f.write_text("# t, x, y, z, qx, qy, qz, qw\n1.0, 2, 3, 4, 0, 0, 0, 1  # first\n2.5,2,3,4,0,0,0,1\n")
    data = _text.read_float_table(f, 8, ",", "8 numbers")
    assert np.array_equal(data, [[1.0, 2, 3, 4, 0, 0, 0, 1], [2.5, 2, 3, 4, 0, 0, 0, 1]])


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("1 2 3 4 5 6 7", "expected 8 fields"),
        ("1 2 3 4 5 6 7 8 9", "expected 8 fields"),
        ("1 2 3 x 5 6 7 8", "'x' is not a number"),
        ("1 2 3 nan 0 0 0 1", "non-finite"),
        ("1 2 3 1e999 0 0 0 1", "non-finite"),
        ("1 2 3 4 0 0 0 0", "zero quaternion"),
    ],
)
def test_bad_lines_still_name_file_and_line(tmp_path, line, message):
    f = tmp_path / "bad.txt"
    f.write_text("# h\n0 0 0 0 0 0 0 1\n" + line + "\n")
    with pytest.raises(ValueError, match=rf"bad.txt:3: .*{message}"):
        read_tum(f)


def test_python_only_float_literals_are_refused_by_both_paths(tmp_path):
    """'1_0' is a Python float literal, not a number of the file formats: the fast path hands it to the line reader,
    which refuses it with the file and line (docs/refusals.md, "Files and messages")."""
    f = tmp_path / "odd.txt"
    f.write_text("0 0 0 0 0 0 0 1\n1\t0 0 0 0 0 0 1_0\n")
    with pytest.raises(ValueError, match=r"odd\.txt:2: .*'1_0' is not a number"):
        read_tum(f)


def test_long_mantissas_are_correctly_rounded(tmp_path):
    """17-19 significant digits (``%.17g``, evo's ``%.18e``) take the double-double path: bit-equal to float()."""
    rng = np.random.default_rng(11)
    n = 8 * 20000
    spread = rng.normal(size=n // 2) * 10.0 ** rng.integers(-15, 15, n // 2)
    x = np.concatenate([spread, 1.4e9 + 1e3 * rng.random(n // 2)])
    fmts = ["{:.17g}", "{:.18e}", "{:.19g}", "{:.16e}", "{:.21g}"]
    toks = [fmts[k % len(fmts)].format(v) for k, v in enumerate(x)]
    f = tmp_path / "long.txt"
    f.write_text("\n".join(" ".join(toks[i : i + 8]) for i in range(0, n, 8)) + "\n")
    data = _text.read_float_table(f, 8, None, "8 numbers")
    want = np.array([float(t) for t in toks]).reshape(-1, 8)
    assert np.array_equal(data.view(np.int64), want.view(np.int64))
