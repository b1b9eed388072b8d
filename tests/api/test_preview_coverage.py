"""The live coverage overlay (/api/preview) gives the coverage node's own figures (#27 item 3): same
bead width ($input references, the bead model, per-section widths), same void and overlap."""

import json
import shutil
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from waamflow.api.app import create_app
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe
from waamflow.settings import Settings

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture()
def client(tmp_path):
    g = tmp_path / "graphs"
    g.mkdir()
    shutil.copy(ROOT / "graphs" / "bead-trials.json", g / "bead-trials.json")
    shutil.copytree(ROOT / "graphs" / "parts", g / "parts")
    shutil.copytree(ROOT / "graphs" / "trials", g / "trials")
    s = Settings(data_dir=tmp_path / "data", graphs_dir=g, start_viewer=False, static_dir=None, workers=1)
    with TestClient(create_app(s)) as c:
        yield c


def _node_rows(overrides, layer):
    recipe = apply_overrides(load_recipe(ROOT / "graphs" / "bead-trials.json"), overrides)
    out = execute(
        build_graph(recipe),
        resolver=FileResolver(ROOT / "graphs"),
        targets=["coverage"],
        artifacts=False,
        preflight=False,
    )
    return {r["key"]: r for r in out.outputs["coverage"]["coverage"].items[layer]["sections"]}


@pytest.mark.parametrize("width", [5.0, 7.0])
def test_preview_coverage_is_the_coverage_node(client, width):
    inputs = {"width": width, "layers": 2}
    node = _node_rows(list(inputs.items()), 1)
    recipe = json.loads((ROOT / "graphs" / "bead-trials.json").read_text())
    r = client.post(
        "/api/preview",
        json={"graph": "bead-trials", "recipe": recipe, "node": "fill", "layer": 1, "coverage": True, "inputs": inputs},
    )
    assert r.status_code == 200, r.text
    rows = {c["key"]: c for c in r.json()["coverage"]}
    assert set(rows) == set(node) and len(rows) == 3
    for key, want in node.items():
        got = rows[key]
        # the bead model's width at each zone's feed and speed, not the recipe's `width` or a 6 mm default
        assert got["bead_width_mm"] == pytest.approx(want["bead_width_mm"], abs=1e-9), key
        assert got["void_area_mm2"] == pytest.approx(want["void_area_mm2"], abs=1e-6), key
        assert got["overlap_area_mm2"] == pytest.approx(want["overlap_area_mm2"], abs=1e-6), key
    # an explicit bead_width in the request still wins (the canvas's "what if" width)
    r = client.post(
        "/api/preview",
        json={
            "graph": "bead-trials",
            "recipe": recipe,
            "node": "fill",
            "layer": 1,
            "coverage": True,
            "inputs": inputs,
            "bead_width": 9.0,
        },
    )
    assert {c["bead_width_mm"] for c in r.json()["coverage"]} == {9.0}


def test_a_sections_overlay_is_computed_once_per_exact_input(monkeypatch):
    """The canvas's coverage overlay of a section whose region, path and width did not change (the
    other sections of the layer after an edit of one) comes from the memo; any change recomputes."""
    import numpy as np
    from shapely.geometry import box

    import waamflow.process.coverage as coverage
    from waamflow.api.routes import preview

    calls = []
    real = coverage.section_coverage

    def counting(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(coverage, "section_coverage", counting)
    preview._COVERAGE.clear()
    region = box(0, 0, 40, 20)
    pts = np.array([[0.0, 3.0], [40.0, 3.0], [40.0, 8.0], [0.0, 8.0], [0.0, 13.0], [40.0, 13.0]])
    arc = np.array([True, False, True, False, True])
    first = preview._section_coverage_json(region, pts, arc, 6.0)
    assert len(calls) == 1 and first["void"] and first["overlap"]
    assert first["region_area_mm2"] == pytest.approx(800.0) and first["bead_width_mm"] == 6.0
    assert preview._section_coverage_json(region, pts.copy(), arc.copy(), 6.0) == first and len(calls) == 1
    moved = pts.copy()
    moved[2, 1] += 1e-9
    for args in ((region, moved, arc, 6.0), (region, pts, arc, 6.5), (box(0, 0, 40, 21), pts, arc, 6.0)):
        got = preview._section_coverage_json(*args)
        want = real(args[0], args[1], args[2], args[3])
        assert got["void_area_mm2"] == round(want.void_area, 4)
    assert len(calls) == 4
    on = arc.copy()
    on[1] = True
    assert preview._section_coverage_json(region, pts, on, 6.0)["overlap_area_mm2"] != first["overlap_area_mm2"]
    assert len(calls) == 5
