"""Layer-parallel execution (engine/parallel.py): same artifacts as a serial run, ordered
warnings, working per-layer cache, executor info in the summary."""

import os
from pathlib import Path

import pytest

from tests.wall_recipe import wall_recipe
from waamflow.engine import parallel
from waamflow.engine.cache import MemoryCache
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import load_recipe

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture()
def always_parallel(monkeypatch):
    monkeypatch.setattr(parallel, "MIN_PARALLEL_S", 0.0)
    monkeypatch.setattr(parallel, "WARM_MIN_PARALLEL_S", 0.0)
    monkeypatch.setattr(parallel, "TIMING_S", 0.0)
    monkeypatch.setattr(parallel, "BACKGROUND_START", False)  # workers up before the next layer: fixed split
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")  # fixed trace date: runs compare byte for byte


@pytest.fixture()
def artifact_writers(monkeypatch) -> list[str]:
    """The node ids whose artifacts were handed to the workers (`LayerPool.submit_artifacts`), in order."""
    written: list[str] = []
    submit = parallel.LayerPool.submit_artifacts

    def spy(self, impl, node_id, *args):
        written.append(node_id)
        return submit(self, impl, node_id, *args)

    monkeypatch.setattr(parallel.LayerPool, "submit_artifacts", spy)
    return written


def _run(name: str, workers: int, cache=None):
    path = GRAPHS / f"{name}.json"
    graph = build_graph(load_recipe(path))
    return execute(graph, resolver=FileResolver(path.parent), cache=cache, workers=workers)


@pytest.mark.parametrize("name", ["mpp-cross", "mpp-slotted-wall"])
def test_parallel_artifacts_are_byte_identical(name, always_parallel):
    serial = _run(name, 1)
    par = _run(name, 2)
    assert par.executor["kind"] == "local" and par.executor["workers"] == 2
    assert par.executor["tasks"] >= 2  # the layers really went to workers
    assert serial.executor["tasks"] == 0
    assert sorted(par.artifacts) == sorted(serial.artifacts)
    for k in serial.artifacts:
        assert par.artifacts[k] == serial.artifacts[k], k
    assert par.warnings == serial.warnings
    assert par.summary("x")["executor"] == par.executor


def test_parallel_fills_the_cache_layer_by_layer(always_parallel):
    cache = MemoryCache()
    first = _run("mpp-cross", 2, cache)
    assert first.stats["strategy"].layers_computed == 8
    again = _run("mpp-cross", 2, cache)
    assert again.stats["strategy"].layers_cached == 8 and again.stats["strategy"].layers_computed == 0
    assert again.executor["tasks"] == 0  # nothing left to send
    assert again.artifacts == first.artifacts


def test_small_runs_stay_serial():
    res = _run("mpp-cross", 2)
    assert res.executor["tasks"] == 0  # 8 quick layers: starting workers would not pay


def test_workers_start_in_the_background_and_write_the_artifacts(monkeypatch, artifact_writers):
    """Workers start in a thread while the parent goes on computing layers; once they are up they
    take the layers of later nodes and write the artifacts of all but the last node (the parent
    would only wait for it), byte for byte as a serial run."""
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")
    monkeypatch.setattr(parallel, "MIN_PARALLEL_S", 0.0)
    monkeypatch.setattr(parallel, "WARM_MIN_PARALLEL_S", 0.0)
    monkeypatch.setattr(parallel, "TIMING_S", 0.0)
    written = artifact_writers
    serial = _run("mpp-cross", 1)
    background = _run("mpp-cross", 2)  # who computes what depends on when the workers are up: not the result
    assert background.artifacts == serial.artifacts and background.warnings == serial.warnings
    written.clear()
    monkeypatch.setattr(parallel, "BACKGROUND_START", False)
    par = _run("mpp-cross", 2)
    # up before the first node (every run pays with MIN_PARALLEL_S 0: the cost model), so from
    # the slice node on; the last node's (post) in the parent: nothing left to overlap; nodes that
    # write no artifact (part, mask, guide) send nothing
    assert written == ["layers", "strategy", "zone", "sequence"]
    # mask's layers after its timed first go out once, as chains mask → guide → strategy → zone
    assert par.executor["tasks"] == len(parallel._chunks(list(range(7)), 2)) == 5
    assert all(par.stats[n].layers_computed == 8 for n in ("mask", "guide", "strategy", "zone"))
    assert list(par.artifacts) == list(serial.artifacts)  # same files, same order
    assert all(par.artifacts[k] == serial.artifacts[k] for k in serial.artifacts)
    assert par.warnings == serial.warnings


