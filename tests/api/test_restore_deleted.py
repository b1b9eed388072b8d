"""What an admin's restore of a deleted graph brings back (#26 Build 4): the chosen revision of the
recipe as a new revision, the graph's owner as it was when deleted (not whoever saved that
revision), the whole recipe history, and the parameter XML as last saved with its history.
Uploaded files are not kept after a delete (a delete frees their space, even on a full disk): the
restore says so in its `problems` and the file list is empty."""

import json

import pytest
from fastapi.testclient import TestClient

import toy_nodes as toy
from waamflow.api.app import create_app
from waamflow.settings import Settings

ALICE = "alice-token-abcdefghijkl"
ROOT = "root-token-abcdefghijklm"
XML1 = '<?xml version="1.0"?><parameters></parameters>'
XML2 = '<?xml version="1.0"?>\n<parameters><!-- second --></parameters>'


@pytest.fixture()
def c(tmp_path):
    tf = tmp_path / "tokens.json"
    tf.write_text(json.dumps({"alice": {"token": ALICE, "role": "editor"}, "root": {"token": ROOT, "role": "admin"}}))
    tf.chmod(0o600)
    s = Settings(
        data_dir=tmp_path / "data",
        graphs_dir=None,
        start_viewer=False,
        static_dir=None,
        workers=1,
        start_workers=False,
        token_file=tf,
    )
    with TestClient(create_app(s)) as client:
        yield client


A = {"Authorization": f"Bearer {ALICE}"}
R = {"Authorization": f"Bearer {ROOT}"}
XMLH = {"Content-Type": "application/xml"}


def test_restore_of_a_deleted_graph_brings_back_recipe_owner_history_and_params(c):
    assert c.put("/api/graphs/g", json=toy.chain(stack={"count": 3}), headers=A).status_code == 201
    assert c.put("/api/graphs/g/params", content=XML1, headers={**A, **XMLH}).status_code == 204
    assert c.put("/api/graphs/g/params", content=XML2, headers={**A, **XMLH}).status_code == 204
    assert c.put("/api/graphs/g/files/part.stl", content=b"solid x", headers=A).status_code == 204
    # an admin saves revision 2 of alice's graph: she stays its owner
    assert c.put("/api/graphs/g", json=toy.chain(stack={"count": 5}), headers=R).status_code == 200
    assert c.delete("/api/graphs/g", headers=A).status_code == 204
    assert c.get("/api/graphs/g", headers=A).status_code == 404

    r = c.post("/api/graphs/g/revisions/2/restore", headers=R)
    assert r.status_code == 201 and r.json()["revision"] == 3
    assert [p["kind"] for p in r.json()["problems"]] == ["not_restored"]
    assert "part.stl" in r.json()["problems"][0]["message"]
    assert c.get("/api/graphs/g", headers=A).json()["nodes"][0]["params"] == {"count": 5}
    listed = {g["name"]: g for g in c.get("/api/graphs", headers=A).json()}
    assert listed["g"]["owner"] == "alice" and listed["g"]["has_params"] is True
    # the owner changes her graph again (an editor changes only her own)
    assert c.put("/api/graphs/g", json=toy.chain(stack={"count": 6}), headers=A).status_code == 200
    assert [(v["revision"], v["user"]) for v in c.get("/api/graphs/g/revisions", headers=A).json()] == [
        (4, "alice"),
        (3, "root"),
        (2, "root"),
        (1, "alice"),
    ]
    p = c.get("/api/graphs/g/params", headers=A)
    assert p.status_code == 200 and p.text == XML2 and p.headers["ETag"] == '"2"'
    # the next parameter save continues the XML's history
    assert c.put("/api/graphs/g/params", content=XML1, headers={**A, **XMLH, "If-Match": '"2"'}).status_code == 204
    assert c.get("/api/graphs/g/params", headers=A).headers["ETag"] == '"3"'
    assert c.get("/api/graphs/g/files", headers=A).json() == []


def test_a_graph_saved_again_after_a_delete_keeps_the_old_parameter_history(c):
    assert c.put("/api/graphs/h", json=toy.chain(), headers=A).status_code == 201
    assert c.put("/api/graphs/h/params", content=XML1, headers={**A, **XMLH}).status_code == 204
    assert c.delete("/api/graphs/h", headers=A).status_code == 204
    # saved anew (not restored): it starts without parameters; its first XML is revision 2, so the
    # deleted graph's revision 1 is still there for a restore of the old graph
    assert c.put("/api/graphs/h", json=toy.chain(), headers=A).status_code == 201
    assert c.get("/api/graphs/h/params", headers=A).status_code == 404
    assert c.put("/api/graphs/h/params", content=XML2, headers={**A, **XMLH}).status_code == 204
    assert c.get("/api/graphs/h/params", headers=A).headers["ETag"] == '"2"'
    assert c.delete("/api/graphs/h", headers=A).status_code == 204
    r = c.post("/api/graphs/h/revisions/1/restore", headers=R)
    assert r.status_code == 201 and r.json()["problems"] == []
    assert c.get("/api/graphs/h/params", headers=A).text == XML2  # as last saved before the delete
