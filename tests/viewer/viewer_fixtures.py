"""Hand-made values for viewer tests: a rectangle raster part, its sections, toolpath and a
simulated trace, built directly from the core model (no other engineer's kernels)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from shapely.geometry import LineString, MultiPolygon, box

from waamflow.core.model import Layer, LayerPaths, LayerSections, Layered, MeshData, Section, SectionPath

LENGTH, WIDTH, H = 43.0, 21.5, 1.5  # mm: the rectangle study's objective, 1.5 mm layers
ZONE_COLORS = {"start": "#00ff00", "z1": "#0000ff", "end": "#ff0000"}


def make_layers(n: int) -> Layered:
    region = MultiPolygon([box(0, 0, LENGTH, WIDTH)])
    return Layered(tuple(Layer(i, H * (i + 1), H, region) for i in range(n)))


def make_sections(layers: Layered) -> Layered:
    items = []
    for layer in layers:
        left = Section("bs1/A", box(0, 0, LENGTH / 2, WIDTH), 0, LineString([(0, WIDTH / 2), (LENGTH / 2, WIDTH / 2)]))
        right = Section("bs1/B", box(LENGTH / 2, 0, LENGTH, WIDTH), 1)
        items.append(LayerSections(layer, (left, right)))
    return Layered(tuple(items))


def raster(x0: float, x1: float, z: float, passes: int, pts_per_pass: int = 10) -> np.ndarray:
    """Boustrophedon passes along x at y = 2, 6, 10, ... (4 mm spacing), (n, 3) mm."""
    rows = []
    for k in range(passes):
        xs = np.linspace(x0, x1, pts_per_pass)
        rows.append(
            np.column_stack(
                [xs if k % 2 == 0 else xs[::-1], np.full(pts_per_pass, 2 + 4 * k), np.full(pts_per_pass, z)]
            )
        )
    return np.vstack(rows)


def section_path(key: str, pts: np.ndarray, speed: float = 10.0) -> SectionPath:
    n = len(pts) - 1
    third = max(n // 3, 1)
    zone = tuple("start" if i < third else ("end" if i >= n - third else "z1") for i in range(n))
    arc = np.ones(n, bool)
    arc[n // 2] = False  # one arc-OFF link in the middle
    spd = np.linspace(speed, 2 * speed, n)
    return SectionPath(key, "raster", pts, arc, arc.copy(), spd, zone, dict(ZONE_COLORS))


def make_toolpath(layers: Layered, pts_per_pass: int = 10, passes: int = 5) -> Layered:
    items = []
    for layer in layers:
        a = section_path("bs1/A", raster(1, LENGTH / 2 - 1, layer.z, passes, pts_per_pass))
        b = section_path("bs1/B", raster(LENGTH / 2 + 1, LENGTH - 1, layer.z, passes, pts_per_pass))
        items.append(LayerPaths(layer, (a, b)))
    return Layered(tuple(items))


@dataclass(frozen=True, eq=False)
class FakeSimulation:
    """Duck-typed like waamflow.trajectory's result: trace dict, programmed (n, 3), metrics."""

    trace: dict
    programmed: np.ndarray
    metrics: dict = field(default_factory=dict)
    corners: dict = field(default_factory=dict)


def make_simulation(toolpath: Layered, cut: float = 0.3) -> FakeSimulation:
    """A trace that follows the programmed points with a `cut` mm offset in y (a stand-in for
    corner cutting), 1 sample per programmed point, 0.1 s apart."""
    pts, lay, sec = [], [], []
    for lp in toolpath:
        for s_idx, sp in enumerate(lp.sections):
            pts.append(sp.points)
            lay.append(np.full(len(sp.points), lp.index))
            sec.append(np.full(len(sp.points), s_idx))
    prog = np.vstack(pts)
    n = len(prog)
    sim = prog + np.array([0.0, cut, 0.0])
    trace = {
        "t": np.arange(n) * 0.1,
        "x": sim[:, 0],
        "y": sim[:, 1],
        "z": sim[:, 2],
        "speed": np.linspace(5, 15, n),
        "arc": np.ones(n, bool),
        "deviation": np.full(n, cut),
        "s": np.arange(n, dtype=float),
        "layer": np.concatenate(lay),
        "section": np.concatenate(sec),
    }
    return FakeSimulation(trace, prog, {"max_deviation_mm": cut})


def make_mesh() -> MeshData:
    v = np.array([[x, y, z] for z in (0, 12) for y in (0, WIDTH) for x in (0, LENGTH)], float)
    f = np.array(
        [
            [0, 1, 3],
            [0, 3, 2],
            [4, 6, 7],
            [4, 7, 5],
            [0, 4, 5],
            [0, 5, 1],
            [2, 3, 7],
            [2, 7, 6],
            [0, 2, 6],
            [0, 6, 4],
            [1, 5, 7],
            [1, 7, 3],
        ]
    )
    return MeshData(v, f, "block")


RECIPE = {
    "format": "waamflow/1",
    "name": "viewer-test",
    "nodes": [
        {"id": "part", "type": "mesh"},
        {"id": "layers", "type": "slice"},
        {"id": "mask", "type": "mask"},
        {"id": "zone", "type": "zone"},
        {"id": "simulate", "type": "simulate-robot"},
    ],
}


def outputs(n_layers: int = 8):
    layers = make_layers(n_layers)
    sections = make_sections(layers)
    tp = make_toolpath(layers)
    return {
        "part": {"mesh": make_mesh()},
        "layers": {"layers": layers},
        "mask": {"sections": sections},
        "zone": {"toolpath": tp},
        "simulate": {"simulation": make_simulation(tp)},
    }