def test_an_artifact_failing_in_a_worker_is_reported_with_its_node(monkeypatch, artifact_writers):
    import toy_nodes as toy
    from waamflow.core.errors import PlanningError
    from waamflow.engine.recipe import parse_recipe

    monkeypatch.setattr(parallel, "MIN_PARALLEL_S", 0.0)
    monkeypatch.setattr(parallel, "TIMING_S", 0.0)
    monkeypatch.setattr(parallel, "BACKGROUND_START", False)
    sent = artifact_writers
    # area is not the last node (the last one's artifacts are written in the parent)
    graph = build_graph(
        parse_recipe(
            toy.recipe(
                [
                    ("stack", "toy-stack", {"count": 8}),
                    ("grow", "toy-grow", {}),
                    ("area", "toy-area", {"scale": -1.0}),
                    ("tail", "toy-area", {}),
                ],
                [("stack.layers", "grow.layers"), ("grow.layers", "area.layers"), ("grow.layers", "tail.layers")],
            )
        )
    )
    assert graph.order[-1] == "tail"
    events = []
    with pytest.raises(PlanningError) as e:
        execute(graph, resolver=FileResolver("."), workers=2, on_event=events.append)
    assert "area" in sent  # written by a worker, failed there, raised here with its node
    assert e.value.node == "area" and "negative area" in str(e.value)
    assert [(ev.kind, ev.node) for ev in events][-2:] == [("node_error", "area"), ("run_failed", "area")]


def test_a_long_part_starts_the_workers_before_its_first_layer_node(monkeypatch, artifact_writers):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")
    monkeypatch.setattr(parallel, "WARM_LAYERS", 8)  # mpp-cross: 8 layers
    monkeypatch.setattr(parallel, "WARM_MIN_PARALLEL_S", 0.0)
    monkeypatch.setattr(parallel, "TIMING_S", 0.0)
    monkeypatch.setattr(parallel, "BACKGROUND_START", False)
    written = artifact_writers
    serial = _run("mpp-cross", 1)
    par = _run("mpp-cross", 2)
    assert written[0] == "layers"  # up right after slicing: even its layers.json
    assert (
        par.executor["tasks"] == len(parallel._chunks(list(range(7)), 2)) == 5
    )  # the 7 layers after the timed first, one map of chains
    assert par.artifacts == serial.artifacts and par.warnings == serial.warnings


def _toy_chain(**fail):
    import toy_nodes as toy
    from waamflow.engine.recipe import parse_recipe

    return build_graph(
        parse_recipe(
            toy.recipe(
                [
                    ("stack", "toy-stack", {"count": 12}),
                    ("grow", "toy-grow", {"per_layer": {"3": 6.0, "9": 7.0}}),
                    ("check", "toy-fail", fail),
                    ("grow2", "toy-grow", {"distance": 0.5}),
                    ("area", "toy-area", {}),
                ],
                [
                    ("stack.layers", "grow.layers"),
                    ("grow.layers", "check.layers"),
                    ("check.layers", "grow2.layers"),
                    ("grow2.layers", "area.layers"),
                ],
            )
        )
    )


def test_a_chain_of_layer_nodes_runs_layer_by_layer_in_one_task(always_parallel):
    """grow → check → grow2: each layer's three nodes in one worker task (one task per chunk,
    not per node), with the warnings in layer order and the per-layer cache filled for all three."""
    import toy_nodes as toy

    serial = execute(_toy_chain(), resolver=FileResolver("."), workers=1)
    cache = MemoryCache()
    toy.CALLS.clear()
    par = execute(_toy_chain(), resolver=FileResolver("."), workers=2, cache=cache)
    assert toy.CALLS["toy-grow"] == 1 + 1  # the parent computed only the timed first layer of each grow
    assert par.executor["tasks"] == len(parallel._chunks(list(range(11)), 2)) == 7
    # every chained node's layer time is counted where it was spent (here grow's wall time holds
    # the whole chain's), so summary.json says what each node costs; whole-part nodes have none
    assert all(par.stats[n].compute_seconds > 0 for n in ("grow", "check", "grow2"))
    assert par.summary("x")["nodes"]["grow2"]["compute_seconds"] == round(par.stats["grow2"].compute_seconds, 4)
    assert par.stats["area"].compute_seconds is None and "compute_seconds" not in par.summary("x")["nodes"]["area"]
    again = execute(_toy_chain(), resolver=FileResolver("."), workers=2, cache=cache)
    assert again.stats["grow2"].compute_seconds == 0.0 and again.stats["grow2"].cached
    assert par.outputs["area"]["toolpath"] == pytest.approx(serial.outputs["area"]["toolpath"], rel=1e-12)
    assert par.outputs["area"]["toolpath"] == pytest.approx(sum((10 + 2 * d + 1) ** 2 for d in [1.0] * 10 + [6.0, 7.0]))
    assert (
        [(w["node"], w["layer"]) for w in par.warnings]
        == [("grow", 3), ("grow", 9)]
        == [(w["node"], w["layer"]) for w in serial.warnings]
    )
    for n in ("grow", "check", "grow2"):
        assert par.stats[n].layers_computed == 12 and par.stats[n].layers_cached == 0
    again = execute(_toy_chain(), resolver=FileResolver("."), workers=2, cache=cache)
    assert again.executor["tasks"] == 0 and all(again.stats[n].layers_cached == 12 for n in ("grow", "check", "grow2"))


