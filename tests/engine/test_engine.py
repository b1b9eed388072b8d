import threading

import pytest

import toy_nodes as toy
from waamflow.core.errors import CancelledError, PlanningError, RecipeError
from waamflow.engine.cache import MemoryCache
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, parse_recipe, parse_set


def run(data, cache=None, **kw):
    graph = build_graph(parse_recipe(data))
    events = []
    res = execute(graph, resolver=FileResolver("."), cache=cache, on_event=events.append, **kw)
    return res, events


def test_values_flow_and_area_is_right():
    res, events = run(toy.chain(grow={"distance": 1.0}, stack={"size": 10, "count": 4}))
    # square 10 mm grown by 1 mm with mitre joins → 12 × 12 per layer
    assert res.outputs["area"]["toolpath"] == pytest.approx(4 * 144.0, rel=1e-9)
    assert res.layer_count == 4
    kinds = [e.kind for e in events]
    assert kinds[0] == "run_started" and kinds[-1] == "run_finished"
    assert kinds.count("node_finished") == 3
    assert [e.seq for e in events] == sorted(e.seq for e in events)


def test_downstream_edit_keeps_upstream_cached():
    cache = MemoryCache()
    run(toy.chain(), cache)
    toy.CALLS.clear()
    res, events = run(toy.chain(area={"scale": 2.0}), cache)
    assert res.stats["stack"].cached and res.stats["grow"].cached and not res.stats["area"].cached
    assert toy.CALLS == {"toy-area": 1}
    assert {e.node for e in events if e.kind == "node_cached"} == {"stack", "grow"}


def test_one_layer_edit_recomputes_one_layer():
    cache = MemoryCache()
    run(toy.chain(stack={"count": 50}), cache)
    toy.CALLS.clear()
    res, _ = run(toy.chain(stack={"count": 50}, grow={"per_layer": {"17": 2.0}}), cache)
    assert toy.CALLS["toy-grow"] == 1
    st = res.stats["grow"]
    assert (st.layers_total, st.layers_cached, st.layers_computed) == (50, 49, 1)
    # layer 17 grown by 2 mm: 14 × 14; the others 12 × 12
    assert res.outputs["area"]["toolpath"] == pytest.approx(49 * 144 + 196)


def test_restricted_layers_compute_only_those():
    toy.CALLS.clear()
    res, _ = run(toy.chain(stack={"count": 30}), MemoryCache(), layers=[3], targets=["grow"])
    assert toy.CALLS["toy-grow"] == 1
    items = res.outputs["grow"]["layers"].items
    assert items[3] is not None and sum(i is not None for i in items) == 1
    assert "area" not in res.outputs


def test_planning_error_names_node_layer_section():
    data = toy.recipe(
        [("stack", "toy-stack", {"count": 10}), ("f", "toy-fail", {"fail_at": 7})], [("stack.layers", "f.layers")]
    )
    with pytest.raises(PlanningError) as ei:
        run(data)
    err = ei.value
    assert (err.node, err.layer, err.section) == ("f", 7, "bs1/A")
    assert "layer 7" in str(err) and "bs1/A" in str(err) and err.exit_code == 3


def test_a_geometry_kernel_error_says_what_to_look_at_and_where():
    """GEOS's own text ("TopologyException: side location conflict at x y") reached the user bare
    (the cow of common-3d-test-models, before the slicer made its self-crossing sections valid)."""
    data = toy.recipe(
        [("stack", "toy-stack", {"count": 10}), ("f", "toy-fail", {"fail_at": 4, "geos": True})],
        [("stack.layers", "f.layers")],
    )
    with pytest.raises(PlanningError) as ei:
        run(data)
    err = ei.value
    assert (err.node, err.layer, err.exit_code) == ("f", 4, 3)
    msg = str(err)
    assert "GEOSException: TopologyException: side location conflict" in msg
    assert "outline near (-83.64, -15.39) mm" in msg and "repair the mesh" in msg


def test_warnings_are_replayed_from_cache():
    cache = MemoryCache()
    data = toy.chain(grow={"per_layer": {"2": 6.0}})
    r1, _ = run(data, cache)
    r2, _ = run(data, cache)
    assert r1.warnings == r2.warnings == [{"node": "grow", "message": "large growth", "layer": 2}]


