"""Operations: the audit log, backup + restore, and a server killed with -9 (during a run and a
save loop) that restarts with every acknowledged save intact and the run marked interrupted."""

import hashlib
import json
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import httpx
from fastapi.testclient import TestClient

import slow_nodes  # noqa: F401  (registers toy-slow)
import toy_nodes as toy
from api_util import wait_for_run as wait
from waamflow.api.app import create_app
from waamflow.cli import main as cli
from waamflow.settings import Settings

ALICE = "alice-token-abcdefghijkl"
BOB = "bob-token-abcdefghijklmn"
XML = '<?xml version="1.0"?><parameters></parameters>'


def _settings(data, **kw):
    return Settings(data_dir=data, graphs_dir=None, start_viewer=False, static_dir=None, workers=1, **kw)


def test_audit_log_names_who_did_what(tmp_path):
    tf = tmp_path / "tokens.json"
    tf.write_text(json.dumps({"alice": ALICE, "bob": BOB}))
    with TestClient(create_app(_settings(tmp_path / "data", token_file=tf))) as c:
        a = {"Authorization": f"Bearer {ALICE}"}
        b = {"Authorization": f"Bearer {BOB}"}
        t0 = time.time()
        assert c.put("/api/graphs/g1", json=toy.chain(), headers=a).status_code == 201
        assert c.put("/api/graphs/g1/files/part.stl", content=b"solid x", headers=a).status_code == 204
        r = c.post("/api/runs", json={"graph": "g1"}, headers=b)
        c.headers.update(b)
        wait(c, r.json()["id"])
        assert c.delete("/api/graphs/g1", headers=b).status_code == 204
        assert c.put("/api/graphs/bad", json={"nodes": 3}, headers=a).status_code == 422  # not saved: no entry
        log = c.get("/api/audit", headers=a).json()
        assert [(e["who"], e["action"], e["target"]) for e in log] == [
            ("bob", "delete_graph", "g1"),
            ("bob", "run", "g1"),
            ("alice", "upload_file", "g1"),
            ("alice", "save_graph", "g1"),
        ]
        assert log[1]["detail"]["run"] == r.json()["id"] and log[2]["detail"] == {
            "file": "part.stl",
            "bytes": 7,
            "version": 1,
            "replaced": None,
            "client": "testclient",
            "sha256": hashlib.sha256(b"solid x").hexdigest(),
        }
        assert all(t0 <= e["time"] <= time.time() for e in log)
        assert [e["action"] for e in c.get("/api/audit?who=alice", headers=a).json()] == ["upload_file", "save_graph"]
        assert len(c.get(f"/api/audit?before={log[1]['id']}", headers=a).json()) == 2


def _snapshot(c) -> dict:
    out = {"graphs": {}, "runs": {}}
    for g in c.get("/api/graphs").json():
        n = g["name"]
        files = {f["name"]: f["size"] for f in c.get(f"/api/graphs/{n}/files").json()}
        p = c.get(f"/api/graphs/{n}/params")
        out["graphs"][n] = (c.get(f"/api/graphs/{n}").json(), files, p.text if p.status_code == 200 else None)
    for r in c.get("/api/runs").json():
        arts = {
            a["name"]: c.get(f"/api/runs/{r['id']}/artifacts/{a['name']}").content
            for a in c.get(f"/api/runs/{r['id']}/artifacts").json()
        }
        st = c.get(f"/api/runs/{r['id']}").json()
        out["runs"][r["id"]] = (st["status"], st["summary"], arts, c.get(f"/api/runs/{r['id']}/log").json())
    # the snapshot's own reads (artifact downloads) are audited too: compare what changed state
    out["audit"] = [e for e in c.get("/api/audit").json() if e["action"] != "download_artifact"]
    return out


