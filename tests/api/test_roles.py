"""Roles per token, owned graphs, restore by an admin, If-Match under concurrency (#26 fault 7:
"bob overwrote and deleted alice's graph (unrecoverable)")."""

import json
import threading

import pytest
from fastapi.testclient import TestClient

import toy_nodes as toy
from waamflow.api.app import create_app
from waamflow.api.auth import TokenFileError, load_tokens, parse_tokens
from waamflow.settings import Settings

T = {
    "alice": "alice-token-abcdefghijkl",
    "bob": "bob-token-abcdefghijklmn",
    "vic": "vic-token-abcdefghijklmn",
    "ola": "ola-token-abcdefghijklmn",
    "root": "root-token-abcdefghijklm",
}
TOKEN_FILE = "\n".join(
    [
        "# name:token:role",
        f"alice:{T['alice']}:editor",
        f"bob:{T['bob']}:editor",
        f"vic:{T['vic']}:viewer",
        f"ola:{T['ola']}:operator",
        f"root:{T['root']}",
    ]
)  # no role: as every token file before roles → admin


def h(who):
    return {"Authorization": f"Bearer {T[who]}"}


@pytest.fixture()
def c(tmp_path):
    tf = tmp_path / "tokens"
    tf.write_text(TOKEN_FILE)
    tf.chmod(0o600)
    s = Settings(
        data_dir=tmp_path / "data",
        graphs_dir=tmp_path / "none",
        start_viewer=False,
        static_dir=None,
        workers=1,
        token_file=tf,
    )
    with TestClient(create_app(s)) as client:
        yield client


def test_token_file_roles_and_defaults(tmp_path):
    t = parse_tokens(TOKEN_FILE)
    assert t.roles == {"alice": "editor", "bob": "editor", "vic": "viewer", "ola": "operator", "root": "admin"}
    j = parse_tokens(json.dumps({"a": T["alice"], "b": {"token": T["bob"], "role": "viewer"}}))
    assert j.roles == {"a": "admin", "b": "viewer"} and j["b"] == T["bob"]
    with pytest.raises(TokenFileError, match="role 'boss'"):
        parse_tokens(f"x:{T['alice']}:boss")
    assert load_tokens(T["root"], None).roles == {"default": "admin"}


def test_viewer_reads_only(c):
    assert c.put("/api/graphs/a1", json=toy.chain(), headers=h("alice")).status_code == 201
    assert c.get("/api/graphs/a1", headers=h("vic")).status_code == 200
    assert c.get("/api/graphs", headers=h("vic")).status_code == 200
    for method, url, body in [
        ("PUT", "/api/graphs/v1", toy.chain()),
        ("PUT", "/api/graphs/a1", toy.chain()),
        ("DELETE", "/api/graphs/a1", None),
        ("POST", "/api/runs", {"graph": "a1"}),
        ("PUT", "/api/graphs/a1/files/x.stl", None),
    ]:
        r = c.request(method, url, json=body, headers=h("vic"))
        assert r.status_code == 403, (method, url, r.text)
        d = r.json()["detail"]
        assert d["kind"] == "forbidden" and "'viewer'" in d["message"], d
    assert [g["name"] for g in c.get("/api/graphs", headers=h("vic")).json()] == ["a1"]
    assert c.get("/api/runs", headers=h("vic")).json() == []


def test_operator_runs_but_does_not_save(c):
    assert c.put("/api/graphs/a1", json=toy.chain(), headers=h("alice")).status_code == 201
    r = c.post("/api/runs", json={"graph": "a1"}, headers=h("ola"))
    assert r.status_code == 202
    assert c.delete(f"/api/runs/{r.json()['id']}", headers=h("ola")).status_code == 202
    for who, status in (("ola", 422), ("vic", 403)):  # the machine side of a build: operators, not viewers
        assert c.post("/api/builds", json={}, headers=h(who)).status_code == status
    assert c.put("/api/graphs/o1", json=toy.chain(), headers=h("ola")).status_code == 403
    assert c.delete("/api/graphs/a1", headers=h("ola")).status_code == 403
    assert c.get("/api/graphs/a1", headers=h("alice")).json()["nodes"] == toy.chain()["nodes"]


