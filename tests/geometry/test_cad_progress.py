"""#24 item 4 (long reads visible) and the 0.0005 mm STEP of item 5: STEP/IGES tessellation reports
progress per face through the engine's node_progress events, stops between faces when the run is
cancelled, and a chordal tolerance that would give too many triangles is refused up front with an
estimate and the tolerance that would do; mesh files report their read stages (parsed, welded,
repaired) and stop between them. STEP files generated here with OpenCascade."""

import threading
import time

import pytest

pytest.importorskip("OCP")

from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut  # noqa: E402
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder, BRepPrimAPI_MakeTorus  # noqa: E402
from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt  # noqa: E402
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer  # noqa: E402

from waamflow.core.errors import CancelledError, InputFileError  # noqa: E402
from waamflow.engine.executor import FileResolver, execute  # noqa: E402
from waamflow.engine.graph import build_graph  # noqa: E402
from waamflow.engine.recipe import parse_recipe  # noqa: E402
from waamflow.geometry.step_io import read_cad_shape, tessellate  # noqa: E402


def _step(path, shape):
    w = STEPControl_Writer()
    w.Transfer(shape, STEPControl_AsIs)
    w.Write(str(path))
    return path.read_bytes()


def _block_with_hole():
    """7 faces: the box's 6 (top and bottom with the hole) and the hole's cylinder."""
    box = BRepPrimAPI_MakeBox(40, 30, 20).Shape()
    cyl = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(20, 15, -1), gp_Dir(0, 0, 1)), 5, 22).Shape()
    return BRepAlgoAPI_Cut(box, cyl).Shape()


def _recipe(path, **params):
    return build_graph(
        parse_recipe(
            {
                "format": "waamflow/1",
                "name": "t",
                "edges": [],
                "nodes": [{"id": "m", "type": "mesh", "params": {"path": path, **params}}],
            }
        )
    )


def test_tessellation_reports_each_face_and_stops_when_cancelled(tmp_path):
    cad = read_cad_shape(_step(tmp_path / "b.step", _block_with_hole()), "b.step")
    assert len(cad.faces) == 7
    seen = []
    tri = tessellate(cad, "b.step", chordal_tolerance=0.01, progress=lambda f, m: seen.append((f, m)))
    assert [f for f, _ in seen] == pytest.approx([i / 7 for i in range(1, 8)])
    assert seen[-1][1] == f"tessellated face 7 of 7 ({len(tri):,} triangles)"

    calls = []

    def cancel_after_three():
        calls.append(1)
        if len(calls) > 3:
            raise CancelledError("run cancelled")

    meshed = []
    cad = read_cad_shape(_step(tmp_path / "b.step", _block_with_hole()), "b.step")
    with pytest.raises(CancelledError):
        tessellate(
            cad,
            "b.step",
            chordal_tolerance=0.01,
            check_cancelled=cancel_after_three,
            progress=lambda f, m: meshed.append(f),
        )
    assert meshed == pytest.approx([1 / 7, 2 / 7, 3 / 7])  # three faces meshed, the fourth never


def test_engine_shows_tessellation_progress_and_cancels_it(tmp_path):
    _step(tmp_path / "b.step", _block_with_hole())
    events = []
    execute(_recipe("b.step"), resolver=FileResolver(tmp_path), on_event=events.append)
    mine = [e for e in events if e.kind == "node_progress" and e.node == "m"]
    assert mine[0].message.startswith("read b.step (0.0")  # MB
    assert mine[-1].message.startswith("tessellated face 7 of 7 (")

    cancel = threading.Event()
    events = []

    def sink(e):
        events.append(e)
        if e.kind == "node_progress" and e.node == "m":
            cancel.set()  # the user presses cancel at the first report

    with pytest.raises(CancelledError):
        execute(_recipe("b.step"), resolver=FileResolver(tmp_path), on_event=sink, cancel=cancel)
    assert events[-1].kind == "run_cancelled"
    assert not any(e.kind == "node_progress" and e.message.startswith("tessellated") for e in events)


def test_a_0_0005_mm_tolerance_is_refused_up_front_with_an_estimate(tmp_path):
    # before: one BRepMesh call on the whole part, ~1 M triangles, minutes without a word
    _step(tmp_path / "torus.step", BRepPrimAPI_MakeTorus(50, 10).Shape())
    t0 = time.perf_counter()
    with pytest.raises(InputFileError) as err:
        execute(_recipe("torus.step", chordal_tolerance=0.0005), resolver=FileResolver(tmp_path))
    assert time.perf_counter() - t0 < 10
    msg = str(err.value)
    assert err.value.node == "m"
    import re

    n = int(re.search(r"about ([\d,]+) triangles in face 1 of 1", msg).group(1).replace(",", ""))
    assert 700_000 < n < 1_300_000  # 97 k measured at 0.005 mm; ∝ 1/tolerance
    suggested = float(re.search(r"a chordal_tolerance of ([\d.e-]+) mm or more", msg).group(1))
    assert 0.0015 < suggested < 0.003  # ≈ 0.0005 × 970 k / 250 k
    assert "max_face_triangles" in msg
    # the total cap is named when it is the one exceeded
    with pytest.raises(
        InputFileError, match=r"about [\d,]+ triangles in all, over the cap of 20,000 \(max_triangles\)"
    ):
        execute(_recipe("torus.step", chordal_tolerance=0.01, max_triangles=20_000), resolver=FileResolver(tmp_path))


def test_mesh_file_read_reports_its_stages_and_stops_between_them(tmp_path):
    import trimesh

    from waamflow.geometry.mesh_io import load_mesh_bytes

    data = trimesh.exchange.stl.export_stl(trimesh.creation.icosphere(subdivisions=4, radius=20))  # 5120 triangles
    seen = []
    load_mesh_bytes(data, "ball.stl", crack_tolerance=0.1, stage=lambda f, m: seen.append((f, m)))
    assert seen == [
        (0.2, "parsed 5,120 triangles (0.2 MB)"),
        (0.5, "welded 5,120 triangles into 2,562 vertices"),
        (0.8, "checked and repaired 5,120 faces (0 open, 0 non-manifold edges left)"),
    ]

    (tmp_path / "ball.stl").write_bytes(data)
    cancel = threading.Event()

    def sink(e):
        if e.kind == "node_progress" and e.node == "m":
            cancel.set()

    with pytest.raises(CancelledError):
        execute(_recipe("ball.stl"), resolver=FileResolver(tmp_path), on_event=sink, cancel=cancel)
