"""The contract, exactly (#26 fault 10): XML past the parser's limits is a 422 (was 500), every
405 carries the `Allow` of its path as the schema declares it, a schema-valid run request is
accepted and `{}` is schema-invalid, HEAD answers on an artifact, DELETE of a run is a cancel that
keeps the run readable."""

import jsonschema_rs
import pytest
from fastapi.testclient import TestClient

import toy_nodes as toy
from api_util import wait_for_run
from waamflow.api.app import create_app
from waamflow.settings import Settings

DEEP = "<parameters>" + "<a>" * 100_000 + "</a>" * 100_000 + "</parameters>"
HUGE_ATTR = '<parameters><layer index="0" z="' + "1" * 19_000_000 + '"/></parameters>'
METHODS = ("GET", "PUT", "POST", "DELETE", "PATCH")


@pytest.fixture(scope="module")
def c(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("exact")
    s = Settings(data_dir=tmp / "data", graphs_dir=tmp / "none", start_viewer=False, static_dir=None, workers=1)
    with TestClient(create_app(s)) as client:
        assert client.put("/api/graphs/g", json=toy.chain()).status_code == 201
        yield client


@pytest.mark.parametrize("xml", [DEEP, HUGE_ATTR], ids=["100k-deep", "19MB-attribute"])
def test_xml_past_the_parser_limits_is_422(c, xml):
    r = c.put("/api/graphs/g/params", content=xml)
    assert r.status_code == 422, r.text[:300]
    d = r.json()["detail"]
    assert d["kind"] == "invalid_input" and "line 1" in d["message"] and "256 levels" in d["message"], d
    assert "XML_PARSE_HUGE" not in d["message"]
    runs = len(c.get("/api/runs").json())
    r = c.post("/api/runs", json={"graph": "g", "params_xml": xml})
    assert r.status_code == 422 and r.json()["detail"]["kind"] == "invalid_input"
    assert len(c.get("/api/runs").json()) == runs  # refused before a run existed


def test_every_405_names_the_declared_methods(c):
    spec = c.get("/openapi.json").json()
    rid = c.post("/api/runs", json={"graph": "g"}).json()["id"]
    wait_for_run(c, rid)
    values = {"name": "g", "run_id": rid, "filename": "f.stl", "rev": "1", "build_id": "b1"}
    checked = 0
    for template, ops in spec["paths"].items():
        url = template
        for k, v in values.items():
            url = url.replace("{" + k + "}", v)
        if "{" in url:
            url = url.replace("{name}", "x")
        declared = sorted(m.upper() for m in ops)
        for m in METHODS:
            if m.lower() in ops:
                continue
            r = c.request(m, url)
            assert r.status_code == 405, (m, url, r.status_code)
            assert r.headers["allow"] == ", ".join(declared), (m, template, r.headers.get("allow"))
            assert r.json()["detail"]["kind"] == "method_not_allowed"
            checked += 1
    assert checked >= 60, checked


def test_run_request_schema_says_graph_or_recipe(c):
    spec = c.get("/openapi.json").json()
    schema = {**spec["components"]["schemas"]["RunRequest"], "components": spec["components"]}
    v = jsonschema_rs.validator_for(schema)
    assert not v.is_valid({}) and not v.is_valid({"inputs": {"a": 1}}) and not v.is_valid({"graph": None})
    assert v.is_valid({"graph": "g"}) and v.is_valid({"recipe": toy.chain()})
    assert c.post("/api/runs", json={}).status_code == 422
    assert c.post("/api/runs", json={"graph": "g"}).status_code == 202


def test_head_artifact_and_delete_keeps_the_run(c):
    rid = c.post("/api/runs", json={"graph": "g"}).json()["id"]
    assert wait_for_run(c, rid)["status"] == "done"
    arts = c.get(f"/api/runs/{rid}/artifacts").json()
    name = arts[0]["name"]
    got = c.get(f"/api/runs/{rid}/artifacts/{name}")
    head = c.head(f"/api/runs/{rid}/artifacts/{name}")
    assert head.status_code == 200 and head.content == b""
    assert int(head.headers["content-length"]) == len(got.content) == arts[0]["size"]
    assert head.headers["content-type"] == got.headers["content-type"]
    assert c.head(f"/api/runs/{rid}/artifacts/nope.json").status_code == 404
    # DELETE is the contract's cancel: a finished run is left as it is and stays readable
    r = c.delete(f"/api/runs/{rid}")
    assert r.status_code == 202 and r.json()["status"] == "done"
    assert c.get(f"/api/runs/{rid}").json()["status"] == "done"
    assert [a["name"] for a in c.get(f"/api/runs/{rid}/artifacts").json()] == [a["name"] for a in arts]
