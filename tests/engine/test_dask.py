"""Layers on a Dask cluster (engine/daskpool.py DaskPool): same artifacts as a serial run, executor
info in the summary, a clear error for a scheduler that is not there."""

from pathlib import Path

import pytest

from waamflow.core.errors import RecipeError
from waamflow.engine import daskpool, parallel
from waamflow.engine.cache import MemoryCache
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import load_recipe

import distributed  # noqa: E402  (a declared dependency: a missing one fails, never skips)

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as c:
        yield c


@pytest.fixture()
def always_parallel(monkeypatch):
    monkeypatch.setattr(parallel, "DASK_MIN_PARALLEL_S", 0.0)
    monkeypatch.setattr(parallel, "TIMING_S", 0.0)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")  # fixed trace date: runs compare byte for byte


def _run(name: str, cache=None, **kw):
    path = GRAPHS / f"{name}.json"
    graph = build_graph(load_recipe(path))
    return execute(graph, resolver=FileResolver(path.parent), cache=cache, **kw)


@pytest.mark.parametrize("name", ["mpp-cross", "mpp-slotted-wall"])
def test_dask_artifacts_equal_a_serial_run(name, cluster, always_parallel):
    serial = _run(name, workers=1)
    dask = _run(name, scheduler=cluster.scheduler_address)
    assert dask.executor == {
        "kind": "dask",
        "address": cluster.scheduler_address,
        "workers": 2,
        "tasks": dask.executor["tasks"],
    }
    # the layers after mask's timed first one go out once, as chains mask → guide → strategy →
    # zone, in guided chunks (large first, small last); the first layer's chain stays in the parent
    layers = len(serial.outputs["zone"]["toolpath"])
    assert dask.executor["tasks"] == len(parallel._chunks(list(range(layers - 1)), daskpool.CHUNK_SPLIT * 2)) <= 8
    for node in ("mask", "guide", "strategy", "zone"):
        assert dask.stats[node].layers_computed == layers
    assert sorted(dask.artifacts) == sorted(serial.artifacts)
    for k in serial.artifacts:
        assert dask.artifacts[k] == serial.artifacts[k], k
    assert dask.warnings == serial.warnings
    assert dask.summary("x")["executor"]["kind"] == "dask"


def test_dask_fills_the_cache_layer_by_layer(cluster, always_parallel):
    cache = MemoryCache()
    first = _run("mpp-cross", cache, scheduler=cluster.scheduler_address)
    assert first.stats["strategy"].layers_computed == 8 and first.executor["tasks"] > 0
    again = _run("mpp-cross", cache, scheduler=cluster.scheduler_address)
    assert again.stats["strategy"].layers_cached == 8 and again.executor["tasks"] == 0
    assert again.artifacts == first.artifacts


def test_unreachable_scheduler_is_a_clear_error(monkeypatch):
    monkeypatch.setattr(parallel, "DASK_CONNECT_S", 0.5)
    with pytest.raises(RecipeError, match="cannot reach the Dask scheduler at 'tcp://127.0.0.1:8209'"):
        _run("mpp-cross", scheduler="tcp://127.0.0.1:8209")


