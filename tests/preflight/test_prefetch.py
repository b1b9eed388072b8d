"""The preflight's sections cut ahead (preflight/prefetch.py, issue #30): a plane is taken from the
prefetch only where the program's own plane equals the predicted one exactly, on the very mesh
arrays the check is given; every figure and section of the check is the one it cuts itself, and a
failed or missed prefetch leaves the check its own cuts."""

import json
import pickle
from concurrent.futures import Future

import numpy as np
import pytest
import shapely
import trimesh

from waamflow.core.model import Layer, Layered, MeshData
from waamflow.preflight import prefetch as pf
from waamflow.preflight import slabs

PART = "graphs/parts/bracket.stl"


class _Workers:
    """Workers in this process: each task and result pickled as to a worker; `fail`: every task raises."""

    def __init__(self, count: int = 2, fail: bool = False) -> None:
        self.count, self.fail, self.submitted = count, fail, []

    def pays(self, triangles, layers, points):
        return True

    def map(self, fn, items):
        return [pickle.loads(pickle.dumps(fn(pickle.loads(pickle.dumps(t))))) for t in items]

    def submit(self, fn, item):
        self.submitted.append(item)
        fut: Future = Future()
        if self.fail:
            fut.set_exception(RuntimeError("worker died"))
        else:
            fut.set_result(pickle.loads(pickle.dumps(fn(pickle.loads(pickle.dumps(item))))))
        return fut


def _mesh():
    mesh = trimesh.load(PART, force="mesh")
    v, f = np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)
    return MeshData(vertices=v, faces=f), v, f


def _layers(v, h=1.3, n=40):
    z0 = float(v[:, 2].min())
    return Layered([Layer(index=i, z=z0 + h * (i + 1), thickness=h) for i in range(n)])


def _started(monkeypatch, workers, mesh, layers):
    monkeypatch.setattr(pf, "MIN_TRIANGLES", 0)
    p = pf.SectionPrefetch()
    p.offer({"mesh": mesh}, lambda: workers)
    assert not p.started  # no layers yet
    p.offer({"layers": layers}, lambda: workers)
    assert p.started
    p._thread.join()  # every cut sent (the fake workers finish each at once)
    return p


def test_predicted_planes_are_the_programs_planes_as_the_posts_write_them():
    tops = [1.3 * k for k in range(1, 6)]  # 3.9000000000000004 among them
    got = pf.predicted_planes(0.0, tops)
    written = [float(f"{z:.3f}") for z in tops]  # what a G-code reader parses back
    mids = [z - max(z - b, 1e-6) / 2 for z, b in zip(written, [0.0] + written[:-1])]
    assert got == mids and got[2] == 3.25 and got != [z - 0.65 for z in tops]


def test_prefetched_sections_equal_the_cut_ones_and_only_exact_planes_are_taken(monkeypatch):
    mesh, v, f = _mesh()
    layers = _layers(v)
    workers = _Workers()
    p = _started(monkeypatch, workers, mesh, layers)
    mids = list(p.zs)
    mids[5] += 1e-9  # a plane the program has elsewhere: not taken
    mids.append(mids[-1] + 1.3)  # a plane never predicted
    got = p.take(mesh.vertices, mesh.faces, mids)  # waits for the tasks
    assert 2 <= len(workers.submitted) <= 2 * pf.TASKS_PER_WORKER
    assert sum(len(t.zs) for t in workers.submitted) == 40
    assert sorted(got) == [i for i in range(40) if i != 5]
    cut = slabs.cut_sections(v, f, slabs.plane_faces(v, f, mids), mids)
    for i, sec in got.items():
        assert shapely.to_wkb(sec) == shapely.to_wkb(cut[i])
    assert sum(s.area > 0 for s in got.values()) >= 30
    assert p.take(v.copy(), f, mids) == {}  # other arrays: nothing taken


