"""Recipes in the graphs folder that cannot be offered (over the recipe size limit, not a regular
file, not a recipe) are listed with an error marker — name, size, reason — instead of being
skipped silently, and their GET is a 422 naming the limit or the reason (#26)."""

import json
import os

from fastapi.testclient import TestClient

import toy_nodes as toy
from waamflow.api.app import create_app
from waamflow.settings import Settings


def test_unloadable_examples_are_listed_with_the_reason(tmp_path):
    gdir = tmp_path / "graphs"
    gdir.mkdir()
    (gdir / "good.json").write_text(json.dumps(toy.chain(stack={"count": 2})))
    big = toy.chain(stack={"count": 2})
    big["description"] = "x" * 30_000  # a valid recipe of ~30 kB, over a 0.02 MB (20,971 B) limit
    (gdir / "big.json").write_text(json.dumps(big))
    big_size = (gdir / "big.json").stat().st_size
    (gdir / "broken.json").write_text('{"format": "waamflow/1", "nodes": [')
    os.mkfifo(gdir / "pipe.json")
    s = Settings(
        data_dir=tmp_path / "data",
        graphs_dir=gdir,
        start_viewer=False,
        static_dir=None,
        workers=1,
        start_workers=False,
        max_body_mb=0.02,
    )
    with TestClient(create_app(s)) as c:
        listed = {g["name"]: g for g in c.get("/api/graphs").json()}
        assert sorted(listed) == ["big", "broken", "good", "pipe"]
        assert listed["good"]["error"] is None
        err = listed["big"]["error"]
        assert err["size"] == big_size and err["file"] == "big.json"
        assert "over the 0.02 MB recipe limit (max_body_mb)" in err["reason"]
        assert f"{big_size / 2**20:.2f} MB" in err["reason"]
        assert "max_body_mb" in listed["big"]["description"] and listed["big"]["example"] is True
        assert "not valid JSON" in listed["broken"]["error"]["reason"]
        assert listed["broken"]["error"]["size"] == len('{"format": "waamflow/1", "nodes": [')
        assert "not a regular file" in listed["pipe"]["error"]["reason"] and listed["pipe"]["error"]["size"] == 0

        r = c.get("/api/graphs/big")
        assert r.status_code == 422 and r.json()["detail"]["kind"] == "unloadable_example"
        assert "max_body_mb" in r.json()["detail"]["message"] and "big.json" in r.json()["detail"]["message"]
        r = c.get("/api/graphs/pipe")
        assert r.status_code == 422 and "not a regular file" in r.json()["detail"]["message"]
        assert c.get("/api/graphs/good").status_code == 200
        assert c.get("/api/graphs/nothing").status_code == 404
        # saving a recipe under such a name replaces the marker with the saved graph
        assert c.put("/api/graphs/broken", json=toy.chain(stack={"count": 2})).status_code == 201
        listed = {g["name"]: g for g in c.get("/api/graphs").json()}
        assert listed["broken"]["error"] is None and c.get("/api/graphs/broken").status_code == 200