def test_cli_run_with_scheduler(cluster, always_parallel, tmp_path, monkeypatch, capsys):
    import json

    from waamflow.cli import main

    monkeypatch.setenv("WAAMFLOW_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "out"
    assert (
        main(
            ["run", str(GRAPHS / "mpp-slotted-wall.json"), "--out", str(out), "--scheduler", cluster.scheduler_address]
        )
        == 0
    )
    ex = json.loads((out / "summary.json").read_text())["executor"]
    assert ex["kind"] == "dask" and ex["address"] == cluster.scheduler_address and ex["workers"] == 2
    assert ex["tasks"] > 0
    # the server's setting comes from the same environment variable
    from waamflow.settings import Settings

    monkeypatch.setenv("WAAMFLOW_SCHEDULER", "tcp://127.0.0.1:8208")
    assert Settings().scheduler == "tcp://127.0.0.1:8208"
    # and an unreachable one from the CLI is exit 2 with the address in the message
    monkeypatch.setattr(parallel, "DASK_CONNECT_S", 0.5)
    assert main(["run", str(GRAPHS / "mpp-slotted-wall.json"), "--out", str(tmp_path / "o2"), "--no-cache"]) == 2
    assert "cannot reach the Dask scheduler at 'tcp://127.0.0.1:8208'" in capsys.readouterr().err


def test_the_preflight_checks_the_layers_on_the_cluster_with_the_same_report(cluster, always_parallel, monkeypatch):
    """The preflight's slab checks and the conservation read-backs go to the cluster (`DaskWorkers`):
    in the parent they were most of what a Dask run took more than a local one (bench_replan)."""
    mapped, submitted = [], []
    pmap, psubmit = daskpool.DaskWorkers.map, daskpool.DaskWorkers.submit
    monkeypatch.setattr(daskpool.DaskWorkers, "map", lambda self, fn, it: mapped.append(len(it)) or pmap(self, fn, it))
    monkeypatch.setattr(
        daskpool.DaskWorkers, "submit", lambda self, fn, it: submitted.append(fn.__name__) or psubmit(self, fn, it)
    )
    serial = _run("mpp-cross", workers=1)
    dask = _run("mpp-cross", scheduler=cluster.scheduler_address)
    assert mapped and sum(mapped) >= 2  # the layers' slab checks
    assert submitted == ["arc_on_of_doc"] * 2  # one task per toolpath.json read back
    assert dask.artifacts["preflight.json"] == serial.artifacts["preflight.json"]
    assert dask.preflight == serial.preflight


def test_the_sequence_nodes_layers_are_sequenced_ahead_on_the_cluster(cluster, always_parallel, monkeypatch):
    """A 40-layer cross: the sequence node's runs of layers go to the cluster (8 tasks), the
    artifacts are the serial run's byte for byte."""
    from waamflow.engine.recipe import apply_overrides, parse_set

    mapped = []
    pmap = daskpool.DaskWorkers.map
    monkeypatch.setattr(
        daskpool.DaskWorkers, "map", lambda self, fn, it: mapped.append((fn.__name__, len(it))) or pmap(self, fn, it)
    )
    recipe = apply_overrides(
        load_recipe(GRAPHS / "mpp-cross.json"), parse_set(["layers.layer_height=0.3", "layers.layer_count=40"])
    )
    serial = execute(build_graph(recipe), resolver=FileResolver(GRAPHS), workers=1)
    dask = execute(build_graph(recipe), resolver=FileResolver(GRAPHS), scheduler=cluster.scheduler_address)
    assert ("_sequence_chunk", 8) in mapped
    assert sorted(dask.artifacts) == sorted(serial.artifacts)
    for k in serial.artifacts:
        assert dask.artifacts[k] == serial.artifacts[k], k


def test_the_zoned_layers_are_sequenced_ahead_in_the_clusters_chain_tasks(
    cluster, always_parallel, monkeypatch, ahead_given
):
    """The same cross without a parameter file: its layers are sequenced in the chain tasks that
    zoned them (the chain's tail); nothing is mapped to the cluster for the sequence node, the
    parent takes a guess for all but each task's first layer; artifacts the serial run's."""
    from waamflow.engine.recipe import apply_overrides, parse_set

    given = ahead_given
    mapped = []
    pmap = daskpool.DaskWorkers.map
    monkeypatch.setattr(
        daskpool.DaskWorkers, "map", lambda self, fn, it: mapped.append(fn.__name__) or pmap(self, fn, it)
    )
    sets = ["layers.layer_height=0.3", "layers.layer_count=40", "zone.parameters="]
    recipe = apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set(sets))
    serial = execute(build_graph(recipe), resolver=FileResolver(GRAPHS), workers=1)
    given.clear()
    dask = execute(build_graph(recipe), resolver=FileResolver(GRAPHS), scheduler=cluster.scheduler_address)
    assert "_sequence_chunk" not in mapped
    assert len(given) == 1 and len(given[0]) == dask.executor["tasks"]
    assert sum(len(run) for run in given[0]) == 39  # layer 0's chain is timed in the parent
    assert sorted(dask.artifacts) == sorted(serial.artifacts)
    for k in serial.artifacts:
        assert dask.artifacts[k] == serial.artifacts[k], k


def test_every_task_carries_its_work_pickled_once(cluster, always_parallel, monkeypatch):
    """The tasks sent to the cluster carry bytes (or a scattered future), never the objects: the
    scheduler unpickles a task's arguments and pickles them again for the worker, and relays the
    results; bytes it only copies (engine/daskpool.py). The run's artifacts stay the serial ones."""
    args: list[type] = []
    psubmit, pmap = distributed.Client.submit, distributed.Client.map

    def submit(self, fn, *a, **k):
        args.extend(type(x) for x in a)
        return psubmit(self, fn, *a, **k)

    def cmap(self, fn, *its, **k):
        for it in its:
            args.extend(type(x) for x in it)
        return pmap(self, fn, *its, **k)

    monkeypatch.setattr(distributed.Client, "submit", submit)
    monkeypatch.setattr(distributed.Client, "map", cmap)
    serial = _run("mpp-cross", workers=1)
    dask = _run("mpp-cross", scheduler=cluster.scheduler_address)
    layers = len(serial.outputs["zone"]["toolpath"])
    chunks = len(parallel._chunks(list(range(layers - 1)), daskpool.CHUNK_SPLIT * 2))
    # the chain's chunks (shared part + chunk each), the preflight's slab tasks and read-backs
    assert len(args) >= 2 * chunks + 2
    assert set(args) == {bytes}
    assert dask.artifacts == serial.artifacts


