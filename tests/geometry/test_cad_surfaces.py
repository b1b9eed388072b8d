"""#24 item 3: CAD surfaces and midsurfaces. IGES/STEP files generated here with OpenCascade (OCP):
a 100 × 50 mm vertical planar trimmed surface (IGES 144 over a 108 plane), a vertical wall ruled
along +Z over an S-shaped B-spline (IGES 144 over a 122 tabulated cylinder, 126 directrix), a
horizontal half-cylinder arch, a closed box, and a curve-only file (one IGES 126 B-spline)."""

import math

import numpy as np
import pytest

pytest.importorskip("OCP")

from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon  # noqa: E402
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakePrism  # noqa: E402
from OCP.GC import GC_MakeArcOfCircle  # noqa: E402
from OCP.GeomAPI import GeomAPI_PointsToBSpline  # noqa: E402
from OCP.gp import gp_Pnt, gp_Vec  # noqa: E402
from OCP.IGESControl import IGESControl_Writer  # noqa: E402
from OCP.OCP.collections import Array1_gp_Pnt  # noqa: E402
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer  # noqa: E402

from waamflow.core.errors import InputFileError  # noqa: E402
from waamflow.core.model import MeshData, Midsurface  # noqa: E402
from waamflow.engine.executor import FileResolver, execute  # noqa: E402
from waamflow.engine.graph import build_graph  # noqa: E402
from waamflow.engine.recipe import parse_recipe  # noqa: E402

S_POINTS = [(0, 0), (25, 20), (50, 0), (75, -20), (100, 0)]


def _iges(path, shape, unit="MM"):
    w = IGESControl_Writer(unit, 0)  # faces mode: 144 trimmed surfaces, 126/110 curves
    w.AddShape(shape)
    w.ComputeModel()
    assert w.Write(str(path))


def _step(path, shape):
    w = STEPControl_Writer()
    w.Transfer(shape, STEPControl_AsIs)
    w.Write(str(path))


def _entity_types(path) -> set[int]:
    lines = [ln for ln in path.read_text().splitlines() if len(ln) >= 73 and ln[72] == "D"]
    return {int(ln[:8]) for ln in lines[::2]}


def _vertical_rectangle():
    """100 (x) × 50 (z) mm planar face in the plane y = 0."""
    poly = BRepBuilderAPI_MakePolygon(gp_Pnt(0, 0, 0), gp_Pnt(100, 0, 0), gp_Pnt(100, 0, 50), gp_Pnt(0, 0, 50), True)
    return BRepBuilderAPI_MakeFace(poly.Wire()).Face()


def _s_edge(z=0.0):
    arr = Array1_gp_Pnt(1, len(S_POINTS))
    for i, (x, y) in enumerate(S_POINTS):
        arr.SetValue(i + 1, gp_Pnt(x, y, z))
    return BRepBuilderAPI_MakeEdge(GeomAPI_PointsToBSpline(arr).Curve()).Edge()


def _s_length() -> float:
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GCPnts import GCPnts_AbscissaPoint

    return GCPnts_AbscissaPoint.Length_s(BRepAdaptor_Curve(_s_edge()), 1e-9)


def _arch():
    """Half cylinder r = 20 mm along x (0..100), its top at z = 20: an open, non-vertical surface."""
    arc = GC_MakeArcOfCircle(gp_Pnt(0, -20, 0), gp_Pnt(0, 0, 20), gp_Pnt(0, 20, 0)).Value()
    return BRepPrimAPI_MakePrism(BRepBuilderAPI_MakeEdge(arc).Edge(), gp_Vec(100, 0, 0)).Shape()


def _run(tmp_path, nodes, edges=(), **kw):
    recipe = {"format": "waamflow/1", "name": "t", "nodes": nodes, "edges": list(edges)}
    return execute(
        build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path), workers=1, **kw
    )  # serial: no process pool


def _mesh_and_slice(path, mesh_params=None, layer_height=1.5):
    return (
        [
            {"id": "m", "type": "mesh", "params": {"path": path, **(mesh_params or {})}},
            {"id": "layers", "type": "slice", "params": {"layer_height": layer_height}},
        ],
        [{"from": "m.mesh", "to": "layers.mesh"}],
    )


def _length(c) -> float:
    return float(np.linalg.norm(np.diff(np.asarray(c), axis=0), axis=1).sum())


def _area(mesh: MeshData) -> float:
    t = mesh.vertices[mesh.faces]
    return float(np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum() / 2)