def test_a_link_failing_in_a_worker_is_reported_with_its_node_and_layer(always_parallel):
    from waamflow.core.errors import PlanningError

    events = []
    with pytest.raises(PlanningError) as e:
        execute(_toy_chain(fail_at=7), resolver=FileResolver("."), workers=2, on_event=events.append)
    assert (e.value.node, e.value.layer, e.value.section) == ("check", 7, "bs1/A")
    assert "curve yields 2 regions" in str(e.value)
    assert [(ev.kind, ev.node) for ev in events][-2:] == [("node_error", "check"), ("run_failed", "check")]


class _Recording:
    """A layer node for `run_chain` alone: records (node, layer) per call; layer `fail` raises, and
    an output None at layer `none` ends that layer's chain as a failure does (no error)."""

    from waamflow.engine.node import NodeParams as _NodeParams

    class Params(_NodeParams):
        pass

    def __init__(self, name: str, calls: list, fail: int = -1, none: int = -1) -> None:
        self.name, self.calls, self.fail, self.none = name, calls, fail, none

    def run_layer(self, ctx, params, index, items):
        self.calls.append((self.name, index))
        if index == self.fail:
            raise ValueError(f"{self.name} fails at {index}")
        ctx.warnings.append({"node": ctx.node_id, "layer": index})
        return {"out": None if index == self.none else items["over"] + [self.name]}


def test_a_chain_runs_link_by_link_over_its_chunk_with_the_same_results_per_layer():
    """Each link over the whole chunk before the next link (one node's code over a run of layers:
    ~27% less CPU than layer by layer on the 500-layer cross); a layer whose link failed or gave
    None goes no further, the other layers go on; results, warnings and the order of the rows
    per layer are those of a layer-by-layer walk."""
    calls: list = []
    a = _Recording("a", calls, fail=2)
    b = _Recording("b", calls, none=3)
    c = _Recording("c", calls)
    chain = (
        parallel.ChainLink(a, "A", {}),
        parallel.ChainLink(b, "B", {}, "over", "out"),
        parallel.ChainLink(c, "C", {}, "over", "out"),
    )
    chunk = [(i, {"over": [i]}) for i in range(5)]
    got, ahead = parallel.run_chain(chain, FileResolver("."), chunk)
    assert ahead == []  # no tail
    assert calls == [("a", 0), ("a", 1), ("a", 2), ("a", 3), ("a", 4)] + [("b", i) for i in (0, 1, 3, 4)] + [
        ("c", i) for i in (0, 1, 4)
    ]
    assert [i for i, _ in got] == [0, 1, 2, 3, 4]
    rows = dict(got)
    assert [len(rows[i]) for i in range(5)] == [3, 3, 1, 2, 3]
    assert rows[2][0][0] is None and rows[2][0][1] == "ValueError: a fails at 2"
    assert rows[3][1][0] == {"out": None}
    assert rows[4][2][0] == {"out": [4, "a", "b", "c"]}
    assert rows[4][2][1] == [{"node": "C", "layer": 4}] and rows[0][1][1] == [{"node": "B", "layer": 0}]
    assert all(sec >= 0.0 for i in range(5) for _, _, sec in rows[i])


class _Ahead:
    """A whole-part node's `run_ahead` for `run_chain` alone: records the runs it is given;
    raises on a run holding `fail`."""

    from waamflow.engine.node import NodeParams as _NodeParams

    class Params(_NodeParams):
        pass

    def __init__(self, fail=None) -> None:
        self.fail = fail

    def run_ahead(self, params, items):
        if self.fail is not None and self.fail in items:
            raise ValueError("speculation failed")
        return ("ran", items)


