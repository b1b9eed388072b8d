"""Issue 26 fault 5: work bounded before it starts and while it runs. An estimate (layers from part
height / layer height, triangles, DXF entities, a 3MF's uncompressed size) refuses a run or a
preview before anything is computed; a node that makes too many layers stops the run at once;
progress events carry the layer; previews share the queue and stop on their time limit and when
the client leaves; cancel ends a run within 2 s, its layer workers killed, a blocking node too."""

import asyncio
import io
import json
import threading
import time
import zipfile

import psutil
import pytest
from pydantic import Field

import slow_nodes  # noqa: F401  (registers toy-slow)
import toy_nodes as toy
from api_util import wait_for_run as wait
from helpers_limits import box_stl, client, parallel_now, settings, sliced
from waamflow.api.app import create_app
from waamflow.engine.node import Node, NodeParams, Port, register

SPINS = {"n": 0}
RELEASE = threading.Event()


@register
class ToySpin(Node):
    """Counts while it computes (checks cancel each 10 ms) for `seconds`; passes the layers on. With
    `beat`, it also appends a byte to that file per count (seen from another process: a preview
    worker's)."""

    type = "toy-spin"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("layers", "layers"),)

    class Params(NodeParams):
        seconds: float = Field(5.0, ge=0)
        beat: str = ""

    def run(self, ctx, params, inputs):
        t0 = time.monotonic()
        while time.monotonic() - t0 < params.seconds:
            ctx.check_cancelled()
            SPINS["n"] += 1
            if params.beat:
                with open(params.beat, "ab") as f:
                    f.write(b".")
            time.sleep(0.01)
        return {"layers": inputs["layers"]}


@register
class ToyBlock(Node):
    """Blocks without looking at cancel (as a read from a FIFO would) until RELEASE or 30 s."""

    type = "toy-block"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("layers", "layers"),)

    def run(self, ctx, params, inputs):
        RELEASE.wait(30)
        return {"layers": inputs["layers"]}


def test_layer_estimate_refuses_run_and_preview_before_they_start(tmp_path):
    with client(tmp_path, max_layers=50) as c:
        assert c.put("/api/graphs/tall", json=sliced("tall.stl")).status_code == 201
        assert c.put("/api/graphs/tall/files/tall.stl", content=box_stl(3000.0)).status_code == 204
        t0 = time.monotonic()
        r = c.post("/api/runs", json={"graph": "tall"})
        assert time.monotonic() - t0 < 2.0
        assert r.status_code == 422, r.text
        d = r.json()["detail"]
        assert d["kind"] == "limit" and d["node"] == "layers"
        assert "2000 layers, over the limit of 50 (max_layers)" in d["message"]
        assert c.get("/api/runs").json() == []  # nothing queued
        r = c.post("/api/preview", json={"recipe": sliced("tall.stl"), "graph": "tall", "node": "layers", "layer": 0})
        assert r.status_code == 422 and "2000 layers" in r.json()["detail"]["message"]
        # 60 mm / 1.5 mm = 40 layers: runs
        assert c.put("/api/graphs/tall/files/low.stl", content=box_stl(60.0)).status_code == 204
        r = c.post("/api/runs", json={"recipe": sliced("low.stl"), "graph": "tall"})
        assert r.status_code == 202, r.text
        run = wait(c, r.json()["id"])
        assert run["status"] == "done" and run["summary"]["layer_count"] == 40


def test_3mf_zip_bomb_and_dxf_flood_are_refused_by_their_declared_size(tmp_path):
    bomb = io.BytesIO()
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("3D/3dmodel.model", b"\0" * (60 * 2**20))  # 60 MB of zeros → ~60 kB compressed
    assert len(bomb.getvalue()) < 200_000
    dxf = (
        "0\nSECTION\n2\nENTITIES\n"
        + "".join(f"0\nLINE\n8\n0\n10\n{i}\n20\n0\n11\n{i}\n21\n1\n" for i in range(600))
        + "0\nENDSEC\n0\nEOF\n"
    )
    with client(tmp_path, max_uncompressed_mb=50, max_dxf_entities=500) as c:
        assert c.put("/api/graphs/g", json=sliced("bomb.3mf")).status_code == 201
        assert c.put("/api/graphs/g/files/bomb.3mf", content=bomb.getvalue()).status_code == 204
        assert c.put("/api/graphs/g/files/many.dxf", content=dxf.encode()).status_code == 204
        r = c.post("/api/runs", json={"graph": "g"})
        assert r.status_code == 422 and "3MF expands to 60 MB, over the limit of 50 MB" in r.json()["detail"]["message"]
        sk = toy.recipe(
            [("s", "sketch", {"path": "many.dxf", "height": 10}), ("layers", "slice", {})], [("s.mesh", "layers.mesh")]
        )
        r = c.post("/api/runs", json={"recipe": sk, "graph": "g"})
        assert r.status_code == 422
        assert "603 DXF entities, over the limit of 500 (max_dxf_entities)" in r.json()["detail"]["message"]


