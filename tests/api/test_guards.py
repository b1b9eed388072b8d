"""Issue 26, faults 6, 8, 9, 11: bodies bounded before they are read, the Host allow-list
(DNS rebinding) and Origin check, wrong-token throttling, weak/exposed token files, disk full,
and the audit of reads (previews, viewer actions, downloads, failed logins) with client address."""

import errno
import json
import sqlite3
import time

import pytest
from fastapi.testclient import TestClient

import toy_nodes as toy
from api_util import wait_for_run as wait
from waamflow.api.app import create_app
from waamflow.api.auth import TokenFileError, load_tokens
from waamflow.settings import Settings

TOKEN = "lab-secret-0123456789abcdef"


def _settings(tmp_path, **kw):
    return Settings(data_dir=tmp_path / "data", graphs_dir=None, start_viewer=False, static_dir=None, workers=1, **kw)


def _stream(chunks):
    """A body without Content-Length (chunked): the server learns its size only by reading."""

    def gen():
        yield from chunks

    return gen()


# ---- fault 6: bodies ----------------------------------------------------------------------------
def test_content_length_over_the_limit_is_refused_before_reading(tmp_path):
    with TestClient(create_app(_settings(tmp_path, max_upload_mb=1, max_body_mb=1))) as c:
        assert c.put("/api/graphs/g", json=toy.chain()).status_code == 201
        read = []

        def body():  # would be 10 GB; only what the server pulls is produced
            for _ in range(10 * 1024):
                read.append(1)
                yield b"x" * 2**20

        t0 = time.monotonic()
        r = c.put("/api/graphs/g/files/big.stl", content=body(), headers={"Content-Length": str(10 * 2**30)})
        assert r.status_code == 413 and r.json()["detail"]["kind"] == "too_large"
        assert "10240.0 MB" in r.json()["detail"]["message"] and "max_upload_mb" in r.json()["detail"]["message"]
        assert time.monotonic() - t0 < 2.0
        # a recipe body: the JSON limit (max_body_mb), declared 300 MB
        r = c.put(
            "/api/graphs/huge",
            content=b"{}",
            headers={"Content-Length": str(300 * 2**20), "Content-Type": "application/json"},
        )
        assert r.status_code == 413 and "max_body_mb" in r.json()["detail"]["message"]
        assert c.get("/api/graphs/huge").status_code == 404
        assert c.put("/api/graphs/g/files/x.stl", content=b"x", headers={"Content-Length": "-5"}).status_code == 400


def test_body_without_content_length_is_cut_at_the_limit(tmp_path):
    with TestClient(create_app(_settings(tmp_path, max_upload_mb=1, max_body_mb=1))) as c:
        assert c.put("/api/graphs/g", json=toy.chain()).status_code == 201
        pulled = []

        def chunks():
            for i in range(300):  # 300 × 64 kB = 18.75 MB offered
                pulled.append(i)
                yield b"x" * 65536

        r = c.put("/api/graphs/g/files/big.stl", content=chunks())
        assert r.status_code == 413 and r.json()["detail"]["kind"] == "too_large"
        assert [f["name"] for f in c.get("/api/graphs/g/files").json()] == []
        big = b'{"format":"waamflow/1","name":"x","nodes":[],"edges":[],"description":"' + b"y" * (2 * 2**20) + b'"}'
        r = c.put(
            "/api/graphs/huge",
            content=_stream([big[i : i + 65536] for i in range(0, len(big), 65536)]),
            headers={"Content-Type": "application/json"},
        )
        assert r.status_code == 413, r.text
        assert c.get("/api/graphs/huge").status_code == 404
        # under the limit, streamed: accepted whole
        r = c.put("/api/graphs/g/files/ok.stl", content=_stream([b"x" * 65536] * 15))
        assert r.status_code == 204
        assert [(f["name"], f["size"]) for f in c.get("/api/graphs/g/files").json()] == [("ok.stl", 15 * 65536)]


def test_oversized_recipe_in_the_graphs_folder_is_not_read(tmp_path):
    gdir = tmp_path / "graphs"
    gdir.mkdir()
    (gdir / "small.json").write_text(json.dumps(toy.chain()))
    with open(gdir / "huge.json", "wb") as f:  # sparse: 300 MB on paper, nothing on disk
        f.truncate(300 * 2**20)
    s = Settings(
        data_dir=tmp_path / "data", graphs_dir=gdir, start_viewer=False, static_dir=None, workers=1, max_body_mb=1
    )
    t0 = time.monotonic()
    with TestClient(create_app(s)) as c:
        listed = {g["name"]: g["error"] for g in c.get("/api/graphs").json()}
        # not read, but listed with the reason (#26: never skipped silently)
        assert listed["small"] is None and listed["huge"]["size"] == 300 * 2**20
        assert "max_body_mb" in listed["huge"]["reason"]
    assert time.monotonic() - t0 < 5.0