def test_a_large_shared_part_is_scattered_once(cluster, always_parallel, monkeypatch):
    """A chain whose links and whole inputs pickle to more than SHARED_INLINE_BYTES goes to every
    worker once (a scattered future in each task): same artifacts."""
    monkeypatch.setattr(daskpool, "SHARED_INLINE_BYTES", 0)
    scattered: list[int] = []
    pscatter = distributed.Client.scatter
    monkeypatch.setattr(
        distributed.Client, "scatter", lambda self, data, **k: scattered.append(len(data)) or pscatter(self, data, **k)
    )
    serial = _run("mpp-cross", workers=1)
    dask = _run("mpp-cross", scheduler=cluster.scheduler_address)
    assert scattered == [1]  # the mask node's chain, once
    assert dask.executor["tasks"] > 1
    assert dask.artifacts == serial.artifacts


def _fails_on_three(x: int) -> int:
    if x == 3:
        raise ValueError(f"item {x} refused")
    return x * x


def test_dask_workers_map_and_submit_give_the_values(cluster, monkeypatch):
    """`DaskWorkers.map` and `submit` hand back fn(item) unpickled; a task's own error is raised in
    the parent (the map computes here again, where the error is reported)."""
    pool = daskpool.DaskPool(cluster.scheduler_address)
    try:
        workers = daskpool.DaskWorkers(pool)
        assert workers.map(_fails_on_three, [0, 1, 2, 4]) == [0, 1, 4, 16]
        assert pool.map_tasks == 4
        fut = workers.submit(_fails_on_three, 5)
        assert fut is not None and fut.result() == 25
        with pytest.raises(ValueError, match="item 3 refused"):
            workers.map(_fails_on_three, [2, 3])
        with pytest.raises(ValueError, match="item 3 refused"):
            workers.submit(_fails_on_three, 3).result()
    finally:
        pool.close()


def test_the_worker_count_is_asked_once_per_ttl(cluster, monkeypatch):
    pool = daskpool.DaskPool(cluster.scheduler_address)
    try:
        client = pool.client()
        calls: list[int] = []
        pinfo = client.scheduler_info
        monkeypatch.setattr(client, "scheduler_info", lambda **k: calls.append(1) or pinfo(**k))
        assert [pool.workers for _ in range(5)] == [2] * 5
        assert len(calls) == 1
        monkeypatch.setattr(daskpool, "WORKERS_TTL_S", -1.0)
        assert [pool.workers for _ in range(3)] == [2] * 3
        assert len(calls) == 4
    finally:
        pool.close()


def test_artifacts_are_written_here_while_the_cluster_computes(cluster, always_parallel, monkeypatch):
    """A node's artifacts (all but the last node's) are held, then written in this process while
    it waits for the cluster's next tasks, never sent to the cluster; byte for byte a serial run's.
    A node whose artifacts fail there is written again by the run, which reports its own error."""
    held: list[str] = []
    written_in_wait: list[str] = []
    psubmit, pwork = daskpool.DaskPool.submit_artifacts, daskpool.DaskPool.work_held

    def submit_artifacts(self, impl, node_id, *a):
        held.append(node_id)
        return psubmit(self, impl, node_id, *a)

    def work_held(self, futures):
        before = [h for h in self._held if h.held]
        pwork(self, futures)
        written_in_wait.extend(str(len(before)) for h in before if not h.held)

    monkeypatch.setattr(daskpool.DaskPool, "submit_artifacts", submit_artifacts)
    monkeypatch.setattr(daskpool.DaskPool, "work_held", work_held)
    serial = _run("mpp-cross", workers=1)
    dask = _run("mpp-cross", scheduler=cluster.scheduler_address)
    order = list(build_graph(load_recipe(GRAPHS / "mpp-cross.json")).order)
    assert held and order[-1] not in held and set(held) <= set(order)
    assert len(written_in_wait) >= 1  # at least the nodes before the sequence node's map
    assert dask.artifacts == serial.artifacts
    assert dask.warnings == serial.warnings