def test_too_many_layers_stop_the_run_before_the_next_node(tmp_path):
    rec = toy.recipe(
        [("stack", "toy-stack", {"count": 2000}), ("slow", "toy-slow", {"seconds": 0.05})],
        [("stack.layers", "slow.layers")],
    )
    with client(tmp_path, max_layers=50) as c:
        t0 = time.monotonic()
        run = wait(c, c.post("/api/runs", json={"recipe": rec}).json()["id"])
        assert time.monotonic() - t0 < 2.0  # the 2000 slow layers (100 s) never ran
        assert run["status"] == "failed" and run["error"]["kind"] == "limit" and run["error"]["node"] == "stack"
        assert "2000 layers, over the limit of 50 (max_layers)" in run["error"]["message"]
        log = c.get(f"/api/runs/{run['id']}/log").json()
        assert not [e for e in log if e.get("node") == "slow"]


def test_progress_events_carry_the_layer(tmp_path):
    rec = toy.recipe(
        [("stack", "toy-stack", {"count": 12}), ("slow", "toy-slow", {"seconds": 0.12})],
        [("stack.layers", "slow.layers")],
    )
    with client(tmp_path, layer_workers=1) as c:
        run = wait(c, c.post("/api/runs", json={"recipe": rec}).json()["id"])
        assert run["status"] == "done"
        prog = [e for e in c.get(f"/api/runs/{run['id']}/log").json() if e["kind"] == "node_progress"]
        layers = [e["layer"] for e in prog if e.get("node") == "slow"]
        assert len(layers) >= 8 and layers == sorted(layers) and layers[-1] == 11
        assert all(e["message"] == f"layer {e['layer']}" for e in prog if e.get("node") == "slow")


def spin(seconds=5.0, beat=None):
    return toy.recipe(
        [
            ("stack", "toy-stack", {"count": 2}),
            ("spin", "toy-spin", {"seconds": seconds, **({"beat": str(beat)} if beat else {})}),
        ],
        [("stack.layers", "spin.layers")],
    )


def beats(path) -> int:
    return path.stat().st_size if path.exists() else 0


# run_memory_mb 0: previews compute in a thread of the server; > 0: in a preview worker process
IN_PROCESS = pytest.mark.parametrize("run_memory_mb", [0, 1024], ids=["thread", "process"])


@IN_PROCESS
def test_preview_has_a_time_limit_and_shares_the_queue(tmp_path, run_memory_mb):
    beat = tmp_path / "beat"
    with client(tmp_path, preview_timeout_s=0.5, max_queued_runs=1, run_memory_mb=run_memory_mb) as c:
        t0 = time.monotonic()
        r = c.post("/api/preview", json={"recipe": spin(5.0, beat), "node": "spin", "layer": 0})
        assert time.monotonic() - t0 < 2.5
        assert r.status_code == 422 and "preview_timeout_s" in r.json()["detail"]["message"]
        n = beats(beat)
        time.sleep(0.3)
        assert n > 5 and beats(beat) == n  # it computed, and stopped with the answer
        rid = c.post("/api/runs", json={"recipe": spin(3.0)}).json()["id"]
        r = c.post("/api/preview", json={"recipe": spin(0.0), "node": "spin", "layer": 0})
        assert r.status_code == 429 and int(r.headers["retry-after"]) >= 1
        c.delete(f"/api/runs/{rid}")
        assert wait(c, rid)["status"] == "cancelled"
        assert c.post("/api/preview", json={"recipe": spin(0.0), "node": "spin", "layer": 0}).status_code == 200


@IN_PROCESS
def test_preview_stops_when_the_client_leaves(tmp_path, run_memory_mb):
    app = create_app(settings(tmp_path, workers=1, run_memory_mb=run_memory_mb))
    beat = tmp_path / "beat"
    body = json.dumps({"recipe": spin(5.0, beat), "node": "spin", "layer": 0}).encode()

    async def scenario():
        sent = []
        left = asyncio.Event()

        async def receive():
            if not sent:
                sent.append(1)
                return {"type": "http.request", "body": body, "more_body": False}
            await left.wait()
            return {"type": "http.disconnect"}

        msgs = []

        async def send(m):
            msgs.append(m)

        scope = {
            "type": "http",
            "method": "POST",
            "path": "/api/preview",
            "raw_path": b"/api/preview",
            "query_string": b"",
            "headers": [
                (b"host", b"127.0.0.1"),
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
            ],
            "client": ("127.0.0.1", 5000),
            "server": ("127.0.0.1", 8000),
            "scheme": "http",
            "http_version": "1.1",
            "asgi": {"version": "3.0"},
            "root_path": "",
        }
        async with app.router.lifespan_context(app):
            task = asyncio.create_task(app(scope, receive, send))
            for _ in range(100):  # computing (a loaded machine may take a while to start)
                await asyncio.sleep(0.05)
                if beats(beat) > 5:
                    break
            assert beats(beat) > 5
            left.set()
            t0 = time.monotonic()
            await asyncio.wait_for(task, 4)
            n = beats(beat)
            await asyncio.sleep(0.3)
            return time.monotonic() - t0, n, beats(beat)

    took, n1, n2 = asyncio.run(scenario())
    assert took < 2.5 and n1 == n2  # stopped, not computing on for the 4.5 s left


