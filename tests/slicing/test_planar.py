import numpy as np
import pytest

from waamflow.slicing.planar import _loop_order, section_loops
from waamflow.slicing.rings import loops_to_regions

from .meshes import as_mesh, tube


def _cycles(sizes: list[int], seed: int) -> np.ndarray:
    """A random permutation made of cycles of these sizes (element i -> nxt[i])."""
    perm = np.random.default_rng(seed).permutation(sum(sizes))
    nxt = np.empty(len(perm), dtype=np.int64)
    o = 0
    for sz in sizes:
        cyc = perm[o : o + sz]
        nxt[cyc] = np.roll(cyc, -1)
        o += sz
    return nxt


@pytest.mark.parametrize("sizes", [[5, 3, 1, 7], [1000], [2] * 50000 + [3] * 1000])
def test_loop_order_walks_every_cycle(sizes):
    """Both walks (pointer jumping: few long cycles; lock-step: many short ones) give positions
    that advance by one along each cycle."""
    nxt = _cycles(sizes, seed=0)
    label, pos, size = _loop_order(nxt)
    assert sorted(size.tolist()) == sorted(sizes)
    np.testing.assert_array_equal(pos[nxt], (pos + 1) % size[label])
    np.testing.assert_array_equal(label[nxt], label)


def test_lock_step_walk_searches_the_active_cycles_once(monkeypatch):
    """The lock-step walk (the vase: 266 loops of ~4,000 segments) finds how many cycles are
    still walking at every step in one search, not one np.searchsorted per step (4,000 calls,
    ~0.05 s); the same positions."""
    from waamflow.slicing import planar

    sizes = [40] * 3000 + [7] * 500 + [300]
    nxt = _cycles(sizes, seed=1)
    calls = []
    real = np.searchsorted

    def counted(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(planar.np, "searchsorted", counted)
    label, pos, size = planar._loop_order(nxt)
    monkeypatch.undo()
    assert len(calls) == 1 and int(size.max()) == 300  # lock-step: 300 steps
    assert sorted(size.tolist()) == sorted(sizes)
    np.testing.assert_array_equal(pos[nxt], (pos + 1) % size[label])
    by_cycle = np.lexsort((pos, label))  # positions 0 .. size - 1 once each along every cycle
    np.testing.assert_array_equal(pos[by_cycle], np.concatenate([np.arange(k) for k in size]))


def test_section_loops_counts_and_order():
    m = as_mesh(tube(20, 30, 10))
    loops = section_loops(m.vertices, m.faces, np.array([-1.0, 2.5, 5.0, 7.5, 11.0]))
    assert loops.plane.tolist() == [1, 1, 2, 2, 3, 3]  # planes outside the part: no loops
    # 256 facets, each a quad split by a diagonal: the plane crosses both triangles
    assert np.diff(loops.offsets).tolist() == [512] * 6
    for j in range(len(loops)):
        r = np.hypot(*loops.loop(j).T)
        # vertical-edge crossings on the circle, diagonal crossings on the facet chords
        assert r.max() == pytest.approx(20.0 if r.max() < 25 else 30.0, rel=1e-12)
        assert r.min() >= r.max() * np.cos(np.pi / 256) - 1e-9
    # the diagonal crossings lie on the facet chords and are dropped when building polygons
    regions = loops_to_regions(loops, 5)
    assert [len(r.geoms) for r in regions] == [0, 1, 1, 1, 0]
    poly = regions[2].geoms[0]
    assert len(poly.exterior.coords) == 257 and len(poly.interiors[0].coords) == 257
    with pytest.raises(ValueError):
        section_loops(m.vertices, m.faces, np.array([5.0, 2.0]))


def test_batches_of_planes_give_the_same_loops():
    m = as_mesh(tube(20, 30, 10))
    heights = np.linspace(0.5, 9.5, 19)
    whole = section_loops(m.vertices, m.faces, heights)
    batched = section_loops(m.vertices, m.faces, heights, batch_segments=1500)  # 1 plane per batch
    np.testing.assert_array_equal(whole.plane, batched.plane)
    np.testing.assert_array_equal(whole.offsets, batched.offsets)
    np.testing.assert_allclose(np.sort(whole.coords, axis=0), np.sort(batched.coords, axis=0))


class _Submit:
    """A node's Context.submit in this process: the job and its result pickled as to a worker."""

    def __init__(self, fail: bool = False, none: bool = False) -> None:
        self.fail, self.none, self.jobs = fail, none, []

    def __call__(self, fn, item):
        import pickle
        from concurrent.futures import Future

        if self.none:
            return None
        self.jobs.append(pickle.loads(pickle.dumps(item)))
        fut = Future()
        if self.fail:
            fut.set_exception(RuntimeError("the worker died"))
        else:
            fut.set_result(pickle.loads(pickle.dumps(fn(self.jobs[-1]))))
        return fut


def _bodies_mesh():
    """Three bodies: a ribbed tube, a solid cylinder beside it and a box above both (planes cross 1-3 bodies)."""
    import trimesh

    from waamflow.geometry.mesh_io import mesh_from_triangles

    from .meshes import box, cylinder, ribbed_tube, union

    ribbed = trimesh.Trimesh(**trimesh.triangles.to_kwargs(ribbed_tube(400, 40).astype(np.float64)))
    others = union(cylinder(15.0, 40.0, xy=(150.0, 0.0)), box((40, 40, 30), (120, -20, 60)))
    return mesh_from_triangles(np.concatenate([np.asarray(ribbed.triangles), np.asarray(others.triangles)]), name="p")


def test_the_upper_planes_cut_in_a_worker_give_the_same_loops(monkeypatch):
    """issue 30: with a worker, the planes above the split are cut there, from a job holding only
    the faces that can cross them (renumbered, int32); loops, bodies and voids are the ones cut in
    one process, bit for bit, and a loop's face is the whole mesh's."""
    from waamflow.slicing import planar

    m = _bodies_mesh()
    heights = np.linspace(0.3, 89.7, 150)
    whole = section_loops(m.vertices, m.faces, heights)
    assert len(set(whole.body.tolist())) == 3 and len(whole) >= 300
    monkeypatch.setattr(planar, "SPLIT_MIN_SEGMENTS", 0)
    for share in (0.5, 0.6, 0.999):
        monkeypatch.setattr(planar, "SPLIT_SHARE", share)
        submit = _Submit()
        split = section_loops(m.vertices, m.faces, heights, submit=submit, batch_segments=20_000)
        (job,) = submit.jobs
        assert 0 < len(job[1]) < len(m.faces) and job[1].dtype == np.int32 and 1 <= len(job[3]) < len(heights)
        for name in ("coords", "offsets", "plane", "body", "void"):
            np.testing.assert_array_equal(getattr(split, name), getattr(whole, name), err_msg=name)
    for submit in (_Submit(fail=True), _Submit(none=True)):  # cut here instead, the same loops
        again = section_loops(m.vertices, m.faces, heights, submit=submit)
        np.testing.assert_array_equal(again.coords, whole.coords)
        np.testing.assert_array_equal(again.body, whole.body)


def test_a_small_cut_stays_in_one_process():
    m = as_mesh(tube(20, 30, 10))
    submit = _Submit()
    section_loops(m.vertices, m.faces, np.linspace(0.5, 9.5, 19), submit=submit)
    assert submit.jobs == []


def _plate_with_boss(jitter: float, seed: int = 1):
    """A 100 × 60 × 3 mm plate with a 20 × 20 mm boss to z 10; the plate's top face (z 3) has its
    vertices moved up or down by up to `jitter` mm, as a float32 STL exporter leaves a face meant
    to be flat (ros-industrial/abb's IRB 4400 base_link.stl: a face at 187 mm, its corners at
    186.99993, 187.000006 and 187.000126 mm)."""
    import trimesh

    plate = trimesh.creation.box(extents=[100, 60, 3])
    plate.apply_translation([50, 30, 1.5])
    boss = trimesh.creation.box(extents=[20, 20, 10])
    boss.apply_translation([50, 30, 5])
    m = trimesh.boolean.union([plate, boss], engine="manifold")
    m = trimesh.Trimesh(m.vertices, m.faces).subdivide().subdivide()
    v = np.array(m.vertices)
    top = np.abs(v[:, 2] - 3.0) < 1e-9
    v[top, 2] += np.random.default_rng(seed).uniform(-jitter, jitter, top.sum())
    return v, np.asarray(m.faces)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_plane_through_a_noisy_flat_face_cuts_just_below_it(seed):
    """A mid-layer plane through a flat face whose corners scatter ±0.15 µm around it cut the
    noise: the base link's layer 93 (a 2 mm layer centred on its 187 mm face) was 332,642 mm²
    where the part is 376,031 mm² just below the face and 149,148 just above, 3,704 mm² of it
    outside both, and the preflight failed the program with 150 mm of weld 24 mm off the part.
    Vertices within TOL.plane_snap of a plane are on it: the plane cuts just below the face, as
    it does through an exact one."""
    v, f = _plate_with_boss(1.5e-4, seed)
    regions = loops_to_regions(section_loops(v, f, np.array([2.0, 3.0, 4.0])), 3)
    assert [round(r.area, 3) for r in regions] == [6000.0, 6000.0, 400.0]
    exact_v, exact_f = _plate_with_boss(0.0)
    exact = loops_to_regions(section_loops(exact_v, exact_f, np.array([3.0])), 1)
    assert exact[0].area == pytest.approx(6000.0)


def test_a_shell_inside_another_shells_outline_is_not_a_hole():
    """Two closed shells facing outwards, a 20 × 20 mm post standing in a 60 × 40 mm base (a mesh
    exported without a boolean union, as ros-industrial/abb's link meshes are): the post's loop lies
    inside the base's without crossing it, and was nested even-odd with it, a 400 mm² hole through
    every layer of the base (the bodies were united only where their loops crossed)."""
    import trimesh

    base = trimesh.creation.box(extents=[60, 40, 20])
    base.apply_translation([30, 20, 10])
    post = trimesh.creation.box(extents=[20, 20, 30])
    post.apply_translation([30, 20, 15])
    m = trimesh.util.concatenate([base, post])
    regions = loops_to_regions(section_loops(m.vertices, m.faces, np.array([5.0, 15.0, 25.0])), 3)
    assert [round(r.area, 6) for r in regions] == [2400.0, 2400.0, 400.0]
    assert all(len(p.interiors) == 0 for r in regions for p in r.geoms)
