"""Concurrent editing (#25 fault 4): saved graphs and their parameter XML carry a revision (strong
ETag); a PUT with a stale If-Match is 409 with both versions and changes nothing; earlier revisions
are kept."""

import json
import sqlite3

import pytest
from fastapi.testclient import TestClient

import toy_nodes as toy
from waamflow.api.app import create_app
from waamflow.settings import Settings

XML = {"content-type": "application/xml"}


def _settings(tmp_path):
    gdir = tmp_path / "graphs"
    gdir.mkdir(exist_ok=True)
    (gdir / "example.json").write_text(json.dumps(toy.chain(stack={"count": 5})))
    return Settings(data_dir=tmp_path / "data", graphs_dir=gdir, start_viewer=False, static_dir=None, workers=1)


@pytest.fixture()
def client(tmp_path):
    with TestClient(create_app(_settings(tmp_path))) as c:
        yield c


def _recipe(description: str) -> dict:
    r = toy.chain()
    r["description"] = description
    return r


def test_two_sessions_second_save_is_409_with_both_versions(client):
    assert client.put("/api/graphs/shared", json=_recipe("first")).status_code == 201
    a, b = client.get("/api/graphs/shared"), client.get("/api/graphs/shared")
    assert a.headers["etag"] == b.headers["etag"] == '"1"'
    # A saves: revision 2
    r = client.put("/api/graphs/shared", json=_recipe("A's change"), headers={"If-Match": a.headers["etag"]})
    assert r.status_code == 200 and r.headers["etag"] == '"2"' and r.json()["revision"] == 2
    # B saves on revision 1: 409, both versions, nothing changed
    yours = _recipe("B's change")
    r = client.put("/api/graphs/shared", json=yours, headers={"If-Match": b.headers["etag"]})
    assert r.status_code == 409
    d = r.json()["detail"]
    assert d["kind"] == "conflict" and "since" in d["message"]
    assert d["yours"]["description"] == "B's change"
    assert d["theirs"]["revision"] == 2 and d["theirs"]["recipe"]["description"] == "A's change"
    assert r.headers["etag"] == '"2"'
    g = client.get("/api/graphs/shared")
    assert g.json()["description"] == "A's change" and g.headers["etag"] == '"2"'
    # B overwrites knowingly: If-Match their revision
    r = client.put("/api/graphs/shared", json=yours, headers={"If-Match": '"2"'})
    assert r.status_code == 200 and r.headers["etag"] == '"3"'
    assert client.get("/api/graphs/shared").json()["description"] == "B's change"
    # without If-Match: saved as before (scripts, CLI)
    r = client.put("/api/graphs/shared", json=_recipe("script"))
    assert r.status_code == 200 and r.headers["etag"] == '"4"'
    assert client.get("/api/graphs/shared").json()["description"] == "script"
    # If-Match "*" matches any stored revision; a weak or garbage tag never matches
    assert client.put("/api/graphs/shared", json=_recipe("star"), headers={"If-Match": "*"}).status_code == 200
    assert client.put("/api/graphs/shared", json=_recipe("weak"), headers={"If-Match": 'W/"5"'}).status_code == 409
    # If-Match on a graph that does not exist (deleted meanwhile): 409, theirs is null
    r = client.put("/api/graphs/gone", json=_recipe("x"), headers={"If-Match": '"1"'})
    assert r.status_code == 409 and r.json()["detail"]["theirs"] is None
    assert client.get("/api/graphs/gone").status_code == 404


def test_params_xml_same_treatment(client):
    assert client.put("/api/graphs/shared", json=_recipe("r")).status_code == 201
    assert client.get("/api/graphs/shared/params").status_code == 404
    r = client.put("/api/graphs/shared/params", content="<parameters/>", headers=XML)
    assert r.status_code == 204 and r.headers["etag"] == '"1"'
    a, b = client.get("/api/graphs/shared/params"), client.get("/api/graphs/shared/params")
    assert a.headers["etag"] == '"1"' and a.text == "<parameters/>"
    mine = "<parameters><!-- A --></parameters>"
    r = client.put("/api/graphs/shared/params", content=mine, headers={**XML, "If-Match": a.headers["etag"]})
    assert r.status_code == 204 and r.headers["etag"] == '"2"'
    yours = "<parameters><!-- B --></parameters>"
    r = client.put("/api/graphs/shared/params", content=yours, headers={**XML, "If-Match": b.headers["etag"]})
    assert r.status_code == 409
    d = r.json()["detail"]
    assert d["yours"] == yours and d["theirs"] == {"revision": 2, "xml": mine}
    assert client.get("/api/graphs/shared/params").text == mine
    r = client.put("/api/graphs/shared/params", content=yours, headers={**XML, "If-Match": '"2"'})
    assert r.status_code == 204 and r.headers["etag"] == '"3"'
    r = client.put("/api/graphs/shared/params", content="<parameters/>", headers=XML)
    assert r.status_code == 204 and r.headers["etag"] == '"4"'
    # the recipe's revision is its own: saving the XML does not make a recipe save stale
    assert client.get("/api/graphs/shared").headers["etag"] == '"1"'


