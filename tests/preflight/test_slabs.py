"""The preflight's planar slabs in tasks (preflight/slabs.py, issue #30): the plane search finds
what a scan per plane finds, and the layers checked in tasks (as the run's workers do, pickled
there and back) give every figure and section of the check done in one piece, bit for bit."""

import pickle

import numpy as np
import pytest
import shapely
import trimesh

from waamflow.preflight import slabs

PARTS = ["graphs/parts/bracket.stl", "graphs/parts/duct.stl", "graphs/parts/curved_bracket.stl"]


def _scan(vertices, faces, zs):
    """The search it replaced: per plane, the faces with zmin ≤ z in a stable zmin order, then zmax ≥ z."""
    tri_z = vertices[:, 2][faces]
    zmin, zmax = tri_z.min(axis=1), tri_z.max(axis=1)
    order = np.argsort(zmin, kind="stable")
    out = []
    for z in zs:
        cand = order[: np.searchsorted(zmin[order], z, side="right")]
        out.append(cand[zmax[cand] >= z])
    return out


@pytest.mark.parametrize("path", PARTS)
def test_plane_faces_equal_a_scan_per_plane(path, monkeypatch):
    mesh = trimesh.load(path, force="mesh")
    v, f = np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)
    z0, z1 = mesh.bounds[:, 2]
    zs = list(np.linspace(z0 - 1, z1 + 1, 41)) + [
        float(v[0, 2]),
        float(z0 + 1.0),
        float(z0 + 1.0),
    ]  # a vertex's z, a repeat
    zs = zs[::-1]  # planes in any order
    got, ref = slabs.plane_faces(v, f, zs), _scan(v, f, zs)
    assert [len(g) for g in got] == [len(r) for r in ref] and sum(len(r) for r in ref) > 100
    assert all(np.array_equal(g, r) for g, r in zip(got, ref))
    assert len(got[3]) == 0 and len(got[-1]) == 0  # above the top, below the bottom
    monkeypatch.setattr(slabs, "MAX_PAIRS", 0)  # the fallback scan gives the same
    assert all(np.array_equal(g, r) for g, r in zip(slabs.plane_faces(v, f, zs), ref))


class _Pickled:
    """Workers in this process: each task and result goes through pickle, as to a worker."""

    def __init__(self, count: int, pays: bool = True) -> None:
        self.count, self._pays, self.tasks = count, pays, []

    def pays(self, triangles, layers, points):
        return self._pays

    def map(self, fn, items):
        self.tasks = [pickle.loads(pickle.dumps(t)) for t in items]
        return [pickle.loads(pickle.dumps(fn(t))) for t in self.tasks]


def _part_and_paths(path):
    mesh = trimesh.load(path, force="mesh")
    z0, z1 = mesh.bounds[:, 2]
    zs = list(np.linspace(z0 + 0.75, z1 - 0.75, 37))
    (x0, y0, _), (x1, y1, _) = mesh.bounds
    rng = np.random.default_rng(5)
    paths = [[np.column_stack([np.linspace(x0, x1, 60), y0 + (y1 - y0) * rng.uniform(0.2, 0.8, 60)])] for _ in zs]
    return np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64), zs, paths


@pytest.mark.parametrize("path", PARTS)
def test_layers_checked_in_tasks_equal_the_check_in_one_piece(path):
    v, f, zs, paths = _part_and_paths(path)
    whole = slabs.cover_part(v, f, zs, paths, 6.0)
    pool = _Pickled(2)
    split = slabs.cover_part(v, f, zs, paths, 6.0, pool)
    assert 2 <= len(pool.tasks) <= 2 * slabs.TASKS_PER_WORKER * 4
    assert sum(len(t.zs) for t in pool.tasks) == len(zs)
    assert all(len(t.faces) < len(f) for t in pool.tasks)  # each task carries only its planes' faces
    assert len(split) == len(whole) == len(zs)
    for a, b in zip(whole, split):
        assert shapely.to_wkb(a.section) == shapely.to_wkb(b.section)
        assert (a.area, a.uncovered, a.uncovered_point) == (b.area, b.uncovered, b.uncovered_point)
    assert sum(c.area > 0 for c in whole) == len(zs) and sum(c.covered > 0 for c in whole) > len(zs) // 2


def test_the_cost_model_or_too_few_layers_keep_the_check_in_one_piece():
    v, f, zs, paths = _part_and_paths(PARTS[0])
    for pool, n in ((_Pickled(2, pays=False), len(zs)), (_Pickled(2), 3), (_Pickled(1), len(zs))):
        slabs.cover_part(v, f, zs[:n], paths[:n], 6.0, pool)
        assert pool.tasks == []


