"""The as-built surface of a build in the 3D view (#29): the scanned top of every scanned layer,
drawn as points where the scan put each path sample's crest (planned crest + deviation along the
build direction), coloured by the deviation from the plan, next to the planned toolpath.

Colours: a diverging map, blue (below plan) → white (on plan) → red (above), symmetric about 0
over ±max |deviation| of the build (at least ±0.05 mm so that a perfect build stays white), so the
same colour means the same error on every layer; samples the scan did not see are not drawn. The
legend (`AsBuiltOverlay.legend`) gives the range, the map's stops, point and layer counts.

    overlay = AsBuiltOverlay(build_id, session.surface())
    overlay.draw(scene)          # viser scene (or NullScene); one point cloud per layer under /asbuilt
    overlay.remove()

Units: mm.
"""

from __future__ import annotations

from contextlib import suppress
from typing import Any

import numpy as np

ROOT = "/asbuilt"
MIN_RANGE_MM = 0.05
# blue → white → red (ColorBrewer RdBu ends, reversed so that red = too high)
STOPS = np.array([[33, 102, 172], [247, 247, 247], [178, 24, 43]], dtype=float)


def diverging(values: np.ndarray, limit: float) -> np.ndarray:
    """(n,) deviation → (n, 3) uint8, −limit blue, 0 white, +limit red (clipped)."""
    u = np.clip(np.asarray(values, float) / max(limit, 1e-12), -1.0, 1.0)
    lo = u < 0
    t = np.abs(u)[:, None]
    rgb = np.where(lo[:, None], STOPS[1] * (1 - t) + STOPS[0] * t, STOPS[1] * (1 - t) + STOPS[2] * t)
    return rgb.round().astype(np.uint8)


class AsBuiltOverlay:
    """The as-built points of a build's scanned layers and their colours (see module doc).
    `layers`: `BuildSession.surface()` (per layer: points, normal, deviation, …)."""

    def __init__(self, build: str, layers: list[dict[str, Any]]) -> None:
        self.build = build
        self.layers: list[tuple[int, np.ndarray, np.ndarray]] = []  # (layer, points, deviation)
        for row in layers:
            dev = np.asarray(row["deviation"], float)
            ok = np.isfinite(dev)
            pts = np.asarray(row["points"], float)[ok] + dev[ok][:, None] * np.asarray(row["normal"], float)[ok]
            self.layers.append((int(row["layer"]), pts, dev[ok]))
        devs = [d for _, _, d in self.layers if len(d)]
        allv = np.concatenate(devs) if devs else np.zeros(0)
        self.min = float(allv.min()) if len(allv) else 0.0
        self.max = float(allv.max()) if len(allv) else 0.0
        self.limit = max(abs(self.min), abs(self.max), MIN_RANGE_MM)
        self.handles: list[Any] = []

    @property
    def points(self) -> int:
        return sum(len(p) for _, p, _ in self.layers)

    def colors(self, layer_pos: int) -> np.ndarray:
        return diverging(self.layers[layer_pos][2], self.limit)

    @property
    def legend(self) -> dict[str, Any]:
        return {
            "kind": "asbuilt",
            "build": self.build,
            "unit": "mm",
            "points": self.points,
            "layers": [k for k, p, _ in self.layers if len(p)],
            "range": {"lo": -round(self.limit, 4), "hi": round(self.limit, 4)},
            "deviation": {"min": round(self.min, 4), "max": round(self.max, 4)},
            "stops": ["#%02x%02x%02x" % tuple(int(c) for c in s) for s in STOPS],
        }

    def draw(self, scene, point_size: float = 1.5) -> int:
        """Draw every layer's points on `scene` (one point cloud per layer); returns handles drawn."""
        self.remove()
        for i, (k, pts, _) in enumerate(self.layers):
            if not len(pts):
                continue
            self.handles.append(
                scene.add_point_cloud(
                    f"{ROOT}/layer_{k:04d}",
                    pts.astype(np.float32),
                    self.colors(i),
                    point_size=point_size,
                    point_shape="circle",
                )
            )
        return len(self.handles)

    def remove(self) -> None:
        for h in self.handles:
            with suppress(Exception):
                h.remove()
        self.handles = []