@pytest.mark.parametrize(
    "mutate, needle",
    [
        (lambda d: d["nodes"].append({"id": "x", "type": "nope", "params": {}}), "unknown node type 'nope'"),
        (lambda d: d["edges"].append({"from": "stack.layers", "to": "area.bogus"}), "no input port 'bogus'"),
        (lambda d: d["edges"].__setitem__(1, {"from": "grow.layers", "to": "area.layerz"}), "no input port 'layerz'"),
        (lambda d: d["nodes"][0].__setitem__("params", {"count": 0}), "greater than or equal to 1"),
        (lambda d: d["nodes"][0].__setitem__("params", {"cuont": 3}), "cuont"),
        (lambda d: d["nodes"][0].__setitem__("params", {"count": "$n"}), "unknown input $n"),
        (lambda d: d["edges"].pop(0), "required input 'layers'"),
        (lambda d: d["nodes"].append({"id": "stack", "type": "toy-stack", "params": {}}), "duplicate node id"),
        (lambda d: d.__setitem__("format", "waamflow/9"), "unsupported recipe format"),
        (lambda d: d["edges"].append({"from": "stack", "to": "grow.layers"}), 'must be "nodeid.port"'),
    ],
)
def test_invalid_recipes_are_named(mutate, needle):
    data = toy.chain()
    mutate(data)
    with pytest.raises(RecipeError) as ei:
        run(data)
    assert needle in str(ei.value)
    assert ei.value.exit_code == 2


def test_type_mismatch_and_cycle():
    data = toy.recipe(
        [("stack", "toy-stack", {}), ("a", "toy-area", {}), ("g", "toy-grow", {})],
        [("stack.layers", "a.layers"), ("a.toolpath", "g.layers")],
    )
    with pytest.raises(
        RecipeError, match="type mismatch: output 'toolpath' is toolpath, input 'layers' expects layers"
    ):
        run(data)
    data = toy.recipe(
        [("g1", "toy-grow", {}), ("g2", "toy-grow", {})], [("g1.layers", "g2.layers"), ("g2.layers", "g1.layers")]
    )
    with pytest.raises(RecipeError, match="cycle"):
        run(data)


def test_inputs_and_set_overrides():
    data = toy.chain(stack={"count": "$n", "size": "$size"}, inputs={"n": 3, "size": 5})
    r = apply_overrides(parse_recipe(data), parse_set(["n=6", "grow.distance=0.5", "grow.per_layer.0=1.5"]))
    res = execute(build_graph(r), resolver=FileResolver("."))
    assert res.layer_count == 6
    assert res.outputs["area"]["toolpath"] == pytest.approx(5 * 36 + 64)
    with pytest.raises(RecipeError, match="unknown input 'm'"):
        apply_overrides(parse_recipe(data), parse_set(["m=6"]))
    with pytest.raises(RecipeError, match="no node with id 'nope'"):
        apply_overrides(parse_recipe(data), parse_set(["nope.x=1"]))
    assert parse_set(["a=[1, 2]", "b=semicircular", "c=4.5"]) == [("a", [1, 2]), ("b", "semicircular"), ("c", 4.5)]


def test_old_format_and_legacy_type_ids_migrate():
    data = toy.chain()
    data["format"] = "waamflow/0"
    data["edges"] = [{"source": e["from"], "target": e["to"]} for e in data["edges"]]
    r = parse_recipe(data)
    assert r.format == "waamflow/1" and r.edges[0].from_ == "stack.layers"
    legacy = parse_recipe({"nodes": [{"id": "s", "type": "simulate", "params": {}}]})
    assert legacy.nodes[0].type == "simulate-robot"


def test_cancel_stops_between_layers():
    cancel = threading.Event()
    cancel.set()
    with pytest.raises(CancelledError):
        run(toy.chain(stack={"count": 100}), cancel=cancel)


def test_file_signature_dirties_on_content_change(tmp_path):
    f = tmp_path / "a.txt"
    f.write_text("one")
    r = FileResolver(tmp_path)
    s1 = r.signature("a.txt")
    f.write_text("two!")
    assert r.signature("a.txt") != s1
    assert r.signature("missing.txt") == "missing"
    with pytest.raises(Exception, match="outside the allowed folders"):
        FileResolver(tmp_path, roots=[tmp_path]).read_bytes("../etc/passwd")


