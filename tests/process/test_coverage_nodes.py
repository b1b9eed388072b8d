"""Coverage through the engine, in the strategy comparison and in /api/preview; the contour strategy."""

import json
import math

import numpy as np
import shutil
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from shapely.geometry import Polygon, box

from waamflow.api.app import create_app
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.paths import StrategySpec, plan_section
from waamflow.paths.compare import Job, compare
from waamflow.paths.contour import offset_rings, step_over
from waamflow.process.coverage import section_coverage
from waamflow.settings import Settings

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def test_contour_offsets_and_one_connected_path_on_a_rectangle():
    region = box(0, 0, 43, 21.5)
    spec = StrategySpec(pattern="contour", bead_width=6.0)
    rings = offset_rings(region, 6.0)
    d = step_over(6.0)
    assert d == pytest.approx(0.738 * 6.0)
    # rings at 3, 3 + d, 3 + 2d, ... until the offset vanishes (half width 10.75), then one pass
    # along the 0.64 mm core the last ring's beads leave between them (contour._cores)
    n = math.floor((10.75 - 3.0) / d) + 1
    assert len(rings) == n + 1
    assert all(np.allclose(r[0], r[-1]) for lv in rings[:n] for r in lv)
    (core,) = rings[n]
    assert np.allclose(core[:, 1], 10.75) and np.ptp(core[:, 0]) == pytest.approx(43 - 2 * (3 + d + 3), abs=1e-6)
    p = plan_section(region, None, spec)
    assert p.arc_switches == 2  # nested loops: one arc-ON path
    assert p.outside_length == pytest.approx(0.0, abs=1e-9)
    # the outer loop is the 37 x 15.5 rectangle
    assert p.length > 2 * (37 + 15.5)


def test_contour_follows_holes_and_splits_into_few_paths():
    region = Polygon([(0, 0), (60, 0), (60, 15), (15, 15), (15, 50), (0, 50)]).difference(box(30, 3, 40, 10))
    p = plan_section(region, None, StrategySpec(pattern="contour", bead_width=4.0))
    cov = section_coverage(region, p.points, p.arc, 4.0)
    assert cov.over_deposit_area == pytest.approx(0.0, abs=1e-6)  # offsets keep the beads inside
    assert cov.void_area < 0.1 * region.area
    assert p.arc_switches <= 6


def test_compare_reports_coverage_per_pattern():
    region = box(0, 0, 43, 21.5)
    spec = StrategySpec(bead_width=4.43, spacing=4.43)
    rows = {r["label"]: r for r in compare([Job(region, None, spec, 40.0)], ["raster", "contour", "spiral"])}
    for r in rows.values():
        assert r["region_area_mm2"] == pytest.approx(43 * 21.5)
        assert 0 <= r["void_area_mm2"] < r["region_area_mm2"]
    # raster: 5 passes of 4.43 mm spaced 4.43 with 1.89 mm margins → the beads reach past the edges
    assert rows["raster"]["void_area_mm2"] == pytest.approx(0.0, abs=1e-6)
    # contour keeps every bead inside: no over-deposit, but voids in the corners of the rings
    assert rows["contour"]["over_deposit_area_mm2"] == pytest.approx(0.0, abs=1e-6)
    assert rows["contour"]["void_area_mm2"] > 0


def _cross_with_coverage():
    recipe = json.loads((GRAPHS / "mpp-cross.json").read_text())
    recipe["nodes"].append({"id": "cov", "type": "coverage", "params": {"bead_width": 6.0}})
    recipe["edges"] += [
        {"from": "zone.toolpath", "to": "cov.toolpath"},
        {"from": "guide.sections", "to": "cov.sections"},
    ]
    return recipe


def test_coverage_node_on_the_cross():
    res = execute(build_graph(parse_recipe(_cross_with_coverage())), resolver=FileResolver(GRAPHS))
    cov = json.loads(res.artifacts["cov.coverage.json"])
    assert len(cov["layers"]) == 8 and all(len(l["sections"]) == 3 for l in cov["layers"])
    tot = cov["total"]
    assert tot["region_area_mm2"] == pytest.approx(
        sum(r["region_area_mm2"] for l in cov["layers"] for r in l["sections"]), abs=0.01
    )
    row = cov["layers"][0]["sections"][0]
    void = sum(Polygon(p["exterior"], p["holes"]).area for p in row["void"])
    assert void == pytest.approx(row["void_area_mm2"], rel=1e-3)
    assert 0 < tot["void_share"] < 0.2


def test_preview_returns_coverage(tmp_path):
    gdir = tmp_path / "graphs"
    shutil.copytree(GRAPHS, gdir)
    s = Settings(data_dir=tmp_path / "data", graphs_dir=gdir, start_viewer=False, static_dir=None, workers=1)
    with TestClient(create_app(s)) as c:
        body = c.post(
            "/api/preview",
            json={"recipe": _cross_with_coverage(), "graph": "mpp-cross", "node": "zone", "layer": 2, "coverage": True},
        ).json()
    assert [r["key"] for r in body["coverage"]] == [p["key"] for p in body["paths"]]
    assert all(r["bead_width_mm"] == 6.0 and r["void_area_mm2"] >= 0 for r in body["coverage"])
