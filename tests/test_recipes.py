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


def test_required_example_recipes_present():
    names = {p.stem for p in RECIPES}
    assert {"mpp-cross", "rectangle-study"} <= names
