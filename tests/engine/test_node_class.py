"""engine.node.node_class: a recipe's node types load only the node modules that declare them."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from waamflow.core.errors import RecipeError
from waamflow.engine import node as node_mod
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe

ROOT = Path(__file__).resolve().parents[2]


def test_the_source_scan_places_every_shipped_node_type_in_its_module():
    registry = node_mod.load_nodes()
    shipped = {t: c.__module__ for t, c in registry.items() if c.__module__.startswith("waamflow.nodes.")}
    assert len(shipped) >= 23  # graph types of the catalog (mesh … calibrate-robot)
    assert {t: m for t, m in node_mod._declaring_modules().items() if t in shipped} == shipped
    assert set(node_mod._declaring_modules()) == set(shipped)


def test_building_the_bracket_imports_only_the_node_modules_it_uses():
    code = (
        "import sys, json\n"
        "from pathlib import Path\n"
        "from waamflow.engine.graph import build_graph\n"
        "from waamflow.engine.recipe import load_recipe\n"
        "g = build_graph(load_recipe(Path('graphs/bracket.json')))\n"
        "print(json.dumps([sorted(m for m in sys.modules if m.startswith('waamflow.') or m in ('ssl', 'urllib.request')), g.order]))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    mods, order = json.loads(out.stdout)
    assert order == ["part", "layers", "mask", "guide", "strategy", "zone", "sequence", "post"]
    nodes = sorted(m.rsplit(".", 1)[1] for m in mods if m.startswith("waamflow.nodes."))
    assert nodes == ["inputs", "mpp", "post", "post_settings", "robotparams", "sequence", "slicing", "strategy"]
    assert "ssl" not in mods and "urllib.request" not in mods  # xml.sax.saxutils brought them (paths/compare)
    for heavy in (
        "waamflow.nodes.robot",
        "waamflow.trajectory.run",
        "waamflow.trajectory.compensate",
        "waamflow.curved.fan",
    ):
        assert heavy not in mods


def _one_node(type_id: str) -> dict:
    return {"format": "waamflow/1", "name": "t", "nodes": [{"id": "n", "type": type_id, "params": {}}], "edges": []}


def test_an_unknown_type_is_still_named_and_a_type_the_scan_misses_is_still_found(monkeypatch):
    with pytest.raises(RecipeError, match="unknown node type 'no-such-node'") as e:
        build_graph(parse_recipe(_one_node("no-such-node")))
    assert e.value.node == "n"
    # the scan found nothing (e.g. modules shipped without sources): every module is imported
    cls = node_mod.REGISTRY["rectangle"]
    monkeypatch.delitem(node_mod.REGISTRY, "rectangle")
    monkeypatch.setattr(node_mod, "_DECLARED", {"-": "-"})
    loaded = []

    def load_all():
        loaded.append(1)
        node_mod.REGISTRY["rectangle"] = cls  # what importing its module registers
        return node_mod.REGISTRY

    monkeypatch.setattr(node_mod, "load_nodes", load_all)
    assert node_mod.node_class("rectangle") is cls and loaded == [1]
    assert node_mod.node_class("rectangle") is cls and loaded == [1]  # registered: no second load


def test_svg_text_is_escaped_as_saxutils_did():
    from xml.sax.saxutils import escape as sax_escape

    from waamflow.paths.compare import escape

    for text in ["a&b<c>d", "&amp;", "\"q\" 'x'", "", "<<>>&&", "mm³/s ≤ 5", "window/L"]:
        assert escape(text) == sax_escape(text)
    assert escape("<a & b>") == "&lt;a &amp; b&gt;"