def test_files_a_node_reads_by_name_join_its_cache_key(tmp_path):
    """A node that reads files named in a plain param (simulate-robot: a user's cell and its
    meshes) says so in `read_files`: editing any of them recomputes it, nothing else does."""
    (tmp_path / "list.txt").write_text("a.txt b.txt")
    (tmp_path / "a.txt").write_text("1.5")
    (tmp_path / "b.txt").write_text("2.25")
    graph = build_graph(parse_recipe(toy.recipe([("r", "toy-reads", {"listing": "list.txt"})], [])))
    cache = MemoryCache()

    def total():
        res = execute(graph, resolver=FileResolver(tmp_path), cache=cache)
        return res.outputs["r"]["toolpath"], res.stats["r"].cached, res.trace["inputs"]

    assert total()[:2] == (3.75, False)
    value, cached, inputs = total()
    assert (value, cached) == (3.75, True)
    assert set(inputs) == {"list.txt", "a.txt", "b.txt"}  # traced like FileRef inputs
    (tmp_path / "b.txt").write_text("4.0")  # a file named inside the listing
    assert total()[:2] == (5.5, False)
    (tmp_path / "list.txt").write_text("a.txt")  # the listing itself
    assert total()[:2] == (1.5, False)
    (tmp_path / "b.txt").write_text("9")  # no longer read: still cached
    assert total()[:2] == (1.5, True)


def test_signatures_tell_values_apart_and_ignore_key_order():
    import numpy as np

    from waamflow.engine.cache import signature

    base = {"speed": 6.5, "pattern": "raster", "split_points": [[1.0, 2.0]]}
    assert signature(base) == signature(dict(reversed(list(base.items()))))  # key order
    assert signature(base) != signature({**base, "speed": 6.50001})
    assert signature(None) != signature(float("nan")) != signature(float("inf"))  # orjson writes all three as null
    assert signature({"v": None}) != signature({"v": float("nan")})
    assert signature(2**70) != signature(2**70 + 1)  # beyond orjson's 64-bit ints
    assert signature({1: "a"}) == signature({"1": "a"})  # JSON keys are strings
    assert signature(np.arange(4.0)) != signature(np.arange(4.0) + 1e-12)  # arrays by their bytes
    assert signature(np.float64(1.5)) == signature(1.5)
    assert signature("a", "b") != signature("ab") != signature(["a", "b"])


def test_node_finished_says_how_long_a_layer_nodes_layers_took():
    res, events = run(toy.chain(stack={"count": 6}))
    done = {e.node: e for e in events if e.kind == "node_finished"}
    assert done["grow"].compute_seconds == round(res.stats["grow"].compute_seconds, 4) > 0
    assert done["grow"].compute_seconds <= done["grow"].seconds  # serial: inside its wall time
    assert done["stack"].compute_seconds is None and done["area"].compute_seconds is None
    assert "compute_seconds" not in done["area"].to_dict()


def test_cached_plain_nodes_layers_keep_their_signatures(monkeypatch):
    """A plain node's layered output (the slice's layers) is signed once, when it is computed: a
    cache hit reuses those per-layer signatures instead of hashing every layer's WKB again (a
    one-layer preview of the 300-layer bracket spent ~6 ms doing so on every edit)."""
    import waamflow.engine.executor as ex

    signed = []
    real = ex._layer_item_signature

    def counting(item, fallback):
        signed.append(item.index)
        return real(item, fallback)

    monkeypatch.setattr(ex, "_layer_item_signature", counting)
    cache = MemoryCache()
    first, _ = run(toy.chain(stack={"count": 40}), cache)
    assert len(signed) == 40
    signed.clear()
    again, _ = run(toy.chain(stack={"count": 40}, area={"scale": 2.0}), cache, layers=[17])
    assert again.stats["stack"].cached and signed == []
    assert again.outputs["stack"]["layers"].sigs == first.outputs["stack"]["layers"].sigs
    assert len(set(first.outputs["stack"]["layers"].sigs)) == 40
    # the same layer-17 edit as without the reuse: one grow layer recomputed, its sig a new one
    toy.CALLS.clear()
    third, _ = run(toy.chain(stack={"count": 40}, grow={"per_layer": {"17": 2.0}}), cache)
    assert signed == [] and toy.CALLS["toy-grow"] == 1
    assert third.stats["grow"].layers_cached == 39