@pytest.mark.parametrize("as_", ["surface", "auto"])
def test_iges_144_vertical_rectangle_is_a_midsurface(tmp_path, as_):
    _iges(tmp_path / "plane.igs", _vertical_rectangle())
    assert {144, 108}.issubset(_entity_types(tmp_path / "plane.igs"))
    res = _run(tmp_path, *_mesh_and_slice("plane.igs", {"as": as_}))
    mid = res.outputs["m"]["mesh"]
    assert isinstance(mid, Midsurface)
    assert len(mid.curves) == 1 and _length(mid.curves[0]) == pytest.approx(100.0, abs=1e-9)
    assert mid.z0 == pytest.approx(0.0, abs=1e-9) and mid.height == pytest.approx(50.0, abs=1e-9)
    rep = res.stats["m"].report
    assert rep["read_as"] == "midsurface" and rep["faces"] == 1 and rep["curve_length_mm"] == pytest.approx(100.0)
    layers = res.outputs["layers"]["layers"]
    assert len(layers) == 33 and layers[-1].z == pytest.approx(50.0)  # 33 × 1.5 = 49.5, the 0.5 merged on top
    assert all(len(lay.curves) == 1 and lay.curves[0].length == pytest.approx(100.0) for lay in layers)
    assert any("read as a midsurface" in w["message"] and "1 curve(s) of 100 mm" in w["message"] for w in res.warnings)


@pytest.mark.parametrize("name", ["wall.igs", "wall.step"])
def test_ruled_bspline_wall_is_a_midsurface_of_the_curve(tmp_path, name):
    wall = BRepPrimAPI_MakePrism(_s_edge(), gp_Vec(0, 0, 40)).Shape()
    if name.endswith(".igs"):
        _iges(tmp_path / name, wall)
        assert {144, 122, 126}.issubset(_entity_types(tmp_path / name))
    else:
        _step(tmp_path / name, wall)
    res = _run(tmp_path, *_mesh_and_slice(name, {"as": "surface", "chordal_tolerance": 0.01}, layer_height=2.0))
    mid = res.outputs["m"]["mesh"]
    assert isinstance(mid, Midsurface) and mid.height == pytest.approx(40.0, abs=1e-6)
    exact = _s_length()
    assert exact == pytest.approx(134.6438, abs=1e-4)
    assert exact - 0.05 < _length(mid.curves[0]) <= exact  # inscribed chords within 0.01 mm sagitta
    layers = res.outputs["layers"]["layers"]
    assert len(layers) == 20 and [lay.curves[0].length for lay in layers] == pytest.approx(
        [_length(mid.curves[0])] * 20
    )


def test_iges_midsurface_in_inch_is_converted_once(tmp_path):
    _iges(tmp_path / "in.igs", _vertical_rectangle(), unit="IN")  # written as 3.937 × 1.969 inch
    assert "3.937" in (tmp_path / "in.igs").read_text()
    res = _run(tmp_path, [{"id": "m", "type": "mesh", "params": {"path": "in.igs"}}])
    mid = res.outputs["m"]["mesh"]
    assert _length(mid.curves[0]) == pytest.approx(100.0, rel=1e-6) and mid.height == pytest.approx(50.0, rel=1e-6)
    assert res.stats["m"].report["file_unit"] == "in"
    # 'units': mm overrides the file unit: the file's numbers (3.937 × 1.969) read as mm
    res = _run(tmp_path, [{"id": "m", "type": "mesh", "params": {"path": "in.igs", "units": "mm"}}])
    mid = res.outputs["m"]["mesh"]
    assert _length(mid.curves[0]) == pytest.approx(100 / 25.4, rel=1e-6) and mid.height == pytest.approx(50 / 25.4)


def test_open_non_vertical_surface_is_tessellated(tmp_path):
    _iges(tmp_path / "arch.igs", _arch())
    res = _run(tmp_path, *_mesh_and_slice("arch.igs", {"as": "surface", "chordal_tolerance": 0.01}, layer_height=2.0))
    mesh = res.outputs["m"]["mesh"]
    assert isinstance(mesh, MeshData) and mesh.surface
    assert math.pi * 20 * 100 - 10 < _area(mesh) <= math.pi * 20 * 100  # inscribed facets
    assert res.stats["m"].report["read_as"] == "surface"
    assert any("not as a sketch" in w["message"] and "not vertical" in w["message"] for w in res.warnings)
    layers = res.outputs["layers"]["layers"]
    assert len(layers) == 10  # 20 mm / 2 mm
    # each layer cuts the arch in two 100 mm lines
    assert [sum(c.length for c in lay.curves) for lay in layers[:-1]] == pytest.approx([200.0] * 9, abs=1e-6)