def test_example_still_read_only(client):
    g = client.get("/api/graphs/example")
    assert g.headers["etag"] == '"1"'
    for headers in ({}, {"If-Match": g.headers["etag"]}):
        r = client.put("/api/graphs/example", json=g.json(), headers=headers)
        assert r.status_code == 409 and "read-only" in r.json()["detail"]["message"]
        r = client.put("/api/graphs/example/params", content="<parameters/>", headers={**XML, **headers})
        assert r.status_code == 409 and "read-only" in r.json()["detail"]["message"]
    assert client.get("/api/graphs/example").headers["etag"] == '"1"'


def test_revisions_are_kept(client):
    for i, desc in enumerate(("one", "two", "three")):
        assert client.put("/api/graphs/hist", json=_recipe(desc)).status_code == (201 if i == 0 else 200)
    revs = client.get("/api/graphs/hist/revisions").json()
    assert [r["revision"] for r in revs] == [3, 2, 1]
    assert all(isinstance(r["time"], float) and "user" in r for r in revs)
    r = client.get("/api/graphs/hist/revisions/2")
    assert r.status_code == 200 and r.json()["description"] == "two" and r.headers["etag"] == '"2"'
    assert client.get("/api/graphs/hist/revisions/9").status_code == 404
    assert client.get("/api/graphs/nope/revisions").status_code == 404
    # a revision number beyond SQLite's integers (schemathesis' stateful phase found the 500): 422
    for path in ("/api/graphs/hist/revisions/99999999999999999999", "/api/graphs/hist/revisions/0"):
        r = client.get(path)
        assert r.status_code == 422 and r.json()["detail"]["field"] == "path.rev", r.text
    assert client.post("/api/graphs/hist/revisions/99999999999999999999/restore").status_code == 422


def test_existing_database_is_migrated(tmp_path):
    """A database written before revisions: its graphs start at revision 1."""
    db = tmp_path / "data" / "waamflow.sqlite"
    db.parent.mkdir(parents=True)
    con = sqlite3.connect(db)
    con.executescript("""CREATE TABLE graphs (name TEXT PRIMARY KEY, recipe TEXT NOT NULL, params_xml TEXT,
                         example INTEGER DEFAULT 0, created REAL NOT NULL, updated REAL NOT NULL);""")
    con.execute(
        "INSERT INTO graphs VALUES (?,?,?,?,?,?)",
        ("old", json.dumps({**_recipe("old"), "name": "old"}), "<parameters/>", 0, 1.0, 1.0),
    )
    con.commit()
    con.close()
    with TestClient(create_app(_settings(tmp_path))) as c:
        g = c.get("/api/graphs/old")
        assert g.status_code == 200 and g.headers["etag"] == '"1"'
        assert c.get("/api/graphs/old/params").headers["etag"] == '"1"'
        r = c.put("/api/graphs/old", json=_recipe("new"), headers={"If-Match": '"1"'})
        assert r.status_code == 200 and r.headers["etag"] == '"2"'


def test_openapi_declares_etag_if_match_and_409(client):
    spec = client.get("/openapi.json").json()
    for path in ("/api/graphs/{name}", "/api/graphs/{name}/params"):
        get, put = spec["paths"][path]["get"], spec["paths"][path]["put"]
        assert "ETag" in get["responses"]["200"]["headers"]
        assert any(p["name"] == "If-Match" and p["in"] == "header" for p in put["parameters"])
        assert "409" in put["responses"]
        ok = put["responses"]["200" if path.endswith("}") else "204"]
        assert "ETag" in ok["headers"]
    conflict = spec["paths"]["/api/graphs/{name}"]["put"]["responses"]["409"]["content"]["application/json"]["schema"]
    assert conflict == {"$ref": "#/components/schemas/ConflictResponse"}