def test_a_chain_tail_runs_ahead_on_each_run_of_consecutive_layers_of_the_last_links_output():
    """`ChainTail`: after the links, the tail's `run_ahead` gets the last link's output of each
    run of consecutive layers of the chunk (None where a layer's chain ended early); a run whose
    speculation fails gives nothing (the node does that work itself), the others still count."""
    calls: list = []
    a = _Recording("a", calls, fail=3)
    b = _Recording("b", calls)
    chain = (parallel.ChainLink(a, "A", {}), parallel.ChainLink(b, "B", {}, "over", "out"))
    chunk = [(i, {"over": [i]}) for i in (0, 1, 2, 3, 4, 7, 8)]
    rows, ahead = parallel.run_chain(chain, FileResolver("."), chunk, parallel.ChainTail(_Ahead(), "T", {}, "out"))
    assert [i for i, _ in rows] == [0, 1, 2, 3, 4, 7, 8]
    assert ahead == [
        ("ran", [[0, "a", "b"], [1, "a", "b"], [2, "a", "b"], None, [4, "a", "b"]]),
        ("ran", [[7, "a", "b"], [8, "a", "b"]]),
    ]
    failing = parallel.ChainTail(_Ahead(fail=[7, "a", "b"]), "T", {}, "out")
    _, ahead = parallel.run_chain(chain, FileResolver("."), chunk, failing)
    assert [len(items) for _, items in ahead] == [5]
    # params the worker cannot validate: no speculation, the chunk's rows all there
    invalid = parallel.ChainTail(_Ahead(), "T", {"no_such_param": 1}, "out")
    rows2, ahead = parallel.run_chain(chain, FileResolver("."), chunk, invalid)
    assert ahead == [] and [i for i, _ in rows2] == [i for i, _ in rows]


def _started_at(seconds: float) -> float:
    """Worker side: when this task started (monotonic clock, shared by the processes), after a nap."""
    import time

    t = time.monotonic()
    time.sleep(seconds)
    return t


class _StampNode:
    """A node whose artifact says when and in which process it was written."""

    from waamflow.engine.node import NodeParams as _NodeParams

    class Params(_NodeParams):
        pass

    def artifacts(self, ctx, params, outputs):
        import time

        return {"t": repr(time.monotonic()), "pid": str(os.getpid())}


def _held_artifacts(pool):
    return pool.submit_artifacts(_StampNode(), "n", _StampNode.Params(), FileResolver("."), {}, {})


def test_a_nodes_artifacts_wait_for_the_next_nodes_tasks(monkeypatch):
    """Artifacts handed over before the next node's tasks: a map's wait has the parent write them
    (nothing pickled to a worker and back); behind a single submit they go to a worker after that
    task; with no task coming a worker gets them within ARTIFACTS_DEFER_S; asking for them computes
    them here at once; a map from another thread sends them to the workers (only the run's thread
    writes them); closing the pool drops what was never sent."""
    import concurrent.futures as cf
    import threading
    import time

    monkeypatch.setattr(parallel, "BACKGROUND_START", False)
    me = str(os.getpid()).encode()
    pool = parallel.LayerPool(2)
    try:
        pool.warm()
        assert pool.ready
        held = _held_artifacts(pool)
        t0 = time.monotonic()
        starts = pool.map(_started_at, [0.05, 0.05, 1.0, 1.0])  # the last two run ~1 s after the first ends
        t1 = time.monotonic()
        assert held.done()  # written while the map's tasks ran
        files, warnings = held.result(timeout=0)
        assert warnings == [] and files["pid"] == me and t0 <= float(files["t"]) <= t1 and len(starts) == 4
        behind = _held_artifacts(pool)
        first = pool.submit(_started_at, 0.2)
        files = behind.result(timeout=60)[0] if cf.wait([behind], timeout=60).done else {}
        assert files["pid"] != me and first.result(timeout=60) > 0  # sent with the task, not written here
        monkeypatch.setattr(parallel, "ARTIFACTS_DEFER_S", 0.05)
        alone = _held_artifacts(pool)
        assert cf.wait([alone], timeout=30).done == {alone}  # the timer sent it
        assert alone.result()[0]["pid"] != me
        monkeypatch.setattr(parallel, "ARTIFACTS_DEFER_S", 600.0)
        asked = _held_artifacts(pool)
        assert asked.result(timeout=0)[0]["pid"] == me
        elsewhere = _held_artifacts(pool)  # a map from another thread than the run's leaves them to the workers
        side = threading.Thread(target=pool.map, args=(_started_at, [0.01, 0.01]))
        side.start()
        side.join()
        assert elsewhere.result(timeout=60)[0]["pid"] != me
        kept = _held_artifacts(pool)
    finally:
        pool.close()
    assert kept.cancelled()  # never sent: the run is over


def test_warm_waits_a_moment_for_the_workers_once_the_fork_server_runs(monkeypatch):
    """The first start in a process goes on in the background (the fork server imports ~0.4 s);
    once the server runs, `warm` first waits up to WARM_WAIT_S for the forks (~0.05 s alone,
    several times that beside a parent computing), then lets them finish in the background."""
    import threading
    import time

    monkeypatch.setattr(parallel, "BACKGROUND_START", False)
    first = parallel.LayerPool(2)
    first.warm()
    first.close()
    assert first.ready and parallel._server_up  # a start that succeeded says the server runs
    gate = threading.Event()

    def held_spawn(self):
        gate.wait(30)
        self._ready.set()

    monkeypatch.setattr(parallel.LayerPool, "_spawn", held_spawn)
    monkeypatch.setattr(parallel, "BACKGROUND_START", True)
    monkeypatch.setattr(parallel, "WARM_WAIT_S", 1.0)
    spent = {}
    for up in (False, True):
        monkeypatch.setattr(parallel, "_server_up", up)
        gate.clear()
        pool = parallel.LayerPool(2)
        t = time.monotonic()
        pool.warm()
        spent[up] = time.monotonic() - t
        assert not pool.ready and pool.warming
        gate.set()
        pool.close()
    assert spent[False] < 1.0 <= spent[True]


