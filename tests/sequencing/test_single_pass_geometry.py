"""The sequencer never changes what is deposited: it only picks a loop's seam and the order and
direction of sections; re-threading (seams.rethread_path) applies to real serpentines only."""

import math
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import box

from waamflow.core.model import Layer, LayerPaths, SectionPath, as_multipolygon
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.sequencing import sequence_part
from waamflow.sequencing.seams import SeamSpec, entries, rethread_path

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def arc_on_length(sections) -> float:
    """mm welded: the summed length of the arc-ON segments."""
    return float(sum(np.asarray(s.segment_lengths)[np.asarray(s.arc, bool)].sum() for s in sections))


def path(key, strategy, xy, z=30.0, inside=None):
    pts = np.column_stack([np.asarray(xy, float), np.full(len(xy), z)])
    n = len(pts) - 1
    return SectionPath(
        key,
        strategy,
        pts,
        np.ones(n, bool),
        np.ones(n, bool) if inside is None else np.asarray(inside, bool),
        np.full(n, 5.0),
    )


def filleted_l(z=30.0):
    """wall2 of graphs/thin-wall-panel.json with fillet_radius=3 (layer 14): a 7 mm stock lead, a
    43.8 mm leg along x, the corner turned on a 4.6 mm radius in 27 steps of 3.33 deg, 57 mm along y."""
    c = np.array([195.4, 4.6])
    t = np.radians(np.linspace(-90.0, 0.0, 28))
    arc = c + 4.6 * np.column_stack([np.cos(t), np.sin(t)])
    xy = [(150 + 4 * math.sqrt(2), 4 * math.sqrt(2)), (151.6, 0.0), *arc, (200.0, 58.4), (200.0, 61.6)]
    n = len(xy) - 1
    return path("wall2", "wall", xy, z, inside=[False] + [True] * (n - 1))


L_LENGTH = 114.985827  # mm: 6.963 lead + 43.8 + 4.6·π/2 fillet + 57.0


def test_filleted_l_wall_is_one_pass_and_keeps_its_geometry():
    w = filleted_l()
    assert w.length == pytest.approx(L_LENGTH, abs=1e-6)
    assert rethread_path(w) is None  # before: passes [(0, 1), (17, 31)], 138.558 mm
    assert [e.name for e in entries(w)] == ["planned", "reversed"]
    for e in entries(w):
        assert arc_on_length([e.path]) == pytest.approx(L_LENGTH, abs=1e-6)
    layers = [
        LayerPaths(Layer(i, 2.0 * (i + 1), 2.0, as_multipolygon(box(140, -10, 210, 70))), (filleted_l(2.0 * (i + 1)),))
        for i in range(4)
    ]
    out, _ = sequence_part(layers, seam=SeamSpec("auto", 4.0))
    for lp in out:
        s = lp.sections[0]
        assert arc_on_length([s]) == pytest.approx(L_LENGTH, abs=1e-6)
        # the same polyline, one way or the other; ignition in the stock lead
        fwd = np.asarray(filleted_l(lp.layer.z).points)
        assert np.allclose(s.points, fwd) or np.allclose(s.points, fwd[::-1])
        assert not s.inside[0]


def serpentine(link):
    """Two 40 mm passes 6 mm apart along x joined at x = 40 by `link` (points between the passes)."""
    return path("S", "parallel", [(0, 0), (40, 0), *link, (40, 6), (0, 6)], 1.5)


def test_serpentines_are_rethreaded_only_when_that_keeps_the_arc_on_length():
    straight = serpentine([])
    re = rethread_path(straight)
    assert re is not None and re.points[0][:2].tolist() == [40, 0] and re.points[-1][:2].tolist() == [40, 6]
    assert arc_on_length([re]) == pytest.approx(86.0)
    # a semicircular link (8 steps, radius 3 mm): its ends turn gradually and cannot move to x = 0
    half = [(40 + 3 * math.sin(a), 3 - 3 * math.cos(a)) for a in np.radians(np.arange(22.5, 180.0, 22.5))]
    round_ = serpentine(half)
    assert rethread_path(round_) is None  # before: a straight link at x = 0, 88.341 mm
    assert {e.name for e in entries(round_)} == {"planned", "reversed"}
    assert arc_on_length([round_]) == pytest.approx(80.0 + 8 * 6 * math.sin(math.radians(11.25)))  # 89.364 mm
    # passes whose far ends do not line up: the link on the other side would be 7.2 mm, not 6
    skew = path("S", "parallel", [(0, 0), (40, 0), (40, 6), (4, 6)], 1.5)
    assert rethread_path(skew) is None  # before: 83.211 mm against 82.0


def test_thin_wall_panel_with_fillets_sequences_the_walls_it_is_given():
    r = apply_overrides(load_recipe(GRAPHS / "thin-wall-panel.json"), parse_set(["fillet_radius=3"]))
    res = execute(build_graph(r), resolver=FileResolver(GRAPHS), artifacts=False, workers=1, targets=["sequence"])
    walls = [arc_on_length(lp.sections) for lp in res.outputs["walls"]["toolpath"]]
    seq = [arc_on_length(lp.sections) for lp in res.outputs["sequence"]["toolpath"]]
    assert walls == pytest.approx([2166.335] + [1412.334] * 14, abs=1e-3)
    # before: 1459.479 mm on every odd layer (wall2 and wall6 read as two passes and re-threaded)
    assert seq == pytest.approx(walls, abs=1e-6)