def test_held_artifacts_that_fail_are_written_again_by_the_run(cluster, always_parallel, monkeypatch):
    """Held artifacts whose writer fails (None, error) are written again by the run itself (which
    raises a node's own error with its context): the same files."""
    from waamflow.engine import parallel as par

    real = par._write_artifacts
    failed: list[str] = []

    def flaky(impl, node_id, *a):
        failed.append(node_id)
        return None, "RuntimeError: disk gone"

    monkeypatch.setattr(par, "_write_artifacts", flaky)
    dask = _run("mpp-cross", scheduler=cluster.scheduler_address)
    monkeypatch.setattr(par, "_write_artifacts", real)
    serial = _run("mpp-cross", workers=1)
    last = list(build_graph(load_recipe(GRAPHS / "mpp-cross.json")).order)[-1]
    assert len(failed) >= 2 and last not in failed  # held ones went through it; the last node's not
    assert dask.artifacts == serial.artifacts


def test_held_artifacts_wait_for_a_first_task_at_most_wait_first_s(monkeypatch):
    """`work_held` polls the map's futures for a first end; tasks that never end (a stalled
    cluster) hold the artifacts back WAIT_FIRST_S at most, then they are written all the same."""
    import time

    class Never:
        def done(self) -> bool:
            return False

    monkeypatch.setattr(daskpool, "WAIT_FIRST_S", 0.2)
    pool = daskpool.DaskPool("tcp://127.0.0.1:1")  # never connected: holding needs no cluster
    graph = build_graph(load_recipe(GRAPHS / "mpp-cross.json"))
    serial = _run("mpp-cross", workers=1)
    gnode = graph.nodes["strategy"]
    held = pool.submit_artifacts(
        gnode.impl, "strategy", gnode.params, FileResolver(GRAPHS), serial.trace, serial.outputs["strategy"]
    )
    assert held.held
    t0 = time.perf_counter()
    pool.work_held([Never(), Never()])
    waited = time.perf_counter() - t0
    assert 0.19 <= waited < 1.5 and not held.held
    files, warnings = held.result()
    assert files["toolpath.json"] == serial.artifacts["strategy.toolpath.json"] and warnings == []


def test_the_held_artifacts_go_to_the_cluster_when_the_next_node_took_its_layers_ahead(
    cluster, always_parallel, monkeypatch
):
    """The cross without a parameter file: the sequence node computes here on the layers the
    chain tasks sequenced ahead, the cluster idle meanwhile, so the artifacts held for the next
    map (the strategy's and zone's) are sent to the cluster before it runs, not written here
    after the last node; byte-identical artifacts."""
    from waamflow.engine.recipe import apply_overrides, parse_set
    from waamflow.nodes.sequence import SequenceNode

    events: list[tuple[str, ...]] = []
    send = daskpool.HeldArtifacts.send
    monkeypatch.setattr(
        daskpool.HeldArtifacts,
        "send",
        lambda self, client: events.append(("sent", self._args[1])) or send(self, client),
    )
    seq_run = SequenceNode.run
    monkeypatch.setattr(SequenceNode, "run", lambda *a: events.append(("sequence",)) or seq_run(*a))
    sets = ["layers.layer_height=0.3", "layers.layer_count=40", "zone.parameters="]
    recipe = apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set(sets))
    serial = execute(build_graph(recipe), resolver=FileResolver(GRAPHS), workers=1)
    events.clear()
    dask = execute(build_graph(recipe), resolver=FileResolver(GRAPHS), scheduler=cluster.scheduler_address)
    before = events[: events.index(("sequence",))]
    assert {"strategy", "zone"} <= {e[1] for e in before if e[0] == "sent"}
    assert sorted(dask.artifacts) == sorted(serial.artifacts)
    for k in serial.artifacts:
        assert dask.artifacts[k] == serial.artifacts[k], k


def test_held_artifacts_the_cluster_fails_or_refuses_are_written_here(monkeypatch):
    """`HeldArtifacts.send`: a task the cluster loses, or a submit it refuses, leaves the artifacts
    to this process, written once when asked for."""
    written = []
    monkeypatch.setattr(parallel, "_write_artifacts", lambda *args: written.append(args[1]) or ({"x": b"1"}, []))

    class Lost:
        def result(self, timeout=None):
            raise OSError("worker lost")

    class Client:
        def __init__(self, fail_submit):
            self.fail_submit = fail_submit

        def submit(self, fn, blob, pure=False):
            if self.fail_submit:
                raise RuntimeError("closed")
            return Lost()

    for fail_submit in (False, True):
        held = daskpool.HeldArtifacts(("impl", f"node{fail_submit}", {}, None, {}, {}))
        held.send(Client(fail_submit))
        assert held.held is fail_submit  # sent, or still held here
        assert held.result() == ({"x": b"1"}, []) and held.result() == ({"x": b"1"}, [])
    assert written == ["nodeFalse", "nodeTrue"]