@pytest.mark.parametrize("n, workers", [(1, 2), (7, 2), (11, 2), (499, 2), (499, 8), (5000, 4)])
def test_chunks_are_guided_large_first_and_small_at_the_end(n, workers):
    """Every layer once, in order; sizes never grow; the last chunk (the run's tail, when one
    worker may wait for the other) is at most 1/(workers·16) of the layers (or one layer)."""
    chunks = parallel._chunks(list(range(n)), workers)
    assert [i for c in chunks for i in c] == list(range(n))
    sizes = [len(c) for c in chunks]
    assert all(a >= b for a, b in zip(sizes, sizes[1:]))
    assert sizes[-1] <= max(1, -(-n // (workers * parallel.CHUNKS_PER_WORKER * 4)))
    assert sizes[0] == -(-n // (2 * workers)) or n < 2 * workers
    assert len(chunks) <= 4 * workers * parallel.CHUNKS_PER_WORKER  # round trips stay few


# ---- the cost model (issue #30): parallel from the run's size, not from the first layers' time ----
def test_the_cost_model_keeps_a_small_recipe_serial_and_sends_the_bench_vase_to_the_workers():
    # the bench vase: 1,008,000 triangles, 133 layers, 68,000 path points -> 4.9 s of shareable work
    assert parallel.parallel_work_s(1_008_000, 133, 68_000) == pytest.approx(2.52 + 0.665 + 1.7)
    assert parallel.wants_workers(2, 1_008_000, 133, 68_000)
    assert parallel.wants_workers(2, triangles=1_008_000)  # its mesh file alone decides, at the start
    assert not parallel.wants_workers(1, 1_008_000, 133, 68_000)  # one worker: serial
    # mpp-cross (graphs/): 8 layers of a small mesh -> ~0.05 s, serial
    assert parallel.parallel_work_s(2_000, 8, 1_500) < 0.1
    assert not parallel.wants_workers(2, 2_000, 8, 1_500)
    assert not parallel.wants_workers(2, 700_000)  # 1.75 s < MIN_PARALLEL_S 2 s
    assert parallel.wants_workers(2, 900_000)
    # graphs/bracket.json: 56 triangles, 300 layers, 4,760 path points -> 1.62 s: serial (the
    # workers lost there at every load measured); the 500-layer cross of bench_replan: parallel
    assert parallel.parallel_work_s(56, 300, 4_760) == pytest.approx(1.619, abs=1e-3)
    assert not parallel.wants_workers(2, 56, 300, 4_760)
    assert parallel.wants_workers(2, 0, 500)
    assert parallel.WARM_LAYERS == 400  # the layer count alone starts them where the model would


def _sleepy_grow(monkeypatch, seconds: float, busy: bool) -> list[int]:
    """toy-grow's layers take `seconds` each (sleeping, or busy on the CPU); the returned list
    gets one entry per start of the workers."""
    import time

    import toy_nodes as toy

    real = toy.ToyGrow.run_layer

    def slow(self, ctx, params, index, items):
        if busy:  # `seconds` of this thread's CPU, however busy the machine
            t = time.thread_time()
            while time.thread_time() - t < seconds:
                pass
        else:
            time.sleep(seconds)
        return real(self, ctx, params, index, items)

    monkeypatch.setattr(toy.ToyGrow, "run_layer", slow)
    started: list[int] = []
    warm = parallel.LayerPool.warm

    def spy(self):
        if not self.started:
            started.append(1)
        return warm(self)

    monkeypatch.setattr(parallel.LayerPool, "warm", spy)
    monkeypatch.setattr(parallel, "MIN_PARALLEL_S", 0.3)
    monkeypatch.setattr(parallel, "COST_LAYER_S", 0.0)  # the first layers' time alone decides
    monkeypatch.setattr(parallel, "BACKGROUND_START", False)
    return started


def _stack_and_grow(count: int):
    import toy_nodes as toy
    from waamflow.engine.recipe import parse_recipe

    return build_graph(
        parse_recipe(
            toy.recipe(
                [("stack", "toy-stack", {"count": count}), ("grow", "toy-grow", {})],
                [("stack.layers", "grow.layers")],
            )
        )
    )


def test_the_first_layers_are_timed_in_cpu_seconds_so_a_busy_machine_does_not_start_the_workers(monkeypatch):
    """30 layers that wait 20 ms each (as a layer does when other processes hold the cores) and
    use no CPU: 29 × 20 ms = 0.58 s of wall time > 0.3 s, but ~0 s of CPU: serial (the wall
    clock started the workers here). The same layers busy on the CPU for 20 ms each start them."""
    started = _sleepy_grow(monkeypatch, 0.02, busy=False)
    idle = execute(_stack_and_grow(30), resolver=FileResolver("."), workers=2)
    assert started == [] and idle.executor["tasks"] == 0
    started = _sleepy_grow(monkeypatch, 0.02, busy=True)
    busy = execute(_stack_and_grow(30), resolver=FileResolver("."), workers=2)
    assert started == [1] and busy.artifacts == idle.artifacts


def test_file_triangles_is_exact_for_binary_stl_and_a_bound_otherwise():
    n = 1_008_000
    head = b"waamflow bench".ljust(80, b" ") + n.to_bytes(4, "little")
    assert parallel.file_triangles(84 + 50 * n, head) == n
    assert parallel.file_triangles(84 + 50 * n + 1, head) == (84 + 50 * n + 1) // 50  # not a binary STL's size
    assert parallel.file_triangles(25_000, b"solid x\n  facet normal 0 0 1") == 500


def _vase_recipe(tmp_path: Path, triangles: int) -> Path:
    """A mesh → slice → wall-path recipe whose STL header and size say `triangles` (a sparse file:
    the cost model reads only the size and the first 84 bytes)."""
    import json

    stl = tmp_path / "vase.stl"
    with open(stl, "wb") as fh:
        fh.write(b"vase".ljust(80, b" ") + triangles.to_bytes(4, "little"))
        fh.truncate(84 + 50 * triangles)
    rec = {
        "format": "waamflow/1",
        "name": "v",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "vase.stl"}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 1.5}},
            {"id": "walls", "type": "wall-path", "params": {"bead_width": 6.0}},
        ],
        "edges": [{"from": "part.mesh", "to": "layers.mesh"}, {"from": "layers.layers", "to": "walls.layers"}],
    }
    (tmp_path / "vase.json").write_text(json.dumps(rec))
    return tmp_path / "vase.json"