def test_spans_are_guided_large_first_small_last():
    """Each span about half the weight left per worker, the last ones small: with 2 workers a
    worker that finishes early waits for a small task, not an equal share (the 500-layer cross in 8
    equal tasks: 2.0 against 1.6 s of CPU per worker, with a read-back task in front)."""
    w = np.array([1.0] * 60 + [10.0] * 60)  # 660
    spans = slabs._spans(w, 2)
    assert spans[0][0] == 0 and spans[-1][1] == 120 and all(a[1] == b[0] for a, b in zip(spans, spans[1:]))
    sums = [float(w[a:b].sum()) for a, b in spans]
    smallest = 660 / (2 * slabs.TASKS_PER_WORKER * 4)  # 20.6
    left = 660.0
    for x in sums:  # never more than a quarter of what is left (or the smallest), give or take one layer
        assert x <= max(smallest, left / 4) + 10.0
        left -= x
    assert sums[0] == max(sums) and sums[0] >= 660 / 4 - 1e-9
    assert sums[-1] <= smallest + 10.0 and max(sums[-3:]) <= smallest + 10.0
    assert 8 <= len(spans) <= 2 * slabs.TASKS_PER_WORKER * 4
    assert slabs._spans(np.ones(3), 2) == [(0, 1), (1, 2), (2, 3)] and slabs._spans(np.zeros(0), 2) == []


def _box_program(layers: int, bulge_every: int):
    """A 40 × 20 mm box, 2 mm layers, one serpentine run a layer; every `bulge_every`-th layer's link
    swings 15 mm beyond the box's end (x 35 against 20): metal outside the part mid-run."""
    from waamflow.preflight.read import read_gcode

    out = ["; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units=mm/min end=M30", "G21", "G90"]
    for i in range(layers):
        z = 2.0 * (i + 1)
        far = 35.0 if i % bulge_every == 0 else 17.0
        run = [(-17.0, -7.0), (17.0, -7.0), (far, -7.0), (far, 7.0), (17.0, 7.0), (-17.0, 7.0)]
        out += [f"; layer {i} z={z:.3f}", "; section s0", f"G0 X{run[0][0]:.3f} Y{run[0][1]:.3f} Z{z:.3f}", "M3"]
        out += [f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f} F480" for x, y in run[1:]] + ["M5"]
    return read_gcode("\n".join(out + ["M30"]))


def test_the_outside_walk_runs_in_the_slab_tasks_with_the_same_report(monkeypatch):
    """The `outside` check's walk of a solid's planar layers (sampling each arc-ON run against the
    layer's section) runs in the coverage check's slab tasks, on the sections they cut: the parent,
    which waits for those tasks anyway, walks no run itself (issue 30: 0.15 s of CPU on the
    500-layer cross's critical path). The report is the one-piece check's, figure for figure."""
    import json

    from waamflow.preflight import PreflightSettings, outside
    from waamflow.preflight.check import Part, check_program

    m = trimesh.creation.box(extents=(40.0, 20.0, 40.0))
    m.apply_translation((0, 0, 20.0))
    part = Part("solid", "part", vertices=np.asarray(m.vertices), faces=np.asarray(m.faces))
    prog = _box_program(20, 4)
    walked = {"task": 0, "parent": 0}
    in_task = [False]
    sample_run = outside.sample_run

    def counted(run, step):
        walked["task" if in_task[0] else "parent"] += 1
        return sample_run(run, step)

    monkeypatch.setattr(outside, "sample_run", counted)

    class _InTask(_Pickled):
        def map(self, fn, items):
            in_task[0] = True
            try:
                return super().map(fn, items)
            finally:
                in_task[0] = False

    pool = _InTask(2)
    split = check_program(part, prog, "post", PreflightSettings(), 6.0, stock_mm=6.0, pool=pool)
    assert 2 <= len(pool.tasks) <= 2 * slabs.TASKS_PER_WORKER * 4
    assert walked == {"task": 20, "parent": 0}  # one run a layer, each walked once, in a task
    assert all(t.paths is None and len(t.outside.runs) == len(t.zs) for t in pool.tasks)  # runs sent once, not twice
    whole = check_program(part, prog, "post", PreflightSettings(), 6.0, stock_mm=6.0)
    assert json.dumps(split, sort_keys=True, default=str) == json.dumps(whole, sort_keys=True, default=str)
    bulged = [L for L in whole["layers"] if L.get("outside_mm", 0.0) > 0]
    assert len(bulged) == 5 and whole["outside_mm"] == pytest.approx(38.0, abs=1.0)
    assert all(L["outside_mm2"] > 0 for L in bulged)
