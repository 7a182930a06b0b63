"""When a regenerated table rewrites the file on disk (podbench.harness.rewrite, issue 23):
only when a number moved by more than one unit of its last written digit, or anything else
changed."""

import numpy as np
import pytest

from podbench.core.atomic import atomic_write_text, replace_dir
from podbench.harness.rewrite import last_digit_unit, same_number, significant_digits, unmoved


@pytest.mark.parametrize("token, unit, digits", [
    ("0.0841", 1e-4, 3), ("49", 1.0, 2), ("49.1", 0.1, 3), ("3.64399e+07", 100.0, 6),
    ("4.45e-07", 1e-9, 3), ("-2.5", 0.1, 2), ("0", 1.0, 1), ("1e+03", 1000.0, 1),
])
def test_last_digit_and_significant_digits(token, unit, digits):
    assert last_digit_unit(token) == pytest.approx(unit, rel=1e-12)
    assert significant_digits(token) == digits


@pytest.mark.parametrize("old, new, same", [
    # the three calibration numbers and the Chapter 5 maximum that flipped between kernels
    ("0.0841", "0.084", True), ("4.44e-07", "4.45e-07", True), ("49", "49.1", True),
    ("3.644e+07", "3.64399e+07", True), ("9.99", "10", True), ("999", "1e+03", True),
    # more than one unit, a sign, integers (orders, counts), one-digit values: rewrite
    ("0.0841", "0.0843", False), ("0.245595", "0.245597", False), ("-0.5", "0.5", False),
    ("5", "6", False), ("27", "12", False), ("0.1", "0.2", False), ("inf", "1e+16", False),
    ("12", "12", True),
])
def test_same_number(old, new, same):
    assert same_number(old, new) is same
    assert same_number(new, old) is same


def _fmt(values, digits):
    return "".join(f"row{i},{v:.{digits}g},x\n" for i, v in enumerate(values)).encode()


@pytest.mark.heavy
@pytest.mark.parametrize("digits, move", [(3, 1e-4), (6, 1e-7), (2, 1e-3)])
def test_round_off_below_the_last_digit_never_rewrites(digits, move):
    """Values over six decades, moved by up to ``move`` (relative; below a tenth of the
    smallest relative unit of ``digits`` digits): the written digits flip for some, and the
    file is never rewritten; a move of three units always is."""
    rng = np.random.default_rng(5)
    v = 10.0 ** rng.uniform(-7, -1, 20000) * rng.choice([-1, 1], 20000)
    w = v * (1 + move * rng.uniform(-1, 1, v.size))
    a, b = _fmt(v, digits), _fmt(w, digits)
    flipped = sum(x != y for x, y in zip(a.split(b"\n"), b.split(b"\n"), strict=True))
    assert flipped > 0 and a != b  # the flips the rule is for do occur
    assert unmoved(a, b)
    for i in range(0, v.size, 997):  # one number moved by three units of its last digit
        s = f"{v[i]:.{digits}g}"
        far = float(s) + 3 * np.sign(v[i]) * last_digit_unit(s)
        c = a.replace(f"row{i},{s},".encode(), f"row{i},{far!r},".encode())
        assert not unmoved(a, c), (s, far)


@pytest.mark.parametrize("new", [
    b"method,error\nML,0.0841\nSL,reproduced\n",   # a word changed
    b"method,error\nML,0.0841\n",                  # a row fewer
    b"method,error,n\nML,0.0841,5\nSL,0.5,6\n",    # a column more
    b"method,error\nML4,0.0841\nSL,0.5\n",         # a label changed (digits inside a word)
])
def test_anything_but_a_last_digit_rewrites(new):
    old = b"method,error\nML,0.0841\nSL,0.5\n"
    assert not unmoved(old, new)
    assert unmoved(old, b"method,error\nML,0.084\nSL,0.5\n")


def test_binary_files_are_kept_only_when_identical():
    png = b"\x89PNG\r\n\x1a\n0.5"
    assert unmoved(png, png) and not unmoved(png, png[:-1] + b"6")


def test_writers_keep_an_unmoved_file_and_replace_a_moved_one(tmp_path):
    f = tmp_path / "t.csv"
    f.write_text("a,0.0841\n")
    atomic_write_text(f, "a,0.084\n", keep=unmoved)
    assert f.read_text() == "a,0.0841\n"
    atomic_write_text(f, "a,0.0846\n", keep=unmoved)
    assert f.read_text() == "a,0.0846\n"
    out = tmp_path / "study"
    with replace_dir(out) as tmp:
        (tmp / "summary.csv").write_text("ML,49\n")
        (tmp / "FINDINGS.md").write_text("ML: 5 of 12 reproduced\n")
    with replace_dir(out, keep=unmoved) as tmp:
        (tmp / "summary.csv").write_text("ML,49.1\n")           # kept
        (tmp / "FINDINGS.md").write_text("ML: 6 of 12 reproduced\n")  # rewritten
        (tmp / "new.md").write_text("x\n")
    assert (out / "summary.csv").read_text() == "ML,49\n"
    assert (out / "FINDINGS.md").read_text() == "ML: 6 of 12 reproduced\n"
    assert sorted(p.name for p in out.iterdir()) == ["FINDINGS.md", "new.md", "summary.csv"]