@pytest.mark.parametrize("triangles, started", [(1_008_000, True), (606_000, True), (200_000, False), (1_000, False)])
def test_a_large_mesh_file_starts_the_workers_before_the_first_node(tmp_path, triangles, started):
    from waamflow.engine.executor import _Run

    path = _vase_recipe(tmp_path, triangles)
    graph = build_graph(load_recipe(path))
    pool = parallel.LayerPool(2)
    warmed: list[bool] = []
    pool.warm = lambda: warmed.append(True)  # type: ignore[method-assign]  # what would start them
    run = _Run(graph, FileResolver(path.parent), None, None, None, None, list(graph.order), True, pool)
    run.warm_by_cost()
    assert run.size[0] == triangles
    assert bool(warmed) is started


def test_the_run_size_after_each_node_feeds_the_cost_model(monkeypatch):
    """mpp-cross (8 layers) stays serial; the same run with the per-layer cost 100 times higher
    (as a run of 800 layers) starts the workers right after slicing, before any layer node."""
    started_after: list[str] = []
    warm = parallel.LayerPool.warm

    def spy(self):
        if not self.started:
            started_after.append(next(iter(reversed(spy.run.outputs))) if spy.run.outputs else "")
        return warm(self)

    from waamflow.engine import executor as ex

    init = ex._Run.__init__

    def keep(self, *a, **k):
        init(self, *a, **k)
        spy.run = self

    monkeypatch.setattr(ex._Run, "__init__", keep)
    monkeypatch.setattr(parallel.LayerPool, "warm", spy)
    small = _run("mpp-cross", 2)
    assert started_after == [] and small.executor["tasks"] == 0
    monkeypatch.setattr(parallel, "COST_LAYER_S", 0.5)  # 8 layers -> 4 s
    _run("mpp-cross", 2)
    assert started_after == ["layers"]


def test_the_preflight_checks_a_parts_layers_in_the_workers_with_the_same_report(always_parallel, monkeypatch):
    mapped: list[int] = []
    pmap = parallel.LayerPool.map

    def spy(self, fn, items):
        mapped.append(len(items))
        return pmap(self, fn, items)

    monkeypatch.setattr(parallel.LayerPool, "map", spy)
    serial = _run("mpp-cross", 1)
    par = _run("mpp-cross", 2)
    assert mapped and sum(mapped) >= 2  # the layers' slab checks went to the workers
    assert par.artifacts["preflight.json"] == serial.artifacts["preflight.json"]
    assert par.preflight == serial.preflight and par.preflight["verdict"] == serial.preflight["verdict"]


