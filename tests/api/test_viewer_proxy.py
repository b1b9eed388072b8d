"""The 3D preview (viser) is reachable only through the API's authenticated /viewer proxy (#26 side
doors): viser listens on 127.0.0.1 whatever --host says, closes any websocket that did not come
through the proxy (another local user), and the proxy applies the token, role, Host and Origin checks."""

import socket

import psutil
import pytest
import viser
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from waamflow.api.app import create_app
from waamflow.settings import Settings

TOKEN = "lab-secret-0123456789"
VIEWER = "viewer-token-abcdefghij"
PROTO = [f"viser-v{viser.__version__}"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _settings(tmp_path, **kw) -> Settings:
    return Settings(
        data_dir=tmp_path / "data",
        graphs_dir=None,
        start_viewer=True,
        viewer_port=_free_port(),
        static_dir=None,
        workers=1,
        start_workers=False,
        **kw,
    )


def _listening(port: int) -> set[str]:
    return {
        c.laddr.ip
        for c in psutil.Process().net_connections(kind="inet")
        if c.status == psutil.CONN_LISTEN and c.laddr.port == port
    }


def _direct_close_code(port: int) -> int | None:
    """Open viser's websocket directly, as another local user would; the close code (None: still open
    after 5 s, i.e. the direct way in works)."""
    with connect(f"ws://127.0.0.1:{port}/?view=spy", subprotocols=PROTO, open_timeout=5) as ws:
        try:
            while True:
                ws.recv(timeout=5)
        except TimeoutError:
            return None
        except ConnectionClosed as e:
            return e.rcvd.code if e.rcvd is not None else -1


def test_without_token_viser_is_behind_the_proxy_too(tmp_path):
    with TestClient(create_app(_settings(tmp_path, host="127.0.0.1"))) as c:
        h = c.get("/api/health").json()
        assert h["viewer_url"] == "/viewer/" and h["viewer_port"] is None
        port = c.app.state.services.viewer.bound_port
        assert _listening(port) == {"127.0.0.1"}
        page = c.get("/viewer/")
        assert page.status_code == 200 and "<html" in page.text[:200].lower()
        with c.websocket_connect("/viewer/?view=tab-1", subprotocols=PROTO) as ws:
            assert len(ws.receive_bytes()) > 0  # viser's first message, relayed
        # the direct way in (another user of this machine) is closed with 1008 (policy violation)
        assert _direct_close_code(port) == 1008
        assert "spy" not in c.app.state.services.viewer.sessions
        # a DNS-rebinding page reaches neither the page nor the websocket
        assert c.get("/viewer/", headers={"Host": "attacker.example"}).status_code == 421
        with pytest.raises(WebSocketDisconnect):
            with c.websocket_connect("/viewer/", subprotocols=PROTO, headers={"Host": "attacker.example"}) as ws:
                ws.receive_bytes()


def test_with_tokens_the_proxy_checks_token_role_and_origin(tmp_path):
    tf = tmp_path / "tokens.txt"
    tf.write_text(f"watcher:{VIEWER}:viewer\n")
    tf.chmod(0o600)
    with TestClient(create_app(_settings(tmp_path, host="0.0.0.0", token=TOKEN, token_file=tf))) as c:
        port = c.app.state.services.viewer.bound_port
        assert _listening(port) == {"127.0.0.1"}  # never 0.0.0.0, though the API binds wider
        assert c.get("/viewer/").status_code == 401
        assert c.get("/viewer/", headers={"Authorization": "Bearer wrong-token-0123456789"}).status_code == 401
        with pytest.raises(WebSocketDisconnect) as e:
            with c.websocket_connect("/viewer/", subprotocols=PROTO) as ws:
                ws.receive_bytes()
        assert e.value.code == 1008
        # the lowest role (viewer) may look at the 3D view, as it may GET /api/viewer/state ...
        auth = {"Authorization": f"Bearer {VIEWER}"}
        assert c.get("/api/viewer/state", headers=auth).status_code == 200
        assert c.get("/viewer/", headers=auth).status_code == 200
        with c.websocket_connect("/viewer/?view=tab-1", subprotocols=PROTO, headers=auth) as ws:
            assert len(ws.receive_bytes()) > 0
        # ... but not change anything through the proxy's path (writes need editor, as on /api)
        r = c.post("/viewer/", headers=auth)
        assert r.status_code == 403 and "'viewer'" in r.json()["detail"]["message"]
        # a page of another site opening the websocket with the user's cookie: refused (forged Origin)
        c.cookies.set("waamflow_token", TOKEN)
        with pytest.raises(WebSocketDisconnect) as e:
            with c.websocket_connect("/viewer/", subprotocols=PROTO, headers={"Origin": "http://evil.example"}) as ws:
                ws.receive_bytes()
        assert e.value.code == 1008
        with c.websocket_connect("/viewer/", subprotocols=PROTO, headers={"Origin": "http://testserver"}) as ws:
            assert len(ws.receive_bytes()) > 0
        assert _direct_close_code(port) == 1008
