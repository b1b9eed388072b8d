"""core.fixedtext writes the text % writes, byte for byte: on ordinary numbers, and on the values
it hands back to % (ties such as 0.03125 → "0.0312", NaN, ±inf, |v·10^d| ≥ 2⁵⁰, a %d column
holding 3.5), negative zero and tiny negatives ("-0.0000"), across block edges."""

from __future__ import annotations

import numpy as np
import pytest

from waamflow.core.fixedtext import fixed_rows, row_format

DEC = (4, 4, 4, 4, 3, None, 4)


def _percent(cols: np.ndarray, dec) -> str:
    fmt = row_format(dec)
    return "".join(fmt % tuple(r) for r in cols.tolist())


def _columns(n: int, rng) -> np.ndarray:
    return np.column_stack(
        [
            np.cumsum(rng.random(n) * 0.004),
            rng.normal(0, 100, n),
            rng.normal(0, 1, n) * rng.choice([1e-5, 1.0, 1e3], n),
            rng.random(n) * 300,
            rng.random(n) * 20,
            (rng.random(n) > 0.5).astype(float),
            rng.random(n) * 0.04,
        ]
    )


def test_the_text_percent_writes():
    rng = np.random.default_rng(1)
    n = 5000
    c = _columns(n, rng)
    assert fixed_rows(c, DEC, block=333) == _percent(c, DEC)
    special = [0.03125, -0.03125, 0.00005, -0.0, 0.0, np.nan, np.inf, -np.inf, 1e20, -1e-20, 0.5, 2.5]
    special += [0.12345, 1e15, 123456789.123456, 0.0625, 0.00015, -7.00005, 9999.99995]
    for j in (0, 1, 2, 3, 4, 6):
        idx = rng.choice(n, 150, replace=False)
        c[idx, j] = rng.choice(special, 150)
    c[rng.choice(n, 5, replace=False), 5] = [2.0, -1.0, -0.0, 3.5, 1e17]
    got = fixed_rows(c, DEC, block=333)
    want = _percent(c, DEC)
    assert got == want
    assert got.count("\n") == n
    for text in ("0.0312,", "-0.0312,", "-0.0000,", "nan", "inf,", "-inf,", "100000000000000000000.0000"):
        assert text in got


def test_few_rows_and_bad_shapes():
    rng = np.random.default_rng(2)
    assert fixed_rows(np.zeros((0, 7)), DEC) == ""
    one = _columns(1, rng)
    assert fixed_rows(one, DEC) == _percent(one, DEC)
    ints = np.array([[0.0, -3.0], [12.0, 5.0], [-0.0, -0.0]])
    assert fixed_rows(ints, (None, None)) == "0,-3\n12,5\n0,0\n"
    assert fixed_rows(np.array([[0.5], [1.5], [-2.5], [0.0001]]), (0,)) == "0\n2\n-2\n0\n"
    with pytest.raises(ValueError, match="columns"):
        fixed_rows(np.zeros((3, 2)), DEC)
