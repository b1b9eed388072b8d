"""Per-run resource limits: wall time, layers, path points, artifact size, memory; queue → 429."""

import time
from pathlib import Path

import numpy as np
from fastapi.testclient import TestClient
from pydantic import Field

import slow_nodes  # noqa: F401  (registers toy-slow)
import toy_nodes as toy
from api_util import wait_for_run as wait
from waamflow.api.app import create_app
from waamflow.core.model import Layered, LayerPaths, SectionPath
from waamflow.engine.node import Node, NodeParams, Port, register
from waamflow.settings import Settings


@register
class ToyPaths(Node):
    """One straight path of `points` points per layer; writes `bytes` bytes of artifact."""

    type = "toy-paths"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("toolpath", "toolpath"),)

    class Params(NodeParams):
        points: int = Field(10, ge=2)
        bytes: int = Field(10, ge=0)

    def run(self, ctx, params, inputs):
        n = params.points
        out = []
        for layer in inputs["layers"]:
            pts = np.column_stack([np.linspace(0, 10, n), np.zeros(n), np.full(n, layer.z)])
            sp = SectionPath("a", "toy", pts, np.ones(n - 1, bool), np.ones(n - 1, bool), np.full(n - 1, 10.0))
            out.append(LayerPaths(layer, (sp,)))
        return {"toolpath": Layered(tuple(out))}

    def artifacts(self, ctx, params, outputs):
        return {"blob.txt": "x" * params.bytes}


@register
class ToyEscape(Node):
    """Writes one artifact under the name given (to try names that leave the run folder)."""

    type = "toy-escape"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("layers", "layers"),)

    class Params(NodeParams):
        name: str = "x.txt"

    def run(self, ctx, params, inputs):
        return {"layers": inputs["layers"]}

    def artifacts(self, ctx, params, outputs):
        return {params.name: "escaped"}


def _client(tmp_path, **kw):
    s = Settings(data_dir=tmp_path / "data", graphs_dir=None, start_viewer=False, static_dir=None, workers=1, **kw)
    return TestClient(create_app(s))


def slow(count=5, seconds=0.05):
    return toy.recipe(
        [("stack", "toy-stack", {"count": count}), ("slow", "toy-slow", {"seconds": seconds})],
        [("stack.layers", "slow.layers")],
    )


def paths(count=3, points=10, nbytes=10):
    return toy.recipe(
        [("stack", "toy-stack", {"count": count}), ("p", "toy-paths", {"points": points, "bytes": nbytes})],
        [("stack.layers", "p.layers")],
    )


def _limit(c, recipe):
    r = c.post("/api/runs", json={"recipe": recipe})
    assert r.status_code == 202, r.text
    run = wait(c, r.json()["id"])
    return run


def test_limits_fail_runs_with_reason(tmp_path):
    with _client(tmp_path, run_timeout_s=0.5, max_layers=20, max_points=1000, max_artifact_mb=0.01) as c:
        ok = _limit(c, paths(count=3, points=100, nbytes=1000))
        assert ok["status"] == "done", ok
        t0 = time.monotonic()
        run = _limit(c, slow(count=20, seconds=0.5))  # would take 10 s (20 layers: within max_layers)
        assert time.monotonic() - t0 < 15.0  # ended by the limit, with a wide margin for a loaded machine
        assert run["finished"] - run["started"] < 15.0
        assert run["status"] == "failed" and run["error"]["kind"] == "limit"
        assert "run_timeout_s" in run["error"]["message"]
        log = c.get(f"/api/runs/{run['id']}/log").json()
        assert log[-1]["kind"] == "run_failed"

        run = _limit(c, slow(count=25, seconds=0))
        assert run["status"] == "failed" and "max_layers" in run["error"]["message"]
        run = _limit(c, paths(count=3, points=400))  # 1200 points
        assert run["status"] == "failed" and "1200 path points" in run["error"]["message"]
        run = _limit(c, paths(count=1, nbytes=20_000))  # 20 kB > 10.24 kB
        assert run["status"] == "failed" and "max_artifact_mb" in run["error"]["message"]
        assert c.get(f"/api/runs/{run['id']}/artifacts").json() == []


def test_memory_limit(tmp_path):
    with _client(tmp_path, max_memory_mb=1) as c:  # the server itself is far over 1 MB
        run = _limit(c, slow(count=20, seconds=0.1))
        assert run["status"] == "failed" and "max_memory_mb" in run["error"]["message"]


def test_full_queue_is_429(tmp_path):
    with _client(tmp_path, max_queued_runs=2, run_timeout_s=5) as c:
        ids = [c.post("/api/runs", json={"recipe": slow(count=20, seconds=0.1)}).json()["id"] for _ in range(2)]
        r = c.post("/api/runs", json={"recipe": slow()})
        assert r.status_code == 429 and int(r.headers["retry-after"]) >= 1
        assert r.json()["detail"]["kind"] == "busy"
        for i in ids:
            c.delete(f"/api/runs/{i}")
        for i in ids:
            assert wait(c, i)["status"] == "cancelled"
        assert c.post("/api/runs", json={"recipe": slow(count=1)}).status_code == 202


def test_artifact_names_never_leave_the_run_folder(tmp_path):
    with _client(tmp_path) as c:
        for name in ("../escaped.txt", "../../escaped.txt", "/tmp/escaped.txt", "sub/escaped.txt", ".hidden", ".."):
            rec = toy.recipe(
                [("stack", "toy-stack", {"count": 1}), ("e", "toy-escape", {"name": name})],
                [("stack.layers", "e.layers")],
            )
            run = _limit(c, rec)
            assert run["status"] == "failed" and "not a plain file name" in run["error"]["message"], (name, run)
            assert c.get(f"/api/runs/{run['id']}/artifacts").json() == []
        ok = _limit(
            c,
            toy.recipe(
                [("stack", "toy-stack", {"count": 1}), ("e", "toy-escape", {"name": "fine.txt"})],
                [("stack.layers", "e.layers")],
            ),
        )
        assert ok["status"] == "done"
        assert c.get(f"/api/runs/{ok['id']}/artifacts/e.fine.txt").text == "escaped"  # prefixed by the node id
    assert not [p for p in tmp_path.rglob("escaped.txt")] and not Path("/tmp/escaped.txt").exists()


def test_upload_size_limit(tmp_path):
    with _client(tmp_path, max_upload_mb=1) as c:
        assert c.put("/api/graphs/g", json=toy.chain()).status_code == 201
        r = c.put("/api/graphs/g/files/big.stl", content=b"x" * (1024 * 1024 + 1))
        assert r.status_code == 413 and r.json()["detail"]["kind"] == "too_large"
        assert "1 MB" in r.json()["detail"]["message"]
        assert c.put("/api/graphs/g/files/ok.stl", content=b"x" * (1024 * 1024)).status_code == 204
        assert [f["name"] for f in c.get("/api/graphs/g/files").json()] == ["ok.stl"]
