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