def test_backup_restore_round_trip(tmp_path, capsys):
    data = tmp_path / "data"
    with TestClient(create_app(_settings(data))) as c:
        for i in range(3):
            assert c.put(f"/api/graphs/g{i}", json=toy.chain(stack={"count": 2 + i})).status_code == 201
        assert c.put("/api/graphs/g0/files/part.stl", content=os.urandom(50_000)).status_code == 204
        assert c.put("/api/graphs/g1/params", content=XML).status_code in (204, 422)
        ids = [c.post("/api/runs", json={"graph": f"g{i}"}).json()["id"] for i in range(3)]
        for i in ids:
            assert wait(c, i)["status"] == "done"
        before = _snapshot(c)
        # backup while the server is up (online backup)
        assert cli(["backup", str(tmp_path / "bk"), "--data", str(data)]) == 0
    assert f"{len(before['graphs'])} graphs, 1 files, 3 runs, 6 run files" in capsys.readouterr().out
    assert cli(["backup", str(tmp_path / "bk"), "--data", str(data)]) == 2  # never into a used folder

    fresh = tmp_path / "fresh"
    assert cli(["restore", str(tmp_path / "bk"), "--data", str(fresh)]) == 0
    with TestClient(create_app(_settings(fresh))) as c:
        after = _snapshot(c)
    assert after == before and len(after["runs"]) == 3 and {"g0", "g1", "g2"} <= set(after["graphs"])
    assert after["graphs"]["g0"][1] == {"part.stl": 50_000}

    # a damaged backup is refused before anything is replaced
    victim = next((tmp_path / "bk" / "runs").iterdir()) / "summary.json"
    victim.write_text("{}")
    assert cli(["restore", str(tmp_path / "bk"), "--data", str(tmp_path / "other")]) == 2
    assert not (tmp_path / "other" / "waamflow.sqlite").exists()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start_server(data: Path, port: int) -> subprocess.Popen:
    tests = Path(__file__).resolve().parents[1]
    code = (
        "import sys; sys.path[:0] = [%r, %r]; import toy_nodes, slow_nodes; "
        "from waamflow.cli import main; sys.exit(main(sys.argv[1:]))"
    ) % (str(tests), str(tests / "api"))
    env = {**os.environ, "WAAMFLOW_TOKEN": ALICE}
    env.pop("WAAMFLOW_TOKEN_FILE", None)
    p = subprocess.Popen(
        [
            sys.executable,
            "-c",
            code,
            "serve",
            "--port",
            str(port),
            "--data",
            str(data),
            "--viewer-port",
            "0",
            "--graphs",
            str(data / "no-examples"),
        ],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    t0 = time.time()
    while time.time() - t0 < 60:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/api/health", timeout=1).status_code == 200:
                return p
        except httpx.HTTPError:
            pass
        if p.poll() is not None:
            raise AssertionError(f"server exited with {p.returncode}")
        time.sleep(0.1)
    p.kill()
    raise AssertionError("server did not start")


def test_kill_9_during_run_and_saves(tmp_path):
    data, port = tmp_path / "data", _free_port()
    base = f"http://127.0.0.1:{port}"
    h = {"Authorization": f"Bearer {ALICE}"}
    server = _start_server(data, port)
    try:
        slow = toy.recipe(
            [("stack", "toy-stack", {"count": 200}), ("slow", "toy-slow", {"seconds": 0.1})],
            [("stack.layers", "slow.layers")],
        )
        run_id = httpx.post(f"{base}/api/runs", json={"recipe": slow}, headers=h, timeout=10).json()["id"]
        acked: dict[str, dict] = {}
        stop = threading.Event()

        def save_loop():
            with httpx.Client(base_url=base, headers=h, timeout=10) as cl:
                i = 0
                while not stop.is_set():
                    rec = toy.chain(stack={"count": 1 + i % 50})
                    try:
                        r = cl.put(f"/api/graphs/s{i % 40}", json=rec)
                    except httpx.HTTPError:
                        return  # the server is gone
                    if r.status_code in (200, 201):
                        acked[f"s{i % 40}"] = rec
                    i += 1

        t = threading.Thread(target=save_loop)
        t.start()
        t0 = time.time()
        while time.time() - t0 < 30:
            st = httpx.get(f"{base}/api/runs/{run_id}", headers=h, timeout=10).json()["status"]
            if st == "running" and len(acked) >= 20:
                break
            time.sleep(0.05)
        assert st == "running"
        os.kill(server.pid, signal.SIGKILL)  # mid-run, mid-save-loop
        server.wait(10)
        stop.set()
        t.join(10)
    finally:
        if server.poll() is None:
            server.kill()
            server.wait(10)

    con = sqlite3.connect(data / "waamflow.sqlite")
    assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    con.close()

    server = _start_server(data, port)
    try:
        with httpx.Client(base_url=base, headers=h, timeout=10) as cl:
            run = cl.get(f"/api/runs/{run_id}").json()
            assert run["status"] == "interrupted" and run["error"]["kind"] == "interrupted"
            names = {g["name"] for g in cl.get("/api/graphs").json()}
            assert set(acked) <= names
            for name, rec in acked.items():
                saved = cl.get(f"/api/graphs/{name}").json()
                # the last acknowledged save (or a later one the kill cut off before its answer)
                assert saved["nodes"][0]["type"] == "toy-stack" and 1 <= saved["nodes"][0]["params"]["count"] <= 50
            assert any(e["action"] == "run" and e["detail"]["run"] == run_id for e in cl.get("/api/audit").json())
    finally:
        server.send_signal(signal.SIGTERM)
        try:
            server.wait(20)
        except subprocess.TimeoutExpired:
            server.kill()