def test_cover_part_with_prefetched_sections_equals_the_check_alone(monkeypatch):
    mesh, v, f = _mesh()
    p = _started(monkeypatch, _Workers(), mesh, _layers(v))
    zs = list(p.zs)
    (x0, y0, _), (x1, y1, _) = v.min(axis=0), v.max(axis=0)
    rng = np.random.default_rng(3)
    paths = [[np.column_stack([np.linspace(x0, x1, 50), y0 + (y1 - y0) * rng.uniform(0.2, 0.8, 50)])] for _ in zs]
    alone = slabs.cover_part(v, f, zs, paths, 6.0)
    known = p.take(mesh.vertices, mesh.faces, zs)
    assert len(known) == len(zs)
    for pool in (None, _Workers()):
        with_known = slabs.cover_part(v, f, zs, paths, 6.0, pool, None, known)
        for a, b in zip(alone, with_known):
            assert shapely.to_wkb(a.section) == shapely.to_wkb(b.section)
            assert (a.area, a.uncovered, a.uncovered_point) == (b.area, b.uncovered, b.uncovered_point)
    assert sum(c.uncovered > 0 for c in alone) >= 20 and sum(c.covered > 0 for c in alone) >= 20


class _Held(_Workers):
    """Workers whose tasks finish only when released (`release`): what is in flight is visible."""

    def submit(self, fn, item):
        self.submitted.append(item)
        fut: Future = Future()
        fut.item, fut.fn = item, fn
        self.futures = getattr(self, "futures", []) + [fut]
        return fut

    def release(self):
        for fut in self.futures:
            if not fut.done():
                fut.set_result(fut.fn(fut.item))
                return


def _wait_for(cond, timeout=30.0):
    import time

    t0 = time.monotonic()
    while not cond():
        assert time.monotonic() - t0 < timeout
        time.sleep(0.005)


def _trickling(monkeypatch):
    """(mesh, workers, prefetch): a prefetch started on 2 held workers, its first cut sent."""
    mesh, v, _f = _mesh()
    monkeypatch.setattr(pf, "MIN_TRIANGLES", 0)
    workers = _Held(2)
    p = pf.SectionPrefetch()
    p.offer({"mesh": mesh, "layers": _layers(v)}, lambda: workers)
    _wait_for(lambda: len(workers.submitted) == 1)
    return mesh, workers, p


def test_the_cuts_trickle_one_worker_at_a_time_until_the_preflight_waits(monkeypatch):
    """With 2 workers at most one cut is in flight: a node's own tasks queue behind one small cut,
    and a core stays with the parent. The preflight's take sends the rest at once."""
    mesh, workers, p = _trickling(monkeypatch)
    for n in (2, 3):
        workers.release()
        _wait_for(lambda: len(workers.submitted) == n)
    assert sum(not x.done() for x in workers.futures) == 1
    total = 2 * pf.TASKS_PER_WORKER
    import threading

    got = {}
    t = threading.Thread(target=lambda: got.update(p.take(mesh.vertices, mesh.faces, list(p.zs))))
    t.start()
    _wait_for(lambda: len(workers.submitted) == total)  # the rest sent at once
    while t.is_alive():
        workers.release()
    assert sorted(got) == list(range(40))
    assert sum(len(x.zs) for x in workers.submitted) == 40


def test_a_run_that_ends_early_ends_the_thread(monkeypatch):
    """A failed or cancelled run closes the prefetch (engine.executor.execute): the thread waiting
    for a worker ends at once and sends nothing more (left trickling, it would hold the mesh)."""
    mesh, workers, p = _trickling(monkeypatch)
    p.close()
    p._thread.join(timeout=30)
    assert not p._thread.is_alive() and len(workers.submitted) == 1


