"""Recipes arriving over REST read only uploaded files and files in the data/graphs folders."""

import os
import sys

import pytest
from fastapi.testclient import TestClient

from waamflow.api.app import create_app
from waamflow.engine import executor
from waamflow.settings import Settings

CUBE_STL = b"""solid c
facet normal 0 0 -1
outer loop
vertex 0 0 0
vertex 0 10 0
vertex 10 0 0
endloop
endfacet
endsolid c
"""


OPENED: list[str] | None = None  # while a list: every path the process opens (audit hook)


def _audit(event, args):
    if OPENED is not None and event == "open" and args and isinstance(args[0], (str, bytes, os.PathLike)):
        OPENED.append(os.fsdecode(args[0]))


sys.addaudithook(_audit)  # cannot be removed; inert while OPENED is None


def mesh_recipe(path):
    return {
        "format": "waamflow/1",
        "name": "m",
        "nodes": [{"id": "part", "type": "mesh", "params": {"path": path}}],
        "edges": [],
    }


@pytest.fixture()
def env(tmp_path, monkeypatch):
    outside = tmp_path / "outside"
    outside.mkdir()
    secret = outside / "secret.stl"
    secret.write_bytes(CUBE_STL)
    gdir = tmp_path / "graphs"
    gdir.mkdir()
    (gdir / "inside.stl").write_bytes(CUBE_STL)
    os.symlink(secret, gdir / "link.stl")
    reads: list[str] = []
    orig = executor.FileResolver.read_bytes

    def spy(self, path, max_bytes=None):
        reads.append(path)
        return orig(self, path, max_bytes)

    monkeypatch.setattr(executor.FileResolver, "read_bytes", spy)
    s = Settings(data_dir=tmp_path / "data", graphs_dir=gdir, start_viewer=False, static_dir=None, workers=1)
    with TestClient(create_app(s)) as c:
        yield c, secret, reads


def test_rest_recipe_cannot_read_outside(env):
    global OPENED
    c, secret, reads = env
    OPENED = []
    control = secret.parent.parent / "graphs" / "inside.stl"
    control.read_bytes()
    assert str(control) in OPENED  # the hook sees opens
    OPENED.clear()
    for path, why in [
        (str(secret), "absolute"),
        ("../outside/secret.stl", "'..'"),
        ("link.stl", "outside"),
        ("file:///etc/passwd", "URL"),
        ("http://example.com/x.stl", "URL"),
        ("sub/../../outside/secret.stl", "'..'"),
        ("C:\\x.stl", "absolute"),
    ]:
        for route, body in [
            ("/api/runs", {"recipe": mesh_recipe(path)}),
            ("/api/preview", {"recipe": mesh_recipe(path), "node": "part", "layer": 0}),
        ]:
            r = c.post(route, json=body)
            assert r.status_code == 422, (path, route, r.text)
            d = r.json()["detail"]
            assert d["kind"] == "outside_sandbox" and d["node"] == "part" and d["field"] == "path", d
            assert why in d["message"], (path, d["message"])
    # the same through a recipe input and through a saved graph
    rec = mesh_recipe("$mesh_file")
    rec["inputs"] = {"mesh_file": "inside.stl"}
    assert c.put("/api/graphs/g", json=rec).status_code == 201
    r = c.post("/api/runs", json={"graph": "g", "inputs": {"mesh_file": str(secret)}})
    assert r.status_code == 422 and r.json()["detail"]["node"] == "part"
    opened, OPENED = OPENED, None
    assert reads == []  # nothing was read: not through the nodes' file resolver,
    outside = (str(secret.parent), str(secret.parent.resolve()))
    assert not [p for p in opened if p.startswith(outside)], opened  # nor opened by anything
    assert c.get("/api/runs").json() == []  # and no run was created


def test_rest_recipe_reads_inside(env):
    c, _, reads = env
    r = c.post("/api/preview", json={"recipe": mesh_recipe("inside.stl"), "node": "part", "layer": 0})
    assert r.status_code in (200, 422) and r.json().get("detail", {}).get("kind") != "outside_sandbox"
    assert "inside.stl" in reads
    # an uploaded file is named by its bare name
    assert c.put("/api/graphs/up", json=mesh_recipe("part.stl")).status_code == 201
    assert c.put("/api/graphs/up/files/part.stl", content=CUBE_STL).status_code == 204
    r = c.post("/api/preview", json={"graph": "up", "recipe": mesh_recipe("part.stl"), "node": "part", "layer": 0})
    assert r.json().get("detail", {}).get("kind") != "outside_sandbox"
    assert "part.stl" in reads