def _workers_of(me: psutil.Process) -> set[int]:
    """Layer workers: the children of a fork server among this process's descendants. Not "every
    grandchild": a run's process forked from this one starts a fork server of its own, itself a
    grandchild (after tests/engine had started this process's fork server, the count read 3)."""
    procs = me.children(recursive=True)
    servers = set()
    for p in procs:
        try:
            if "multiprocessing.forkserver" in " ".join(p.cmdline()):
                servers.add(p.pid)
        except psutil.Error:  # ended meanwhile
            pass
    out = set()
    for p in procs:
        try:
            if p.ppid() in servers:
                out.add(p.pid)
        except psutil.Error:
            pass
    return out


def test_cancel_kills_layer_workers_within_2_s(tmp_path, monkeypatch):
    # toy-slow sleeps: its layers cost no CPU, so the engine's timing (CPU seconds) would keep
    # them in the run's own process; the workers are started at once instead
    parallel_now(monkeypatch)
    rec = toy.recipe(
        [("stack", "toy-stack", {"count": 40}), ("slow", "toy-slow", {"seconds": 0.4})],
        [("stack.layers", "slow.layers")],
    )
    me = psutil.Process()
    with client(tmp_path, layer_workers=2) as c:
        before = _workers_of(me)
        rid = c.post("/api/runs", json={"recipe": rec}).json()["id"]
        t0 = time.monotonic()
        workers: set[int] = set()
        while time.monotonic() - t0 < 20 and len(workers) < 2:
            workers = _workers_of(me) - before
            time.sleep(0.05)
        assert len(workers) == 2, "the run's layer workers did not start"
        time.sleep(0.5)
        t1 = time.monotonic()
        assert c.delete(f"/api/runs/{rid}").status_code in (200, 202, 204)
        run = wait(c, rid)
        while time.monotonic() - t1 < 3 and any(
            psutil.pid_exists(p) and psutil.Process(p).status() != "zombie" for p in workers
        ):
            time.sleep(0.05)
        gone = time.monotonic() - t1
        assert run["status"] == "cancelled"
        assert gone < 2.0, f"workers still there {gone:.1f} s after cancel"


def test_cancel_ends_a_blocked_run_within_2_s(tmp_path):
    rec = toy.recipe(
        [("stack", "toy-stack", {"count": 2}), ("block", "toy-block", {})], [("stack.layers", "block.layers")]
    )
    RELEASE.clear()
    try:
        with client(tmp_path) as c:
            rid = c.post("/api/runs", json={"recipe": rec}).json()["id"]
            t0 = time.monotonic()
            while c.get(f"/api/runs/{rid}").json()["status"] != "running" and time.monotonic() - t0 < 10:
                time.sleep(0.05)
            time.sleep(0.3)
            t1 = time.monotonic()
            c.delete(f"/api/runs/{rid}")
            run = wait(c, rid, timeout=10)
            assert run["status"] == "cancelled" and time.monotonic() - t1 < 2.5
            # its slot is free again: the next run runs while the blocked thread still waits
            r2 = wait(c, c.post("/api/runs", json={"recipe": toy.chain()}).json()["id"])
            assert r2["status"] == "done"
            RELEASE.set()  # the abandoned thread returns; its result is dropped
            time.sleep(0.2)
            assert c.get(f"/api/runs/{rid}").json()["status"] == "cancelled"
    finally:
        RELEASE.set()


def test_concurrent_previews_wait_their_turn(tmp_path):
    """One computing at a time (workers=1): four sent at once all answer, one after the other."""
    with client(tmp_path) as c:
        out = []

        def one(k):  # four different recipes: none answered from the cache
            out.append(
                c.post("/api/preview", json={"recipe": spin(0.3 + k / 1000), "node": "spin", "layer": 0}).status_code
            )

        t0 = time.monotonic()
        ts = [threading.Thread(target=one, args=(k,)) for k in range(4)]
        for t in ts:
            t.start()
        for t in ts:
            t.join()
        assert out == [200] * 4
        assert time.monotonic() - t0 >= 4 * 0.3 * 0.9  # not at the same time
