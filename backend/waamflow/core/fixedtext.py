"""CSV rows of numbers in fixed-point notation, written by numpy: the text `%` gives, faster.

`fixed_rows(cols, decimals)` returns what `"".join(row % tuple(r) for r in cols)` returns for
`row = ",".join("%.{d}f" or "%d" per column) + "\\n"`, byte for byte. The digits are worked out
on whole columns (integers), laid out in fixed-width fields padded with spaces and the spaces
dropped; a row that this cannot write exactly is written by `%` in its place:

- `%.{d}f` prints v·10^d rounded to the nearest integer N (exactly: half to even on the exact
  binary value). y = fl(v·10^d) is within u·|y|·(1 + 2u) of v·10^d (u = 2⁻⁵³; 10^d is exact),
  so when |y − rint(y)| < ½ − 2.3e-16·|y|, N = rint(y) (y − rint(y) is exact: Sterbenz). Other
  values (within 1e-13 of a tie, |y| ≥ 2⁵⁰, NaN, ±inf) are `%`'s. The sign is v's sign bit
  ("-0.0000" for −0.00001, as `%` writes it).
- `%d` prints int(v) (truncation); columns written with it must hold integers (0/1 flags):
  another value, or |v| ≥ 2⁵⁰, is `%`'s.
Units: none (text).
"""

from __future__ import annotations

import numpy as np

_SPACE = 32
_LIMIT = 2.0**50  # |v·10^d| below this: the integer digits fit int64 and the test above holds


def fixed_rows(cols: np.ndarray, decimals: tuple[int | None, ...], block: int = 16384) -> str:
    """The rows of `cols` (n, c) as `%` writes them with `row_format(decimals)` (module doc);
    decimals[j]: digits after the point of column j, None for `%d`. block: rows per buffer (it
    stays in the CPU cache)."""
    cols = np.asarray(cols, dtype=float)
    n = len(cols)
    if n == 0:
        return ""
    if cols.ndim != 2 or cols.shape[1] != len(decimals):
        raise ValueError(f"fixed_rows: {cols.shape} columns for {len(decimals)} formats")
    fmt = row_format(decimals)
    scaled = []
    ok = np.ones(n, dtype=bool)
    with np.errstate(invalid="ignore", over="ignore"):
        for j, d in enumerate(decimals):
            v = cols[:, j]
            if d is None:
                y = v
                good = (v == np.trunc(v)) & (np.abs(v) < _LIMIT)
                N = np.where(good, v, 0.0)
                neg = N < 0  # int(-0.0) is 0: no sign
            else:
                y = v * 10.0**d
                N = np.rint(y)
                good = (np.abs(y) < _LIMIT) & (np.abs(y - N) < 0.5 - 2.3e-16 * np.abs(y))
                N = np.where(good, N, 0.0)
                neg = np.signbit(v)
            ok &= good
            scaled.append((np.abs(N).astype(np.int64), neg, d))
    if ok.all():
        return _fast(scaled, n, block)
    out = []
    bad = np.flatnonzero(~ok).tolist()
    start = 0
    for i in bad + [n]:
        if i > start:
            out.append(_fast([(a[start:i], s[start:i], d) for a, s, d in scaled], i - start, block))
        if i < n:
            out.append(fmt % tuple(cols[i].tolist()))
        start = i + 1
    return "".join(out)


def row_format(decimals: tuple[int | None, ...]) -> str:
    """The `%` row format of `fixed_rows`: "%.4f,%d,...\\n"."""
    return ",".join("%d" if d is None else f"%.{d}f" for d in decimals) + "\n"


def _fast(scaled: list[tuple[np.ndarray, np.ndarray, int | None]], n: int, block: int) -> str:
    """Rows of |N|, sign and decimals per column (all exact): fixed-width fields (a field's sign
    in its first byte, before the integer part's leading spaces), the spaces dropped."""
    layout = []
    for a, _, d in scaled:
        dd = d or 0
        digits = len(str(int(a.max()) // 10**dd))
        layout.append((digits, dd, 1 + digits + (1 + dd if dd else 0)))  # sign, integer part, ".", decimals
    W = sum(w for _, _, w in layout) + len(layout)  # a comma after each field, the last one "\n"
    out = []
    for r0 in range(0, n, block):
        m = min(n, r0 + block) - r0
        buf = np.empty((m, W), dtype=np.uint8)
        pos = 0
        for (a, neg, d), (digits, dd, w) in zip(scaled, layout):
            ab = a[r0 : r0 + m]
            buf[:, pos] = np.where(neg[r0 : r0 + m], _MINUS, _SPACE)
            # digits from the last: q − 10·(q // 10), then q //= 10 (by a constant: numpy's fast path)
            q = ab
            for c in range(pos + w - 1, pos + 1 + digits, -1):  # the decimals
                h = q // 10
                buf[:, c] = q - h * 10 + _ZERO
                q = h
            if dd:  # "%.0f" writes no point
                buf[:, pos + 1 + digits] = _POINT
            h = q // 10
            buf[:, pos + digits] = q - h * 10 + _ZERO  # the units digit, written always
            q = h
            for c in range(pos + digits - 1, pos, -1):  # the integer part's leading zeros are spaces
                h = q // 10
                buf[:, c] = np.where(q > 0, q - h * 10 + _ZERO, _SPACE)
                q = h
            buf[:, pos + w] = _COMMA
            pos += w + 1
        buf[:, W - 1] = _NEWLINE
        out.append(buf.tobytes().translate(None, b" "))
    return b"".join(out).decode("ascii")


_ZERO, _MINUS, _POINT, _COMMA, _NEWLINE = (ord(c) for c in "0-.,\n")
