"""Authentication (bearer tokens), serve's refusal to listen unauthenticated on the network, CORS."""

import json
import subprocess
import sys

import pytest
from fastapi.testclient import TestClient

import toy_nodes as toy
from api_util import wait_for_run as wait
from waamflow.api.app import create_app
from waamflow.api.auth import TokenFileError, load_tokens, parse_tokens
from waamflow.settings import Settings

TOKEN = "lab-secret-0123456789"
ALICE = "alice-token-abcdefghijkl"


@pytest.fixture()
def settings(tmp_path):
    gdir = tmp_path / "graphs"
    gdir.mkdir()
    (gdir / "example.json").write_text(json.dumps(toy.chain(stack={"count": 3})))
    tf = tmp_path / "tokens.txt"
    tf.write_text(f"# lab tokens\nalice:{ALICE}\n\n")
    return Settings(
        data_dir=tmp_path / "data",
        graphs_dir=gdir,
        start_viewer=False,
        static_dir=None,
        workers=1,
        token=TOKEN,
        token_file=tf,
    )


def test_token_required_on_every_api_route(settings):
    with TestClient(create_app(settings)) as c:
        h = c.get("/api/health")
        assert h.status_code == 200 and h.json()["auth_required"] is True
        for method, path in [
            ("GET", "/api/graphs"),
            ("GET", "/api/nodes"),
            ("GET", "/api/graphs/example"),
            ("PUT", "/api/graphs/x"),
            ("POST", "/api/runs"),
            ("GET", "/api/runs"),
            ("POST", "/api/preview"),
            ("POST", "/api/viewer/select"),
            ("GET", "/api/nope"),
            ("GET", "/viewer/"),
        ]:
            r = c.request(method, path, json={})
            assert r.status_code == 401, (method, path, r.status_code)
            assert r.headers["www-authenticate"].startswith("Bearer")
            assert r.json()["detail"]["kind"] == "unauthorized"
        r = c.get("/api/graphs", headers={"Authorization": "Bearer wrong-token-0123456789"})
        assert r.status_code == 401 and 'error="invalid_token"' in r.headers["www-authenticate"]
        assert c.get("/api/graphs", headers={"Authorization": f"Basic {TOKEN}"}).status_code == 401
        # a token prefix is not the token
        assert c.get("/api/graphs", headers={"Authorization": f"Bearer {TOKEN[:-1]}"}).status_code == 401

        for tok in (TOKEN, ALICE):
            r = c.get("/api/graphs", headers={"Authorization": f"Bearer {tok}"})
            assert r.status_code == 200 and [g["name"] for g in r.json()] == ["example"]
        # a browser's EventSource/download link: the session cookie works for GET, not for writes
        c.cookies.set("waamflow_token", ALICE)
        assert c.get("/api/graphs").status_code == 200
        assert c.put("/api/graphs/mine", json=toy.chain()).status_code == 401
        c.cookies.clear()
        auth = {"Authorization": f"Bearer {ALICE}"}
        r = c.post("/api/runs", json={"graph": "example"}, headers=auth)
        assert r.status_code == 202
        c.headers.update(auth)
        run = wait(c, r.json()["id"])
        assert run["status"] == "done" and run["summary"]["layer_count"] == 3


def test_without_token_everything_is_open(tmp_path):
    s = Settings(data_dir=tmp_path / "data", graphs_dir=None, start_viewer=False, static_dir=None, workers=1)
    with TestClient(create_app(s)) as c:
        assert c.get("/api/health").json()["auth_required"] is False
        assert c.get("/api/graphs").status_code == 200
        # CORS is closed by default: no Access-Control-Allow-Origin for a foreign origin
        r = c.get("/api/graphs", headers={"Origin": "http://evil.example"})
        assert "access-control-allow-origin" not in r.headers
    s = Settings(
        data_dir=tmp_path / "data2",
        graphs_dir=None,
        start_viewer=False,
        static_dir=None,
        workers=1,
        cors_origins=["http://lab.example"],
    )
    with TestClient(create_app(s)) as c:
        r = c.get("/api/graphs", headers={"Origin": "http://lab.example"})
        assert r.headers["access-control-allow-origin"] == "http://lab.example"


def test_token_files(tmp_path):
    assert parse_tokens(json.dumps({"alice": ALICE, "bob": TOKEN})) == {"alice": ALICE, "bob": TOKEN}
    assert parse_tokens(f"alice: {ALICE}\n# c\n") == {"alice": ALICE}
    for bad in ("alice", "alice:short", f"a b:{ALICE}", f"alice:{ALICE}\nalice:{TOKEN}", "", "{nope"):
        with pytest.raises(TokenFileError):
            parse_tokens(bad)
    with pytest.raises(TokenFileError, match="cannot read"):
        load_tokens(None, tmp_path / "missing.txt")
    assert load_tokens(TOKEN, None) == {"default": TOKEN}


def _serve(args, env_extra, tmp_path):
    env = {
        "PATH": "/usr/bin:/bin",
        "PYTHONPATH": str(__import__("waamflow").__path__[0].rsplit("/", 1)[0]),
        **env_extra,
    }
    return subprocess.run(
        [sys.executable, "-m", "waamflow.cli", "serve", "--data", str(tmp_path / "d"), "--viewer-port", "0", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_serve_refuses_network_without_token(tmp_path):
    r = _serve(["--host", "0.0.0.0", "--port", "8149"], {}, tmp_path)
    assert r.returncode != 0
    assert "WAAMFLOW_TOKEN" in r.stderr and "--token-file" in r.stderr
    bad = tmp_path / "t.txt"
    bad.write_text("alice:short\n")
    r = _serve(["--host", "0.0.0.0", "--port", "8149", "--token-file", str(bad)], {}, tmp_path)
    assert r.returncode == 2 and "at least 16 characters" in r.stderr


def test_viewer_behind_the_api_auth(tmp_path):
    """With a token, viser listens on loopback and is reached through /viewer/ (page + websocket)."""
    import socket

    import viser
    from starlette.websockets import WebSocketDisconnect

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    st = Settings(
        data_dir=tmp_path / "data",
        graphs_dir=None,
        start_viewer=True,
        viewer_port=port,
        static_dir=None,
        workers=1,
        token=TOKEN,
        host="0.0.0.0",
    )
    with TestClient(create_app(st)) as c:
        h = c.get("/api/health").json()
        # viser is a dependency and its port is free: not starting is a failure, not a skip
        assert h["viewer_url"] is not None, "the viewer did not start, so its auth was never checked"
        assert h["viewer_url"] == "/viewer/" and h["viewer_port"] is None
        svc = c.app.state.services
        assert svc.viewer.server.get_host() == "127.0.0.1"  # not on the network, whatever --host says
        assert c.get("/viewer/").status_code == 401
        with pytest.raises(WebSocketDisconnect):
            with c.websocket_connect("/viewer", subprotocols=[f"viser-v{viser.__version__}"]) as ws:
                ws.receive_bytes()
        c.cookies.set("waamflow_token", TOKEN)
        page = c.get("/viewer/")
        assert page.status_code == 200 and "<html" in page.text[:200].lower()
        with c.websocket_connect("/viewer", subprotocols=[f"viser-v{viser.__version__}"]) as ws:
            assert len(ws.receive_bytes()) > 0  # viser's first message, relayed
