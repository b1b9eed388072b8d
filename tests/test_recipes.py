"""Every recipe shipped in graphs/ runs as shipped with `waamflow run` (compas_slicer's test_examples)."""

import json
from pathlib import Path

import pytest

from waamflow.cli import main

GRAPHS = Path(__file__).resolve().parents[1] / "graphs"
RECIPES = sorted(GRAPHS.glob("*.json"))


@pytest.mark.parametrize("recipe", RECIPES, ids=[p.stem for p in RECIPES])
def test_recipe_runs_as_shipped(recipe, tmp_path, monkeypatch):
    monkeypatch.setenv("WAAMFLOW_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "out"
    assert main(["run", str(recipe), "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "done"
    data = json.loads(recipe.read_text())
    assert summary["recipe"] == data["name"]
    assert set(summary["nodes"]) == {n["id"] for n in data["nodes"]}
    # every node produced its artifacts and nothing is left half-written
    assert not list(tmp_path.glob(".out.partial-*"))
    # issue 22: every shipped example passes its own preflight, with every figure in its band
    pf = json.loads((out / "preflight.json").read_text())
    assert summary["preflight"]["verdict"] == pf["verdict"] == "ok", pf["problems"]
    for prog in pf["programs"]:
        assert prog["top_gap_mm"] is not None and prog["top_gap_mm"] <= 0.5 * prog["layer_height_mm"] + 1e-6
        assert prog["uncovered_share"] <= 0.02
        assert prog["weld_data_missing"] in (0, None)
        assert prog["outside_mm"] == 0.0  # no weld clear of the part beyond a run end's stock
        if prog["wire_part_volume_ratio"] is not None:
            assert 0.9 <= prog["wire_part_volume_ratio"] <= 1.2


def test_required_example_recipes_present():
    names = {p.stem for p in RECIPES}
    assert {"mpp-cross", "rectangle-study"} <= names


def test_rerun_after_downstream_change_reports_upstream_cached(tmp_path, monkeypatch, capsys):
    """Issue 2: change one downstream parameter → upstream nodes cached in summary.json and events."""
    monkeypatch.setenv("WAAMFLOW_CACHE", str(tmp_path / "cache"))
    recipe = GRAPHS / "mpp-cross.json"
    out = tmp_path / "out"
    assert main(["run", str(recipe), "--out", str(out)]) == 0
    assert main(["run", str(recipe), "--out", str(out), "--set", "format=krl", "-v"]) == 0
    nodes = json.loads((out / "summary.json").read_text())["nodes"]
    assert [n for n, s in nodes.items() if not s["cached"]] == ["post"]
    assert nodes["zone"]["layers_cached"] == 8 and nodes["zone"]["layers_computed"] == 0
    assert (out / "post.src").is_file() and not (out / "post.gcode").exists()
    err = capsys.readouterr().err
    assert "  layers (slice): cached" in err and "  mask (mask): cached" in err
    # one section's zoning changed: the zone node recomputes, mesh → strategy stay cached
    assert main(["run", str(recipe), "--out", str(out), "--set", "zone.sections.bs1/A.end_length=12"]) == 0
    nodes = json.loads((out / "summary.json").read_text())["nodes"]
    assert all(nodes[n]["cached"] for n in ("part", "layers", "mask", "guide", "strategy"))
    assert nodes["zone"]["layers_computed"] == 8
