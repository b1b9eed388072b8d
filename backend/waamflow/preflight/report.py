"""The preflight report of one program as it is built: its problems (each naming the check,
severity, node, layer and section) and its per-layer figures; `rounded` is how figures enter it."""

from __future__ import annotations

import math


class Report:
    """A program's problems and per-layer figures (see module doc)."""

    def __init__(self, node: str, fmt: str) -> None:
        self.node, self.fmt = node, fmt
        self.problems: list[dict] = []
        self.layers: dict[int, dict] = {}

    def problem(
        self, check: str, severity: str, message: str, *, layer=None, section=None, value=None, limit=None, point=None
    ) -> None:
        self.problems.append(
            {
                "check": check,
                "severity": severity,
                "node": self.node,
                "layer": layer,
                "section": section,
                "message": message,
                "value": rounded(value),
                "limit": rounded(limit),
                "point": None if point is None else [round(float(v), 3) for v in point],
            }
        )

    def layer(self, i: int) -> dict:
        return self.layers.setdefault(i, {"index": i})


def rounded(v, nd: int = 4):
    """`v` rounded to `nd` digits (lists and tuples item by item); None for None and non-finite values.
    A value that rounds to zero is 0.0, never -0.0 (a top gap of -1e-9 mm read "-0.0")."""
    if v is None:
        return None
    if isinstance(v, (list, tuple)):
        return [rounded(x, nd) for x in v]
    v = float(v)
    return round(v, nd) + 0.0 if math.isfinite(v) else None