def test_editors_change_only_their_own_and_admin_restores(c):
    original = toy.chain(stack={"count": 3})
    assert c.put("/api/graphs/alices", json=original, headers=h("alice")).status_code == 201
    owner = {g["name"]: g["owner"] for g in c.get("/api/graphs", headers=h("bob")).json()}
    assert owner == {"alices": "alice"}
    # bob (editor) can neither overwrite nor delete alice's graph, nor her files or parameter XML
    r = c.put("/api/graphs/alices", json=toy.chain(stack={"count": 9}), headers=h("bob"))
    assert r.status_code == 403 and "'alice'" in r.json()["detail"]["message"]
    assert c.delete("/api/graphs/alices", headers=h("bob")).status_code == 403
    assert c.put("/api/graphs/alices/files/p.stl", content=b"solid x", headers=h("bob")).status_code == 403
    assert c.put("/api/graphs/alices/params", content=b"<parameters/>", headers=h("bob")).status_code == 403
    assert c.get("/api/graphs/alices", headers=h("bob")).json()["nodes"][0]["params"] == {"count": 3}
    # bob saves his own; alice edits hers (revision 2) and deletes it
    assert c.put("/api/graphs/bobs", json=toy.chain(), headers=h("bob")).status_code == 201
    assert c.put("/api/graphs/alices", json=toy.chain(stack={"count": 4}), headers=h("alice")).status_code == 200
    assert c.delete("/api/graphs/alices", headers=h("alice")).status_code == 204
    assert c.get("/api/graphs/alices", headers=h("alice")).status_code == 404
    # the deleted graph's history stays; only an admin restores it
    revs = c.get("/api/graphs/alices/revisions", headers=h("root")).json()
    assert [(r["revision"], r["user"]) for r in revs] == [(2, "alice"), (1, "alice")]
    assert c.get("/api/graphs/alices/revisions/1", headers=h("vic")).json()["nodes"][0]["params"] == {"count": 3}
    r = c.post("/api/graphs/alices/revisions/1/restore", headers=h("alice"))
    assert r.status_code == 403 and "admin" in r.json()["detail"]["message"]
    r = c.post("/api/graphs/alices/revisions/1/restore", headers=h("root"))
    assert r.status_code == 201 and r.json()["revision"] == 3 and r.headers["ETag"] == '"3"'
    back = c.get("/api/graphs/alices", headers=h("alice")).json()
    assert back["nodes"] == original["nodes"] and back["edges"] == original["edges"]
    assert {g["name"]: g["owner"] for g in c.get("/api/graphs", headers=h("root")).json()}["alices"] == "alice"
    # an admin overwrites anyone's graph, and restores what was overwritten
    assert c.put("/api/graphs/bobs", json=toy.chain(stack={"count": 7}), headers=h("root")).status_code == 200
    assert c.post("/api/graphs/bobs/revisions/1/restore", headers=h("root")).status_code == 200
    assert c.get("/api/graphs/bobs", headers=h("bob")).json()["nodes"] == toy.chain()["nodes"]
    assert c.post("/api/graphs/bobs/revisions/9/restore", headers=h("root")).status_code == 404
    assert c.delete("/api/graphs/bobs", headers=h("root")).status_code == 204
    for who in ("alice", "ola", "vic"):  # the audit log (who, what, from where) is for admins
        assert c.get("/api/audit", headers=h(who)).status_code == 403
    actions = [(e["who"], e["action"], e["target"]) for e in c.get("/api/audit", headers=h("root")).json()]
    assert ("root", "restore_graph", "alices") in actions and ("root", "delete_graph", "bobs") in actions


def test_if_match_under_concurrency_exactly_one_wins(c):
    """Two clients that loaded the same revision save at once with If-Match: one 200, one 409, in
    every round; the revision counts only the winners."""
    assert c.put("/api/graphs/race", json=toy.chain(), headers=h("alice")).status_code == 201
    rounds, results = 40, []
    for i in range(rounds):
        rev = c.get("/api/graphs/race", headers=h("alice")).headers["ETag"]
        barrier = threading.Barrier(2)
        got: list[int] = []

        def save(count):
            barrier.wait()
            r = c.put(
                "/api/graphs/race", json=toy.chain(stack={"count": count}), headers={**h("alice"), "If-Match": rev}
            )
            got.append(r.status_code)

        ts = [threading.Thread(target=save, args=(10 + i,)), threading.Thread(target=save, args=(100 + i,))]
        for t in ts:
            t.start()
        for t in ts:
            t.join(10)
        results.append(sorted(got))
    assert results == [[200, 409]] * rounds
    r = c.get("/api/graphs/race", headers=h("alice"))
    assert r.headers["ETag"] == f'"{1 + rounds}"'
    assert len(c.get("/api/graphs/race/revisions", headers=h("alice")).json()) == 1 + rounds