def test_closed_step_box_as_surface_is_its_walls_and_auto_is_a_solid(tmp_path):
    _step(tmp_path / "box.step", BRepPrimAPI_MakeBox(60, 40, 30).Shape())
    res = _run(tmp_path, [{"id": "m", "type": "mesh", "params": {"path": "box.step", "as": "surface"}}])
    mesh = res.outputs["m"]["mesh"]
    assert isinstance(mesh, MeshData) and mesh.surface and _area(mesh) == pytest.approx(2 * (2400 + 1800 + 1200))
    res = _run(tmp_path, [{"id": "m", "type": "mesh", "params": {"path": "box.step"}}])
    mesh = res.outputs["m"]["mesh"]
    assert not mesh.surface and res.stats["m"].report["read_as"] == "solid"
    assert res.stats["m"].report["volume_mm3"] == pytest.approx(72000)


def test_curve_only_iges_is_a_sketch(tmp_path):
    _iges(tmp_path / "curve.igs", _s_edge(z=5.0))
    assert _entity_types(tmp_path / "curve.igs") == {126}
    with pytest.raises(InputFileError, match=r"curve\.igs: 1 curve\(s\) and no faces.*'sketch' node") as err:
        _run(tmp_path, [{"id": "m", "type": "mesh", "params": {"path": "curve.igs"}}])
    assert err.value.node == "m"
    nodes = [
        {"id": "sk", "type": "sketch", "params": {"path": "curve.igs", "height": 30, "arc_tolerance": 0.01}},
        {"id": "layers", "type": "slice", "params": {"layer_height": 1.5}},
    ]
    res = _run(tmp_path, nodes, [{"from": "sk.mesh", "to": "layers.mesh"}])
    mid = res.outputs["sk"]["mesh"]
    assert mid.z0 == pytest.approx(5.0) and mid.height == 30
    assert _s_length() - 0.05 < _length(mid.curves[0]) <= _s_length()
    assert len(res.outputs["layers"]["layers"]) == 20


def test_sketch_node_reads_the_wall_iges_with_its_height(tmp_path):
    _iges(tmp_path / "wall.igs", BRepPrimAPI_MakePrism(_s_edge(), gp_Vec(0, 0, 40)).Shape())
    res = _run(tmp_path, [{"id": "sk", "type": "sketch", "params": {"path": "wall.igs"}}])
    mid = res.outputs["sk"]["mesh"]
    assert mid.height == pytest.approx(40.0) and _s_length() - 0.05 < _length(mid.curves[0]) <= _s_length()
    _iges(tmp_path / "arch.igs", _arch())
    with pytest.raises(InputFileError, match=r"arch\.igs: the faces are not a midsurface of vertical walls"):
        _run(tmp_path, [{"id": "sk", "type": "sketch", "params": {"path": "arch.igs", "height": 10}}])


def test_iges_midsurface_with_a_t_and_an_x_feeds_feature_recognition_like_the_sketch(tmp_path):
    """The thin-walls study's input as the study has it: an IGES midsurface, one 144 face per wall.
    Walls meeting in a T or an X are non-manifold as a mesh; read as a midsurface they give the same
    features as the same walls drawn as a JSON sketch."""
    import json

    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Compound

    walls = [[(0, 0), (100, 0)], [(50, 0), (50, 60)], [(20, 40), (80, 40)]]  # a T at (50, 0), an X at (50, 40)
    comp = TopoDS_Compound()
    b = BRep_Builder()
    b.MakeCompound(comp)
    for (x0, y0), (x1, y1) in walls:
        edge = BRepBuilderAPI_MakeEdge(gp_Pnt(x0, y0, 0), gp_Pnt(x1, y1, 0)).Edge()
        b.Add(comp, BRepPrimAPI_MakePrism(edge, gp_Vec(0, 0, 20)).Shape())
    b.Add(comp, BRepBuilderAPI_MakeEdge(gp_Pnt(0, -10, 0), gp_Pnt(100, -10, 0)).Edge())  # a construction line
    _iges(tmp_path / "walls.igs", comp)
    (tmp_path / "walls.json").write_text(json.dumps({"curves": walls, "height": 20}))

    def kinds(node):
        nodes = [
            node,
            {"id": "layers", "type": "slice", "params": {"layer_height": 2}},
            {"id": "features", "type": "features", "params": {}},
        ]
        edges = [{"from": "p.mesh", "to": "layers.mesh"}, {"from": "layers.layers", "to": "features.layers"}]
        res = _run(tmp_path, nodes, edges)
        fs = res.outputs["features"]["features"]
        return res, sorted((f["kind"], tuple(f["point"])) for f in fs.features if f["layer"] == 0)

    res, from_iges = kinds({"id": "p", "type": "mesh", "params": {"path": "walls.igs"}})
    assert isinstance(res.outputs["p"]["mesh"], Midsurface) and res.stats["p"].report["faces"] == 3
    assert any("1 curve(s) outside any face ignored" in w["message"] for w in res.warnings)
    _, from_json = kinds({"id": "p", "type": "sketch", "params": {"path": "walls.json"}})
    assert from_iges == from_json
    assert ("t_crossing", (50.0, 0.0)) in from_iges and ("direct_crossing", (50.0, 40.0)) in from_iges


