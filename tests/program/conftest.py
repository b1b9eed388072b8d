"""Hand-built toolpaths for the post-processor tests: several layers, sections, zones."""

from __future__ import annotations

import numpy as np
import pytest

from waamflow.core.model import Layer, LayerPaths, Layered, SectionPath

ZONE_PARAMS = {
    "start": {"current": 220.0, "voltage": 21.0, "wire_feed_speed": 11.0, "travel_speed": 5.0, "dwell": 0.8, "job": 12},
    "z1": {"current": 200.0, "voltage": 20.0, "wire_feed_speed": 10.0, "travel_speed": 6.0},
    "end": {"current": 180.0, "voltage": 19.0, "wire_feed_speed": 8.5, "travel_speed": 7.0},
}
SPEED = {"start": 5.0, "z1": 6.0, "end": 7.0}


def _zoned(key: str, pts: np.ndarray, arc: np.ndarray | None = None, approach=None) -> SectionPath:
    """A section path whose segments are split into start / z1 / end zones by thirds."""
    n = len(pts) - 1
    zone = tuple("start" if i < n // 3 else ("z1" if i < 2 * n // 3 else "end") for i in range(n))
    return SectionPath(
        key=key,
        strategy="test",
        points=pts,
        arc=np.ones(n, bool) if arc is None else arc,
        inside=np.ones(n, bool),
        speed=np.array([SPEED[z] for z in zone]),
        zone=zone,
        zone_colors={"start": "#ff0000", "z1": "#00ff00", "end": "#0000ff"},
        zone_params={k: dict(v) for k, v in ZONE_PARAMS.items()},
        approach=approach,
    )


def wall(z: float) -> np.ndarray:
    """Straight wall along x, 40 mm, 9 points."""
    x = np.linspace(0.0, 40.0, 9)
    return np.column_stack([x, np.full_like(x, 0.0), np.full_like(x, z)])


def half_ring(z: float, r: float = 15.0, n: int = 25) -> np.ndarray:
    """Semicircle centre (20, 30), radius r, counter-clockwise from angle -90° to 90°, n points."""
    a = np.linspace(-np.pi / 2, np.pi / 2, n)
    return np.column_stack([20 + r * np.cos(a), 30 + r * np.sin(a), np.full(n, z)])


def zigzag(z: float) -> np.ndarray:
    """Raster of 3 passes (30 mm) joined by 4 mm links: 12 points, links arc OFF."""
    pts = []
    for k in range(3):
        y = 60.0 + 4.0 * k
        xs = (0.0, 10.0, 20.0, 30.0) if k % 2 == 0 else (30.0, 20.0, 10.0, 0.0)
        pts += [(x, y, z) for x in xs]
    return np.array(pts)


def build_toolpath(n_layers: int = 3, dwell: float = 20.0) -> Layered:
    layers = []
    for i in range(n_layers):
        z = 1.5 * (i + 1)
        layer = Layer(index=i, z=z, thickness=1.5)
        zz = zigzag(z)
        arc = np.ones(len(zz) - 1, bool)
        arc[[3, 7]] = False  # the links between passes
        sections = (
            _zoned("bs1/A", wall(z)),
            _zoned("bs1/B", half_ring(z), approach=np.array([[20.0, 15.0, z + 10.0]])),
            _zoned("bs1/C", zz, arc=arc),
        )
        layers.append(LayerPaths(layer=layer, sections=sections, dwell_after_s=dwell))
    return Layered(tuple(layers))


@pytest.fixture
def toolpath() -> Layered:
    return build_toolpath()


class PostCtx:
    """The context a post-process node's run and artifacts get in these tests: its id and the
    warnings' messages."""

    node_id = "post"

    def __init__(self):
        self.warnings = []

    def warn(self, message, *, layer=None, section=None):
        self.warnings.append(message)