# ---- fault 9: Host and Origin -------------------------------------------------------------------
def test_dns_rebinding_host_is_refused_without_a_token(tmp_path):
    with TestClient(create_app(_settings(tmp_path))) as c:
        for host in ("attacker.example", "attacker.example:8000", "127.0.0.1.attacker.example", "evil"):
            r = c.get("/api/graphs", headers={"Host": host})
            assert r.status_code == 421 and r.json()["detail"]["kind"] == "misdirected", host
            r = c.put("/api/graphs/rebound", json=toy.chain(), headers={"Host": host})
            assert r.status_code == 421
        assert c.get("/api/graphs/rebound").status_code == 404
        for host in ("127.0.0.1:8000", "localhost:8000", "localhost", "[::1]:8000", "127.0.0.2"):
            assert c.get("/api/health", headers={"Host": host}).status_code == 200, host
    # a token decides instead of the Host (a reverse proxy names the server as it likes)
    with TestClient(create_app(_settings(tmp_path, token=TOKEN))) as c:
        r = c.get("/api/graphs", headers={"Host": "cam.lab.example", "Authorization": f"Bearer {TOKEN}"})
        assert r.status_code == 200


def test_cross_site_origin_is_refused(tmp_path):
    with TestClient(create_app(_settings(tmp_path, cors_origins=["https://gui.lab.example"]))) as c:
        evil = {"Origin": "http://attacker.example"}
        r = c.put("/api/graphs/x", json=toy.chain(), headers=evil)
        assert r.status_code == 403 and r.json()["detail"]["kind"] == "forbidden"
        assert c.post("/api/runs", json={"recipe": toy.chain()}, headers=evil).status_code == 403
        assert c.get("/api/runs/abc/events", headers=evil).status_code == 403
        # same origin, a listed origin, no Origin (scripts): accepted
        assert c.put("/api/graphs/x", json=toy.chain(), headers={"Origin": "http://testserver"}).status_code == 201
        assert (
            c.put("/api/graphs/y", json=toy.chain(), headers={"Origin": "https://gui.lab.example"}).status_code == 201
        )
        assert c.put("/api/graphs/z", json=toy.chain()).status_code == 201
    # websockets (the /viewer relay): a cross-site page is closed before the app accepts
    from starlette.applications import Starlette
    from starlette.routing import WebSocketRoute
    from starlette.websockets import WebSocketDisconnect

    from waamflow.api.guards import HostOriginMiddleware

    async def echo(ws):
        await ws.accept()
        await ws.send_text("hello")
        await ws.close()

    app = HostOriginMiddleware(Starlette(routes=[WebSocketRoute("/viewer", echo)]), None, set())
    with TestClient(app) as c:
        with c.websocket_connect("/viewer", headers={"Origin": "http://testserver"}) as ws:
            assert ws.receive_text() == "hello"
        with c.websocket_connect("/viewer") as ws:  # no Origin: not a browser
            assert ws.receive_text() == "hello"
        for origin in ("http://attacker.example", "null", "http://testserver.attacker.example"):
            with pytest.raises(WebSocketDisconnect) as e:
                with c.websocket_connect("/viewer", headers={"Origin": origin}) as ws:
                    ws.receive_text()
            assert e.value.code == 1008


# ---- fault 8: throttling and token files --------------------------------------------------------
def test_wrong_tokens_are_throttled_per_address(tmp_path):
    with TestClient(create_app(_settings(tmp_path, token=TOKEN, auth_failures_per_minute=5))) as c:
        codes = [
            c.get("/api/graphs", headers={"Authorization": f"Bearer wrong-{i:04d}-abcdefghijklmn"}).status_code
            for i in range(20)
        ]
        assert codes[:5] == [401] * 5
        assert codes[6:] == [429] * 14
        r = c.get("/api/graphs", headers={"Authorization": f"Bearer {TOKEN}"})  # same address: waits too
        assert r.status_code == 429 and 1 <= int(r.headers["retry-after"]) <= 300
        assert "too many wrong tokens" in r.json()["detail"]["message"]
        assert c.get("/api/health").status_code == 200  # no token: health stays open
    # the back-off doubles with each refusal past the limit
    from waamflow.api.guards import AuthThrottle

    t = AuthThrottle(per_minute=3)
    for i in range(4):
        t.failed("10.0.0.1", now=100.0 + i)
    w1 = t.retry_after("10.0.0.1", now=103.0)
    t.failed("10.0.0.1", now=103.5)
    w2 = t.retry_after("10.0.0.1", now=103.5)
    assert 55 <= w1 <= 60 and w2 >= 1.8 * w1
    assert t.retry_after("10.0.0.2", now=103.5) == 0


