"""Per-run memory limit (#26 Build 3, fault 5): each run executes in a process of its own under
`run_memory_mb` of address space (resource.setrlimit RLIMIT_AS), its layer workers included (they
inherit it). A run that needs more fails with a run error naming the limit; the server, and the
other runs, go on. The allocations here fail at once, before any page is touched (the limit is on
address space), so the test uses no real memory."""

import os
import resource
import time

import numpy as np
from fastapi.testclient import TestClient
from pydantic import Field

import toy_nodes as toy
from api_util import wait_for_run as wait
from waamflow.api.app import create_app
from waamflow.engine import parallel
from waamflow.engine.node import LayerNode, Node, NodeParams, Port, register
from waamflow.settings import Settings


@register
class ToyHog(Node):
    """Allocates `mb` MB (zeroed by numpy, so a lazy mapping) and passes the layers on."""

    type = "toy-hog"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("layers", "layers"),)

    class Params(NodeParams):
        mb: int = Field(1, ge=1)

    def run(self, ctx, params, inputs):
        block = np.zeros(params.mb * 2**20, dtype=np.uint8)
        block[::4096] = 1   # touched page by page: the memory is really used when the limit allows it
        return {"layers": inputs["layers"]}


@register
class ToyLayerHog(LayerNode):
    """Allocates `mb` MB in every layer (where the layers are computed: a layer worker or the run)."""

    type = "toy-layer-hog"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("layers", "layers"),)

    class Params(NodeParams):
        mb: int = Field(1, ge=1)
        pid_dir: str = ""

    def run_layer(self, ctx, params, index, items):
        if params.pid_dir:   # who computed the layer, under which address-space limit
            with open(os.path.join(params.pid_dir, str(os.getpid())), "w") as f:
                f.write(str(resource.getrlimit(resource.RLIMIT_AS)[0]))
        block = np.zeros(params.mb * 2**20, dtype=np.uint8)
        block[::4096] = 1
        return {"layers": items["layers"]}


def _hog(mb: int, node: str = "toy-hog", count: int = 3, **extra) -> dict:
    return toy.recipe([("stack", "toy-stack", {"count": count}), ("hog", node, {"mb": mb, **extra})],
                      [("stack.layers", "hog.layers")])


def _settings(tmp_path, **kw) -> Settings:
    return Settings(data_dir=tmp_path / "data", graphs_dir=None, start_viewer=False, static_dir=None, **kw)


def test_default_is_a_share_of_the_machine_memory(tmp_path):
    total_mb = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") / 2**20
    assert Settings().run_memory_mb == round(total_mb / 2)


def test_a_run_over_its_memory_limit_fails_and_the_server_goes_on(tmp_path):
    with TestClient(create_app(_settings(tmp_path, workers=2, run_memory_mb=200, layer_workers=1))) as c:
        pid = os.getpid()
        big = c.post("/api/runs", json={"recipe": _hog(400)}).json()["id"]
        small = c.post("/api/runs", json={"recipe": _hog(20)}).json()["id"]
        rb, rs = wait(c, big), wait(c, small)
        assert rb["status"] == "failed", rb
        msg = rb["error"]["message"]
        assert rb["error"]["kind"] == "limit" and "more than 200 MB" in msg and "--run-memory-mb" in msg
        assert rb["error"]["node"] == "hog"
        assert rs["status"] == "done" and rs["summary"]["layer_count"] == 3
        # the server is alive and runs more (in its own process: the limit was the run's)
        assert os.getpid() == pid and c.get("/api/health").status_code == 200
        again = c.post("/api/runs", json={"recipe": toy.chain(stack={"count": 4})}).json()["id"]
        assert wait(c, again)["summary"]["layer_count"] == 4


def test_layer_workers_inherit_the_limit(tmp_path, monkeypatch):
    monkeypatch.setattr(parallel, "MIN_PARALLEL_S", 0.0)
    monkeypatch.setattr(parallel, "WARM_MIN_PARALLEL_S", 0.0)
    monkeypatch.setattr(parallel, "TIMING_S", 0.0)
    monkeypatch.setattr(parallel, "BACKGROUND_START", False)
    pids = tmp_path / "pids"
    pids.mkdir()
    with TestClient(create_app(_settings(tmp_path, workers=1, run_memory_mb=200, layer_workers=2))) as c:
        ok = c.post("/api/runs", json={"recipe": _hog(20, "toy-layer-hog", count=8, pid_dir=str(pids))}).json()["id"]
        assert wait(c, ok, timeout=120)["status"] == "done"
        ran_in = {int(p.name): int(p.read_text()) for p in pids.iterdir()}
        assert os.getpid() not in ran_in and len(ran_in) >= 2   # the run's process and/or its workers
        assert all(lim != resource.RLIM_INFINITY for lim in ran_in.values()), ran_in
        bad = c.post("/api/runs", json={"recipe": _hog(400, "toy-layer-hog", count=8)}).json()["id"]
        rb = wait(c, bad, timeout=120)
        assert rb["status"] == "failed" and "more than 200 MB" in rb["error"]["message"], rb
        assert c.get("/api/health").status_code == 200


def test_off_runs_in_the_server_process(tmp_path):
    pids = tmp_path / "pids"
    pids.mkdir()
    with TestClient(create_app(_settings(tmp_path, workers=1, run_memory_mb=0, layer_workers=1))) as c:
        r = c.post("/api/runs", json={"recipe": _hog(5, "toy-layer-hog", count=2, pid_dir=str(pids))}).json()["id"]
        t0 = time.monotonic()
        assert wait(c, r)["status"] == "done" and time.monotonic() - t0 < 60
        assert {int(p.name): int(p.read_text()) for p in pids.iterdir()} == {os.getpid(): resource.RLIM_INFINITY}


def test_serve_option_and_variable(monkeypatch, tmp_path):
    """`serve --run-memory-mb` overrides WAAMFLOW_RUN_MEMORY_MB, which overrides the default."""
    import uvicorn

    from waamflow import cli
    from waamflow.api import app as app_module

    got = {}
    monkeypatch.setattr(app_module, "create_app", lambda settings: got.update(mb=settings.run_memory_mb) or object())
    monkeypatch.setattr(uvicorn, "run", lambda app, host, port, **kw: None)
    monkeypatch.setenv("WAAMFLOW_DATA_DIR", str(tmp_path / "d"))
    monkeypatch.setenv("WAAMFLOW_RUN_MEMORY_MB", "700")
    assert cli.main(["serve"]) == 0 and got["mb"] == 700
    assert cli.main(["serve", "--run-memory-mb", "300"]) == 0 and got["mb"] == 300
    assert cli.main(["serve", "--run-memory-mb", "-1"]) == 2
