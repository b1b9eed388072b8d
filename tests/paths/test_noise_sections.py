"""A section far smaller than a bead is slicing noise: it is left out with a warning, never planned.
PrusaSlicer's resources/data/printer_gantries/prusa3d_ht90_actuator.stl read in cm (a 0.87 m part),
contour, 5 mm beads: layer 83 held two slivers of 0.0021 and 0.0015 mm² (mesh noise, above the
slicer's 0.001 mm² floor), and contour stopped the run on the second ("the path has zero length")
while every other pattern welded a 0.1 mm bead there."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely import affinity
from shapely.geometry import MultiPolygon, box

from waamflow.core.model import Layer, LayerSections, Section
from waamflow.engine.node import load_nodes
from waamflow.nodes.strategy import NOISE_WIDTHS2
from waamflow.paths import PATTERNS

# the second sliver of that layer, as the slicer cut it (mm)
SLIVER = shapely.from_wkt(
    "POLYGON ((222.38283665693055 -310.1524106050191, 222.37733412343837 -310.2790330391377, 222.40001678466797 -310.40000915527344, 222.35843012596303 -310.1782101166923, 222.38283665693055 -310.1524106050191))"
)
SQUARE = box(200.0, -300.0, 240.0, -260.0)


class _Ctx:
    def __init__(self) -> None:
        self.warnings: list[tuple[str, int | None, str | None]] = []
        self.reports: list[dict] = []

    def warn(self, message, layer=None, section=None, **_kw) -> None:
        self.warnings.append((message, layer, section))

    def report(self, data) -> None:
        self.reports.append(data)


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
def test_a_sliver_section_is_left_out_with_a_warning(pattern):
    assert SLIVER.area == pytest.approx(0.00147, abs=1e-5)
    strategy = load_nodes()["strategy"]
    params = strategy.Params.model_validate({"default": {"pattern": pattern, "bead_width": 5, "spacing": 4}})
    node, ctx, outs = strategy(), _Ctx(), []
    for index, sliver in ((83, SLIVER), (84, affinity.translate(SLIVER, 1.0)), (90, SLIVER)):
        layer = Layer(index=index, z=2.0 * index, thickness=2.0, region=MultiPolygon([SQUARE, sliver]))
        sections = (Section("region0", SQUARE), Section("region4", sliver, order=1))
        out = node.run_layer(ctx, params, index, {"sections": LayerSections(layer, sections)})
        assert [sp.key for sp in out["toolpath"].sections] == ["region0"]
        outs.append(out["toolpath"])
    assert ctx.warnings == [] or all(w[2] != "region4" for w in ctx.warnings)  # none per layer
    node.combine(ctx, params, {"toolpath": outs}, {"sections": None})
    (noise,) = [w for w in ctx.warnings if "slicing noise" in w[0]]  # one for the part
    assert noise[1:] == (83, "region4")
    assert "3 sections on 3 layers (83-84, 90)" in noise[0] and "0.0015 mm²" in noise[0]
    (report,) = ctx.reports
    assert report["cover"]["sections_left_out"] == 3


def test_the_noise_floor_is_a_share_of_the_bead_and_a_pin_is_welded():
    """A 2 x 2 mm pin (16 % of a 5 mm bead's square) is a feature: one bead on it."""
    assert NOISE_WIDTHS2 <= 0.01
    strategy = load_nodes()["strategy"]
    params = strategy.Params.model_validate({"default": {"pattern": "contour", "bead_width": 5, "spacing": 4}})
    pin = box(0, 0, 2, 2)
    layer = Layer(index=0, z=2.0, thickness=2.0, region=MultiPolygon([pin]))
    ctx = _Ctx()
    out = strategy().run_layer(ctx, params, 0, {"sections": LayerSections(layer, (Section("region0", pin),))})
    (sp,) = out["toolpath"].sections
    assert len(sp.points) >= 2 and float(np.ptp(np.asarray(sp.points)[:, :2], axis=0).max()) > 0
    assert ctx.warnings == [] or all("left out" not in w[0] for w in ctx.warnings)