def test_weak_or_exposed_token_files_are_refused(tmp_path):
    tf = tmp_path / "tokens.txt"
    tf.write_text("alice:" + "a" * 40 + "\n")
    tf.chmod(0o600)
    with pytest.raises(TokenFileError, match="one character|distinct"):
        load_tokens(None, tf)
    with pytest.raises(TokenFileError, match="distinct"):
        load_tokens("abababababababababab", None)
    tf.write_text("alice:alice-token-abcdefghijkl\n")
    for mode in (0o666, 0o644, 0o602):
        tf.chmod(mode)
        with pytest.raises(TokenFileError, match="chmod 600"):
            load_tokens(None, tf)
    tf.chmod(0o640)
    assert load_tokens(None, tf) == {"alice": "alice-token-abcdefghijkl"}


# ---- fault 8: disk full -------------------------------------------------------------------------
def test_disk_full_is_507_and_deletes_still_work(tmp_path, monkeypatch):
    with TestClient(create_app(_settings(tmp_path))) as c:
        assert (tmp_path / "data" / ".disk-reserve").stat().st_blocks * 512 >= 2**20  # allocated, not sparse
        assert c.put("/api/graphs/g", json=toy.chain()).status_code == 201
        store = c.app.state.services.store

        def full(*a, **kw):
            raise OSError(errno.ENOSPC, "No space left on device")

        def full_sqlite(*a, **kw):
            raise sqlite3.OperationalError("database or disk is full")

        monkeypatch.setattr(store, "put_file", full)
        r = c.put("/api/graphs/g/files/big.stl", content=b"x" * 1000)
        assert r.status_code == 507 and r.json()["detail"]["kind"] == "disk_full"
        assert "disk" in r.json()["detail"]["message"] and "delete" in r.json()["detail"]["message"]
        monkeypatch.setattr(store, "put_graph", full_sqlite)
        r = c.put("/api/graphs/h", json=toy.chain())
        assert r.status_code == 507 and r.json()["detail"]["kind"] == "disk_full"
        # the reserve kept on the data folder's disk is given back for the deletes' journal
        assert not (tmp_path / "data" / ".disk-reserve").exists()
        assert c.delete("/api/graphs/g").status_code == 204
        assert c.get("/api/graphs/g").status_code == 404


# ---- fault 11: audit of reads --------------------------------------------------------------------
def test_audit_has_previews_viewer_downloads_failed_logins_with_address(tmp_path):
    with TestClient(create_app(_settings(tmp_path, token=TOKEN))) as c:
        ok = {"Authorization": f"Bearer {TOKEN}"}
        assert c.get("/api/graphs", headers={"Authorization": "Bearer not-the-token-0123456789"}).status_code == 401
        assert c.put("/api/graphs/g", json=toy.chain(), headers=ok).status_code == 201
        r = c.post("/api/runs", json={"graph": "g"}, headers=ok)
        c.headers.update(ok)
        run = wait(c, r.json()["id"])
        assert run["status"] == "done"
        name = c.get(f"/api/runs/{run['id']}/artifacts").json()[0]["name"]
        assert c.get(f"/api/runs/{run['id']}/artifacts/{name}").status_code == 200
        r = c.post("/api/preview", json={"recipe": toy.chain(), "node": "grow", "layer": 1, "graph": "g"})
        assert r.status_code == 200, r.text
        assert c.post("/api/viewer/select", json={"node": "grow", "layer": 1}).status_code == 204
        log = c.get("/api/audit").json()
        acts = [(e["action"], e["who"], e["target"]) for e in log]
        assert acts[:4] == [
            ("viewer_select", "default", None),
            ("preview", "default", "g"),
            ("download_artifact", "default", run["id"]),
            ("run", "default", "g"),
        ]
        assert ("failed_login", None, None) == acts[-1]
        assert log[-1]["detail"]["client"] == "testclient" and log[-1]["detail"]["path"] == "/api/graphs"
        assert all(e["detail"]["client"] == "testclient" for e in log[:3])
        assert log[1]["detail"]["layer"] == 1 and log[1]["detail"]["node"] == "grow"
        assert log[2]["detail"]["file"] == name