def test_a_failed_prefetch_leaves_the_check_its_own_cuts(monkeypatch):
    mesh, v, f = _mesh()
    p = _started(monkeypatch, _Workers(fail=True), mesh, _layers(v))
    assert p.take(mesh.vertices, mesh.faces, list(p.zs)) == {}
    p2 = pf.SectionPrefetch()
    p2.offer({"mesh": mesh, "layers": _layers(v)}, lambda: None)  # workers not up: waits for a later offer
    assert not p2.started and p2.take(mesh.vertices, mesh.faces, [1.0]) == {}


def test_small_parts_and_tilted_layers_are_not_cut_ahead():
    mesh, v, f = _mesh()
    workers = _Workers()
    p = pf.SectionPrefetch()
    p.offer({"mesh": mesh, "layers": _layers(v)}, lambda: workers)
    assert not p.started and len(f) < pf.MIN_TRIANGLES
    tilted = Layered([Layer(index=0, z=5.0, thickness=1.0, frame=np.eye(4))])
    q = pf.SectionPrefetch()
    q.vertices, q.faces = v, f
    q.offer({"layers": tilted}, lambda: workers)
    assert not q.started and workers.submitted == []


@pytest.mark.slow
def test_a_run_with_workers_takes_the_sections_it_cut_ahead(tmp_path, monkeypatch):
    """End to end: a tube whose planes the slicer predicts; the parallel run's artifacts are the
    serial run's, byte for byte, its sections came from the prefetch and its slicer cut the upper
    planes in a worker."""
    from waamflow.engine import executor
    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import parse_recipe

    tube = trimesh.creation.annulus(r_min=40.0, r_max=46.0, height=60.0, sections=400)
    tube.apply_translation([0, 0, 30.0])
    tube.export(tmp_path / "tube.stl")
    recipe = {
        "format": "waamflow/1",
        "name": "tube",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "tube.stl"}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 1.3}},
            {"id": "walls", "type": "wall-path", "params": {"speed": 10.0, "bead_width": 6.0}},
            {"id": "post", "type": "post-process", "params": {"format": "gcode"}},
        ],
        "edges": [
            {"from": "part.mesh", "to": "layers.mesh"},
            {"from": "layers.layers", "to": "walls.layers"},
            {"from": "walls.toolpath", "to": "post.toolpath"},
        ],
    }
    monkeypatch.setattr(pf, "MIN_TRIANGLES", 0)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1")
    taken: list[int] = []
    real_take = pf.SectionPrefetch.take

    def take(self, vertices, faces, zs):
        got = real_take(self, vertices, faces, zs)
        taken.append(len(got))
        return got

    monkeypatch.setattr(pf.SectionPrefetch, "take", take)
    from waamflow.slicing import planar

    split: list[int] = []
    real_job = planar._upper_job

    def upper_job(*args):
        sel, job = real_job(*args)
        split.append(len(job[3]))
        return sel, job

    monkeypatch.setattr(planar, "_upper_job", upper_job)
    monkeypatch.setattr(planar, "SPLIT_MIN_SEGMENTS", 0)  # the slicer's upper planes in a worker too
    monkeypatch.setattr(executor.parallel, "MIN_PARALLEL_S", 0.0)  # workers for this small part
    monkeypatch.setattr(executor.parallel, "BACKGROUND_START", False)  # up before the slicer ends
    graph = build_graph(parse_recipe(recipe))
    resolver = FileResolver(tmp_path)
    serial = execute(graph, resolver=resolver, workers=1)
    par = execute(graph, resolver=resolver, workers=2)
    assert taken and taken[-1] == 46  # 60 mm in 1.3 mm layers: every plane came cut ahead
    assert len(split) == 1 and 1 <= split[0] < 46  # the slicer's upper planes went to a worker
    a, b = json.loads(serial.artifacts["preflight.json"]), json.loads(par.artifacts["preflight.json"])
    assert a == b and len(a["layers"]) == 46
    assert sorted(serial.artifacts) == sorted(par.artifacts)
    for name, data in serial.artifacts.items():  # layers, toolpath, program, preflight: byte for byte
        assert par.artifacts[name] == data, name
