"""Every audited action names the client address it came from (#26 fault 11): saves (recipe,
parameter XML, files), deletes, restores, run start and cancel, artifact reads, previews and
failed logins."""

import json

from fastapi.testclient import TestClient

import slow_nodes  # noqa: F401  (registers toy-slow)
import toy_nodes as toy
from api_util import wait_for_run as wait
from waamflow.api.app import create_app
from waamflow.settings import Settings

ALICE = "alice-token-abcdefghijkl"
ADDR = ("10.20.30.40", 51234)
XML = '<?xml version="1.0"?><parameters></parameters>'


def test_audit_entries_carry_the_client_address(tmp_path):
    tf = tmp_path / "tokens.json"
    tf.write_text(json.dumps({"alice": ALICE}))
    tf.chmod(0o600)
    s = Settings(
        data_dir=tmp_path / "data", graphs_dir=None, start_viewer=False, static_dir=None, workers=1, token_file=tf
    )
    with TestClient(create_app(s), client=ADDR) as c:
        a = {"Authorization": f"Bearer {ALICE}"}
        assert c.put("/api/graphs/g1", json=toy.chain(stack={"count": 2}), headers=a).status_code == 201
        assert (
            c.put("/api/graphs/g1/params", content=XML, headers={**a, "Content-Type": "application/xml"}).status_code
            == 204
        )
        assert c.put("/api/graphs/g1/files/part.stl", content=b"solid x", headers=a).status_code == 204
        run = c.post("/api/runs", json={"graph": "g1"}, headers=a).json()["id"]
        c.headers.update(a)
        assert wait(c, run)["status"] == "done"
        arts = c.get(f"/api/runs/{run}/artifacts").json()
        assert c.get(f"/api/runs/{run}/artifacts/{arts[0]['name']}").status_code == 200
        slow = toy.recipe(
            [("stack", "toy-stack", {"count": 200}), ("slow", "toy-slow", {"seconds": 0.05})],
            [("stack.layers", "slow.layers")],
        )
        run2 = c.post("/api/runs", json={"recipe": slow}).json()["id"]
        assert c.delete(f"/api/runs/{run2}").status_code == 202
        wait(c, run2)
        assert (
            c.post(
                "/api/preview", json={"recipe": toy.chain(stack={"count": 2}), "node": "grow", "layer": 1}
            ).status_code
            == 200
        )
        assert c.delete("/api/graphs/g1").status_code == 204
        assert c.post("/api/graphs/g1/revisions/1/restore").status_code == 201
        c.headers.pop("Authorization")
        assert c.get("/api/graphs", headers={"Authorization": "Bearer wrong-token-0123456789"}).status_code == 401
        log = c.get("/api/audit", headers=a).json()
    actions = [e["action"] for e in log]
    for action in (
        "save_graph",
        "save_params",
        "upload_file",
        "run",
        "download_artifact",
        "cancel_run",
        "preview",
        "delete_graph",
        "restore_graph",
        "failed_login",
    ):
        assert action in actions, (action, actions)
    assert len(log) >= 11
    missing = [(e["action"], e["detail"]) for e in log if (e["detail"] or {}).get("client") != ADDR[0]]
    assert missing == []
    save = next(e for e in log if e["action"] == "save_graph")
    delete = next(e for e in log if e["action"] == "delete_graph")
    assert save["detail"] == {"created": True, "nodes": 3, "revision": 1, "client": "10.20.30.40"}
    assert delete["detail"] == {"client": "10.20.30.40"} and delete["who"] == "alice"