def test_wall_path_rings_centre_lines_in_the_workers_give_the_same_program(always_parallel, monkeypatch, tmp_path):
    """A tube's ring layers: the wall-path node's centre lines computed in the workers (ctx.map,
    once they are up and the cost model says so), the laps placed here: every artifact identical
    to a serial run, the preflight's report included."""
    import json

    import trimesh

    trimesh.creation.annulus(r_min=30.0, r_max=36.0, height=30.0, sections=256).export(tmp_path / "tube.stl")
    rec = wall_recipe("tube.stl")
    (tmp_path / "tube.json").write_text(json.dumps(rec))
    mapped: list[str] = []
    pmap = parallel.LayerPool.map

    def spy(self, fn, items):
        mapped.append(fn.__name__)
        return pmap(self, fn, items)

    monkeypatch.setattr(parallel.LayerPool, "map", spy)
    graph = build_graph(load_recipe(tmp_path / "tube.json"))
    serial = execute(graph, resolver=FileResolver(tmp_path), workers=1)
    assert mapped == [] and serial.layer_count == 20
    par = execute(graph, resolver=FileResolver(tmp_path), workers=2)
    assert "_centerlines" in mapped
    assert sorted(par.artifacts) == sorted(serial.artifacts) and "post.gcode" in par.artifacts
    for k in serial.artifacts:
        assert par.artifacts[k] == serial.artifacts[k], k
    assert par.warnings == serial.warnings


def test_the_fork_server_preloads_the_nodes_without_trimesh():
    """trimesh (the preflight's slab check only) preloaded by the fork server delayed every
    worker's start by ~0.45 s; each worker imports it with its first slab task. The preflight's
    own modules are preloaded: each worker imported them with its first layer task."""
    import subprocess
    import sys

    probe = (
        "import gc, sys, waamflow.engine.warm; print('trimesh' in sys.modules, 'scipy' in sys.modules, "
        "'waamflow.nodes.thinwall' in sys.modules, 'waamflow.preflight.slabs' in sys.modules, "
        "'waamflow.preflight.read.gcode' in sys.modules, gc.get_freeze_count() > 10000)"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120).stdout.split()
    # the preflight's layer tasks find theirs loaded; what was loaded is frozen (workers' collections skip it)
    assert out == ["False", "False", "True", "True", "True", "True"]


def test_the_sequence_nodes_layers_are_sequenced_ahead_in_the_workers(always_parallel, monkeypatch, parent_sequenced):
    """A 40-layer cross: the sequence node's runs of layers go to the workers (the parent sequences
    none itself: every guess is the chain's), the conservation check's read-backs too; the
    artifacts are the serial run's byte for byte."""
    from waamflow.engine.recipe import apply_overrides, parse_set
    from waamflow.preflight import conserve

    here = parent_sequenced
    submitted = []
    submit = parallel.RunWorkers.submit
    monkeypatch.setattr(
        parallel.RunWorkers, "submit", lambda self, fn, it: submitted.append(fn) or submit(self, fn, it)
    )
    recipe = apply_overrides(
        load_recipe(GRAPHS / "mpp-cross.json"), parse_set(["layers.layer_height=0.3", "layers.layer_count=40"])
    )

    def run(workers):
        return execute(build_graph(recipe), resolver=FileResolver(GRAPHS), cache=MemoryCache(), workers=workers)

    serial = run(1)
    assert len(here) == 40
    here.clear()
    par = run(2)
    assert here == []  # the workers sequenced every layer (in forked processes: not counted here)
    assert submitted == [conserve.arc_on_of_doc] * 2  # the zone's and the sequence's toolpath.json, side by side
    assert sorted(par.artifacts) == sorted(serial.artifacts)
    for k in serial.artifacts:
        assert par.artifacts[k] == serial.artifacts[k], k
    assert par.warnings == serial.warnings