def test_a_run_freezes_what_the_process_held_before_it_and_unfreezes_it_after():
    """The objects alive before the run are frozen for its garbage collections (they scan the run's
    objects only) and unfrozen after, whether the run ends well or fails; a caller that froze its
    own (a server's run process) keeps them frozen. The switch interval is 1 ms during the run."""
    import gc
    import sys

    assert gc.get_freeze_count() == 0
    seen = []
    graph = build_graph(parse_recipe(toy.chain(stack={"count": 3})))
    switch = sys.getswitchinterval()
    execute(
        graph,
        resolver=FileResolver("."),
        on_event=lambda e: seen.append((e.kind, gc.get_freeze_count(), sys.getswitchinterval())),
    )
    during = [(n, sw) for kind, n, sw in seen if kind.startswith("node_")]
    assert len(during) >= 6 and min(n for n, _ in during) > 1000  # the test process's objects, frozen
    assert max(sw for _, sw in during) == pytest.approx(0.001)  # helper threads get the interpreter back sooner
    assert gc.get_freeze_count() == 0 and sys.getswitchinterval() == switch
    bad = toy.recipe(
        [("stack", "toy-stack", {"count": 3}), ("f", "toy-fail", {"fail_at": 1})], [("stack.layers", "f.layers")]
    )
    with pytest.raises(PlanningError):
        execute(build_graph(parse_recipe(bad)), resolver=FileResolver("."))
    assert gc.get_freeze_count() == 0 and sys.getswitchinterval() == switch
    gc.freeze()
    try:
        held = gc.get_freeze_count()
        execute(graph, resolver=FileResolver("."), cache=MemoryCache())
        assert gc.get_freeze_count() > held - 100  # still frozen (less what the run freed of them)
    finally:
        gc.unfreeze()


def test_overlapping_runs_leave_the_interpreter_as_it_was():
    """Two runs in threads, the first ending while the second still runs: the second keeps the
    run's settings until it ends, and then the process has its own back (each run saving and
    restoring its own would have left the second's view of them: 1 ms, frozen)."""
    import gc
    import sys

    switch = sys.getswitchinterval()
    graph = build_graph(parse_recipe(toy.chain(stack={"count": 2})))
    b_started, a_done = threading.Event(), threading.Event()
    seen_b: list[tuple[float, int]] = []

    def on_a(e):
        if e.kind == "node_started" and e.node == "stack":
            assert b_started.wait(30)

    def on_b(e):
        if e.kind == "node_started" and e.node == "stack":
            b_started.set()
            assert a_done.wait(30)
        if e.kind == "node_finished":
            seen_b.append((sys.getswitchinterval(), gc.get_freeze_count()))

    def run_a():
        try:
            execute(graph, resolver=FileResolver("."), cache=MemoryCache(), on_event=on_a)
        finally:
            a_done.set()

    ta, tb = (
        threading.Thread(target=run_a),
        threading.Thread(target=lambda: execute(graph, resolver=FileResolver("."), cache=MemoryCache(), on_event=on_b)),
    )
    ta.start(), tb.start()
    ta.join(60), tb.join(60)
    assert a_done.is_set() and len(seen_b) == 3
    assert all(sw == pytest.approx(0.001) and n > 1000 for sw, n in seen_b)  # B ran on after A ended
    assert sys.getswitchinterval() == switch and gc.get_freeze_count() == 0


def test_the_disk_cache_commits_unsynced_and_the_store_synced(tmp_path):
    """The disk cache's commits are not synced to the disk (synchronous NORMAL, WAL: a power cut
    loses at most the last entries, computed again; a GUI preview's edit puts ~4), and what a user
    made, the store's graphs and runs, stays synced on every commit (FULL)."""
    from waamflow.api.store import Store
    from waamflow.engine.cache import SqliteCache

    cache = SqliteCache(tmp_path / "cache.sqlite")
    cache.put("k", {"a": 1})
    assert cache._conn.execute("PRAGMA synchronous").fetchone()[0] == 1  # NORMAL
    assert cache._conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    store = Store(tmp_path / "store.sqlite")
    assert store._conn.execute("PRAGMA synchronous").fetchone()[0] == 2  # FULL
    assert SqliteCache(tmp_path / "cache.sqlite").get("k") == {"a": 1}