def test_horizontal_100x50_trimmed_surface_is_a_surface_of_5000_mm2_and_has_no_height(tmp_path):
    poly = BRepBuilderAPI_MakePolygon(gp_Pnt(0, 0, 0), gp_Pnt(100, 0, 0), gp_Pnt(100, 50, 0), gp_Pnt(0, 50, 0), True)
    _iges(tmp_path / "flat.igs", BRepBuilderAPI_MakeFace(poly.Wire()).Face())
    res = _run(tmp_path, [{"id": "m", "type": "mesh", "params": {"path": "flat.igs"}}])
    mesh = res.outputs["m"]["mesh"]
    assert isinstance(mesh, MeshData) and mesh.surface and _area(mesh) == pytest.approx(5000.0)
    assert res.stats["m"].report["open_edges"] == 4
    from waamflow.core.errors import PlanningError

    # it said "thinner than one layer; use top 'ceil' (...), a layer_height of at most 0 mm": top was
    # 'ceil' already, and no layer height fits a flat part
    with pytest.raises(PlanningError, match=r"no layers: the part is 0 mm tall .*: the part is flat") as err:
        _run(tmp_path, *_mesh_and_slice("flat.igs"))
    assert "at most 0 mm" not in str(err.value) and "use top 'ceil'" not in str(err.value)


def test_reading_iges_prints_nothing_on_stdout(tmp_path, capfd):
    from waamflow.geometry.step_io import read_cad_shape

    _iges(tmp_path / "curve.igs", _s_edge())
    capfd.readouterr()
    cad = read_cad_shape((tmp_path / "curve.igs").read_bytes(), "curve.igs")
    assert len(cad.edges) == 1
    out = capfd.readouterr().out
    assert "loaded entities" not in out and out == ""  # before: OpenCascade's coloured info line


@pytest.mark.parametrize("lean,midsurface", [(0.02, True), (0.2, False), (1.0, False)])
def test_a_wall_leaning_less_than_the_tolerance_is_a_midsurface(tmp_path, lean, midsurface):
    """A 100 × 50 mm wall whose top is `lean` mm off its bottom: within chordal_tolerance 0.05 mm it
    is a vertical wall (a CAD export's rounding); beyond, a tessellated surface saying why."""
    poly = BRepBuilderAPI_MakePolygon(
        gp_Pnt(0, 0, 0), gp_Pnt(100, 0, 0), gp_Pnt(100, lean, 50), gp_Pnt(0, lean, 50), True
    )
    _iges(tmp_path / "lean.igs", BRepBuilderAPI_MakeFace(poly.Wire()).Face())
    res = _run(tmp_path, [{"id": "m", "type": "mesh", "params": {"path": "lean.igs"}}])
    part = res.outputs["m"]["mesh"]
    assert isinstance(part, Midsurface) == midsurface
    if midsurface:
        assert _length(part.curves[0]) == pytest.approx(100.0) and part.height == pytest.approx(50.0)
    else:
        why = f"leans {lean:g} mm over its 50 mm height" if lean < 0.5 else "a face is not vertical"
        assert any("not as a sketch" in w["message"] and why in w["message"] for w in res.warnings)
        assert _area(part) == pytest.approx(100 * math.hypot(50, lean))