def test_the_zoned_layers_are_sequenced_ahead_in_the_chain_tasks_that_made_them(
    always_parallel, monkeypatch, parent_sequenced, ahead_given
):
    """A 40-layer cross without a parameter file (the zone's combine keeps its layers): the
    sequence node's layers are sequenced in the chain tasks right after they were zoned (the
    chain's tail), none sent to the workers again; the parent sequences only the first layers of
    the chunks that start where the chain has a torch position, until the chain meets the guesses;
    byte-identical artifacts. With the parameter file (the zone's combine makes new layers) no
    task runs ahead and the runs of layers go to the workers as before."""
    from waamflow.engine.recipe import apply_overrides, parse_set

    here, given = parent_sequenced, ahead_given
    mapped = []
    real_map = parallel.RunWorkers.map
    monkeypatch.setattr(
        parallel.RunWorkers, "map", lambda self, fn, items: mapped.append(fn.__name__) or real_map(self, fn, items)
    )
    tails = []
    real_layers = parallel.LayerPool.map_layers

    def spy_layers(self, chain, resolver, todo, on_done, cancelled, tail=None, on_ahead=None):
        tails.append(None if tail is None else tail.node_id)
        return real_layers(self, chain, resolver, todo, on_done, cancelled, tail, on_ahead)

    monkeypatch.setattr(parallel.LayerPool, "map_layers", spy_layers)

    def run(workers, params_file):
        sets = ["layers.layer_height=0.3", "layers.layer_count=40", f"zone.parameters={params_file}"]
        recipe = apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set(sets))
        return execute(build_graph(recipe), resolver=FileResolver(GRAPHS), cache=MemoryCache(), workers=workers)

    serial = run(1, "")
    assert len(here) == 40
    assert given == [[]]  # nothing ran ahead of a serial run
    here.clear()
    tails.clear()
    given.clear()
    par = run(2, "")
    chunks = len(parallel._chunks(list(range(39)), 2))  # the parent times layer 0's chain itself
    assert tails == ["sequence"]  # the mask's map: mask → guide → strategy → zone, then sequence ahead
    assert len(given) == 1 and len(given[0]) == chunks  # one run of consecutive layers a task
    assert sum(len(run) for run in given[0]) == 39
    assert "_sequence_chunk" not in mapped
    assert len(here) == 1 + chunks  # layer 0 (timed in the parent) and each chunk's first (given nothing)
    assert sorted(par.artifacts) == sorted(serial.artifacts)
    for k in serial.artifacts:
        assert par.artifacts[k] == serial.artifacts[k], k
    assert par.warnings == serial.warnings
    tails.clear()
    mapped.clear()
    given.clear()
    par = run(2, "mpp-cross.params.xml")
    assert tails == [None] and given == [[]] and "_sequence_chunk" in mapped


def test_the_artifacts_held_for_a_map_go_to_the_workers_when_the_next_node_took_its_layers_ahead(
    always_parallel, monkeypatch
):
    """The cross without a parameter file: the sequence node takes its layers from the chain tasks
    and computes in the parent while the workers idle, so the artifacts held for a next map (the
    strategy's and zone's) go to the workers before it runs, instead of after their timer
    (ARTIFACTS_DEFER_S) or when the run collects them after the last node (the 500-layer cross:
    ~0.2 s between the last node and the preflight). Byte-identical artifacts."""
    from waamflow.engine.recipe import apply_overrides, parse_set
    from waamflow.nodes.sequence import SequenceNode

    monkeypatch.setattr(parallel, "ARTIFACTS_DEFER_S", 600.0)  # no timer sends them
    events: list[tuple[str, ...]] = []
    release = parallel.LayerPool._release

    def spy_release(self):
        events.append(("sent", *(args[1] for _fut, _fn, args in self._deferred)))
        return release(self)

    monkeypatch.setattr(parallel.LayerPool, "_release", spy_release)
    seq_run = SequenceNode.run
    monkeypatch.setattr(SequenceNode, "run", lambda *a: events.append(("sequence",)) or seq_run(*a))
    sets = ["layers.layer_height=0.3", "layers.layer_count=40", "zone.parameters="]
    recipe = apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set(sets))

    def run(workers):
        return execute(build_graph(recipe), resolver=FileResolver(GRAPHS), cache=MemoryCache(), workers=workers)

    serial = run(1)
    events.clear()
    par = run(2)
    assert par.executor["tasks"] > 1
    before = events[: events.index(("sequence",))]
    assert {"strategy", "zone"} <= {nid for e in before if e[0] == "sent" for nid in e[1:]}
    assert sorted(par.artifacts) == sorted(serial.artifacts)
    for k in serial.artifacts:
        assert par.artifacts[k] == serial.artifacts[k], k


def test_the_pool_comes_up_with_every_worker_when_the_parent_is_slow_between_submits(monkeypatch):
    """The executor forks a worker only when none is idle: a start-up task that ended before the
    next submit left its worker idle, and the pool of 2 came up with 1 (tests/api/test_run_memory.py's
    guard test failed so on a loaded machine). Each start-up task now waits for the others' submits;
    here the parent sleeps 0.3 s after each submit."""
    import time

    make = parallel.LayerPool._executor

    def slow(self):
        ex = make(self)
        if not getattr(ex, "_slowed", False):
            submit = ex.submit

            def slowly(*args, **kwargs):
                fut = submit(*args, **kwargs)
                time.sleep(0.3)
                return fut

            ex.submit = slowly
            ex._slowed = True
        return ex

    monkeypatch.setattr(parallel.LayerPool, "_executor", slow)
    pool = parallel.LayerPool(2)
    try:
        pool._spawn()
        assert pool.ready and len(set(pool.pids())) == 2
    finally:
        pool.close()
