"""A node's notes gathered over its layers and said once per kind.

A kernel notes each event where it happens ("direct_crossing at [x, y]: influence_radius 10 mm is
below 20.1 mm …", one per crossing); pythonocc-demos' Ventilator.stp gave 51 warnings through
wall-path, 34 of them two such kinds. Notes that differ only in their numbers are one kind: the
first is said as it is, followed by how many more there are and on which layers."""

from __future__ import annotations

import re

from .errors import layer_ranges

_NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


class Notes:
    """Notes by kind, in the order their kinds were first noted. A note repeated word for word
    (an extrusion's layers repeat their notes) counts once."""

    def __init__(self) -> None:
        self._kinds: dict[str, list[tuple[int | None, str]]] = {}
        self._seen: set[str] = set()

    def add(self, text: str, layer: int | None = None) -> None:
        if text in self._seen:
            return
        self._seen.add(text)
        self._kinds.setdefault(_NUMBER.sub("#", text), []).append((layer, text))

    def said(self) -> list[tuple[int | None, str]]:
        """(layer of the first, text) per kind: the first note, then "(and N more like it, on
        layers …)" when there are more."""
        out = []
        for items in self._kinds.values():
            layer, text = items[0]
            if len(items) > 1:
                layers = sorted({i for i, _t in items if i is not None})
                where = f", on layer{'s' if len(layers) > 1 else ''} {layer_ranges(layers)}" if layers else ""
                text = f"{text} (and {len(items) - 1} more like it{where})"
            out.append((layer, text))
        return out
