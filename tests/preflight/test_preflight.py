"""The preflight on programs written by hand (not by our post-processor), each wrong in one way it
must catch: a missing top layer, half the section without a bead, three times the wire, stacked
starts, missing weld values, arc flicker; and the right program, which must pass."""

from __future__ import annotations


import numpy as np
import shapely
import pytest
import trimesh

from waamflow.core.process import deposit_rate_mm3_s
from waamflow.preflight.check import Part, check_program, footprint
from waamflow.preflight.read import read_gcode, read_krl, read_rapid
from waamflow.preflight.settings import PreflightSettings

L, W, H = 40.0, 20.0, 6.0  # box part, mm
LAYER = 1.5
BEAD, STEP, SPEED = 6.0, 5.0, 8.0  # bead width, pass spacing mm, travel mm/s
# wire feed that puts exactly STEP·LAYER mm³ of metal per mm of path (η 0.95, 1.2 mm wire)
WFS = STEP * LAYER * SPEED / deposit_rate_mm3_s(1.0)


def box_part() -> Part:
    m = trimesh.creation.box(extents=(L, W, H))
    m.apply_translation((0, 0, H / 2))
    return Part("solid", "part", vertices=np.asarray(m.vertices), faces=np.asarray(m.faces))


def passes(y_values, x0=-L / 2 + 1.0, x1=L / 2 - 1.0, reverse=False):
    """A boustrophedon over the given y: list of (x, y) points."""
    pts = []
    for k, y in enumerate(y_values):
        a, b = (x0, x1) if (k % 2 == 0) != reverse else (x1, x0)
        pts += [(a, y), (b, y)]
    return pts


def gcode(layers, wfs=WFS, weld=True, header=True):
    """layers: list of (z, [run, ...]) with run = list of (x, y)."""
    out = ["; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units=mm/min end=M30"]
    if header:
        out.append('; waamflow-weld: wire_feed_speed[m/min]="M67 E0 Q{value:.2f}" current[A]="M67 E1 Q{value:.1f}"')
    out += ["G21", "G90"]
    for i, (z, runs) in enumerate(layers):
        out.append(f"; layer {i} z={z:.3f}")
        for j, run in enumerate(runs):
            out.append(f"; section s{j}")
            x, y = run[0]
            out.append(f"G0 X{x:.3f} Y{y:.3f} Z{z:.3f}")
            if weld:
                out += [f"M67 E0 Q{wfs:.3f}", "M67 E1 Q180.0"]
            else:
                out.append(f"; wire_feed_speed {wfs:.2f} m/min")
            out += ["M3", "G4 P0.5"]
            for k, (x, y) in enumerate(run[1:]):
                out.append(f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f}" + (f" F{SPEED * 60:.0f}" if k == 0 else ""))
            out.append("M5")
    out.append("M30")
    return "\n".join(out)


YS = [-7.5, -2.5, 2.5, 7.5]


def good_layers(n=4, ys=YS):
    out = []
    for i in range(n):
        reverse = i % 2 == 1  # alternate ends: no stacked starts
        out.append(((i + 1) * LAYER, [passes(ys[::-1] if i % 2 else ys, reverse=reverse)]))
    return out


def check(text, **kw):
    s = PreflightSettings(**kw)
    return check_program(box_part(), read_gcode(text), "post", s, BEAD)


def kinds(rep):
    return {(p["check"], p["severity"]) for p in rep["problems"]}


def test_the_right_program_passes():
    rep = check(gcode(good_layers()))
    assert rep["verdict"] == "ok", rep["problems"]
    assert rep["top_gap_mm"] == pytest.approx(0.0, abs=1e-6)
    assert rep["uncovered_share"] < 0.02
    # per layer 4 passes of 38 mm + 3 links of 5 mm at STEP·LAYER mm³/mm, and the 0.5 s ignition dwell
    # (G4 P0.5 with the arc on: the metal of 0.5 s · SPEED mm of path), against 40 × 20 × 1.5 mm
    per_layer = (4 * 38 + 3 * 5 + 0.5 * SPEED) * STEP * LAYER
    assert rep["wire_part_volume_ratio"] == pytest.approx(per_layer / (L * W * LAYER), rel=1e-3)
    assert rep["dwell_mm3"] == pytest.approx(4 * 0.5 * SPEED * STEP * LAYER, rel=1e-3)
    assert rep["weld_data_missing"] == 0
    assert rep["start_spread_mm"] >= BEAD
    # starts and stops per layer: one run a layer, alternating ends
    first, second = rep["layers"][0], rep["layers"][1]
    assert first["starts"] == [[-19.0, -7.5, 1.5]] and first["stops"] == [[-19.0, 7.5, 1.5]]
    assert second["starts"] == [[19.0, 7.5, 3.0]]


def test_missing_top_layer_fails_with_the_gap_and_the_layer():
    rep = check(gcode(good_layers(3)))
    top = [p for p in rep["problems"] if p["check"] == "top_gap"]
    assert top and top[0]["severity"] == "fail" and top[0]["layer"] == 2
    assert rep["top_gap_mm"] == pytest.approx(1.5, abs=1e-6)
    assert rep["uncovered_share"] == pytest.approx(0.25, abs=0.02)  # one of four layers never built
    assert rep["verdict"] == "fail"


def test_half_section_without_bead_fails():
    rep = check(gcode(good_layers(ys=[-7.5, -2.5])))  # only the y < 0 half
    unc = [p for p in rep["problems"] if p["check"] == "uncovered"]
    assert unc and unc[0]["severity"] == "fail"
    assert rep["uncovered_share"] == pytest.approx(0.45, abs=0.05)  # 20 mm wide, beads reach y = 0.5
    assert unc[0]["point"][1] > 0  # the hole is on the +y side
    assert rep["verdict"] == "fail"


def test_three_times_the_wire_fails():
    rep = check(gcode(good_layers(), wfs=3 * WFS))
    vr = [p for p in rep["problems"] if p["check"] == "volume_ratio"]
    assert vr and vr[0]["severity"] == "fail"
    ok = check(gcode(good_layers()))["wire_part_volume_ratio"]
    assert rep["wire_part_volume_ratio"] == pytest.approx(3 * ok, rel=1e-3)


def test_stacked_starts_are_caught():
    same = [((i + 1) * LAYER, [passes(YS)]) for i in range(4)]  # every layer ignites at one point
    rep = check(gcode(same))
    st = [p for p in rep["problems"] if p["check"] == "stacked_starts"]
    assert st and rep["stacked_starts"] == 3 and rep["start_spread_mm"] == pytest.approx(0.0, abs=1e-6)
    assert check(gcode(same), stacked_starts="fail")["verdict"] == "fail"


def test_missing_weld_values_fail_even_with_comments():
    rep = check(gcode(good_layers(), weld=False))
    wd = [p for p in rep["problems"] if p["check"] == "weld_data"]
    segs = 4 * (2 * len(YS) - 1)  # 4 layers of 7 moves
    assert wd and wd[0]["severity"] == "fail" and rep["weld_data_missing"] == segs
    assert rep["wire_part_volume_ratio"] is None  # unknown metal is never counted as balanced


def test_arc_flicker_is_caught():
    layers = good_layers()
    z, runs = layers[-1]
    layers[-1] = (z, runs + [[(0.0, 0.0), (0.18, 0.0)]])
    rep = check(gcode(layers))
    ar = [p for p in rep["problems"] if p["check"] == "arc_run"]
    assert ar and rep["min_arc_run_mm"] == pytest.approx(0.18, abs=1e-3) and ar[0]["layer"] == 3


def test_weave_footprint_is_as_wide_as_the_weave():
    # a zigzag of amplitude ±3 mm, period 6 mm, bead 6 mm covers a 12 mm strip without notches
    pts = np.array([(3.0 if k % 2 == 0 else -3.0, -30.0 + 3.0 * k) for k in range(21)])
    strip = footprint([pts], 6.0).intersection(trimesh.path.polygons.Polygon([(-6, -27), (6, -27), (6, 27), (-6, 27)]))
    assert strip.area == pytest.approx(12 * 54, rel=0.01)


def test_krl_and_rapid_readers_give_the_same_runs():
    krl_src = "\n".join(
        [
            "DEF prog( )",
            ";- arc control: digital output $OUT[1]",
            ';- waamflow-weld: wire_feed_speed[m/min]="$ANOUT[1]={value}/20"',
            ";- layer 0 z=1.500",
            ";- section s0",
            "$VEL.CP=0.100000",
            "LIN P1",
            "$ANOUT[1]=5.0",
            "$OUT[1]=TRUE",
            "WAIT SEC 0.5",
            "$VEL.CP=0.008000",
            "LIN P2 C_DIS",
            "LIN P3 C_DIS",
            "TRIGGER WHEN DISTANCE=1 DELAY=0 DO $OUT[1]=FALSE",
            "LIN P4",
            "END",
        ]
    )
    dat = "\n".join(
        ["DEFDAT prog"]
        + [
            f"DECL E6POS P{i + 1}={{X {x},Y {y},Z 1.5,A 0,B 90,C 0,E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}}"
            for i, (x, y) in enumerate([(0, 0), (10, 0), (10, 5), (0, 5)])
        ]
        + ["ENDDAT"]
    )
    k = read_krl({"prog.src": krl_src, "prog.dat": dat})
    assert len(k.runs) == 1 and k.runs[0].length == pytest.approx(25.0)
    assert k.runs[0].speed == pytest.approx([8.0] * 3) and k.runs[0].weld.all()
    mod = "\n".join(
        [
            "MODULE prog",
            "  ! arcdata = [sched(job), mode, voltage V, wirefeed m/min, control, current A]",
            "  CONST robtarget p1 := [[0,0,1.5],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];",
            "  CONST robtarget p2 := [[10,0,1.5],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];",
            "  CONST robtarget p3 := [[10,5,1.5],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];",
            "  CONST robtarget p4 := [[0,5,1.5],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];",
            "  PERS welddata wd1 := [8,0,[0,0,20,5.0,0,180,0,0,0],[0,0,0,0,0,0,0,0,0]];",
            "  PROC main()",
            "    ! layer 0 z=1.500",
            "    ArcLStart p1, v100, sm1, wd1, fine, tWeldGun;",
            "    ArcL p2, v100, sm1, wd1, z1, tWeldGun;",
            "    ArcL p3, v100, sm1, wd1, z1, tWeldGun;",
            "    ArcLEnd p4, v100, sm1, wd1, fine, tWeldGun;",
            "  ENDPROC",
            "ENDMODULE",
        ]
    )
    r = read_rapid(mod)
    assert len(r.runs) == 1 and r.runs[0].length == pytest.approx(25.0)
    assert r.runs[0].speed == pytest.approx([8.0] * 3) and r.runs[0].wfs == pytest.approx([5.0] * 3)


def test_settings_refuse_bands_that_do_not_nest():
    with pytest.raises(ValueError):
        PreflightSettings(volume_ratio_ok=(0.7, 1.2), volume_ratio_fail=(0.75, 1.5))


def test_starts_in_machining_stock_may_stack():
    # every layer ignites at one point 3 mm beyond the part's end (the thin-wall rule: stock is machined off)
    runs = [[(-L / 2 - 3.0, YS[0])] + passes(YS)]
    same = [((i + 1) * LAYER, runs) for i in range(4)]
    rep = check(gcode(same))
    assert rep["stacked_starts"] == 0 and rep["starts_in_stock"] == 4
    assert not [p for p in rep["problems"] if p["check"] == "stacked_starts"]


def test_a_smooth_curve_is_no_weave():
    """A bead along a smooth curve deposits its swept disk, nothing more: three consecutive points
    of a curve sampled every 1 mm lie within a bead width, but the path never comes back, so no
    weave's pool is bridged. The chord triangles of every such triple used to add a sliver of the
    sagitta along the inside of the bend (12 mm² a lap on the twisted bench vase), covering part
    area no bead reaches."""
    t = np.linspace(0.0, np.pi, 95)  # R 30 mm, ~1 mm steps
    arc = np.column_stack([30.0 * np.cos(t), 30.0 * np.sin(t)])
    ripple = np.column_stack([np.linspace(0, 150, 151), 8.0 * np.sin(np.linspace(0, 150, 151) / 12.0)])
    for p in (arc, ripple):
        swept = shapely.LineString(p).buffer(3.0, quad_segs=8)
        assert footprint([p], 6.0).area == pytest.approx(swept.area, rel=1e-9)


def test_a_weaves_triangles_are_buffered_as_one():
    """The weave's triangles are united, then buffered once: the same area as buffering each and
    uniting them, but for the round caps' polygons (a union of buffers is the buffer of the union)."""
    from shapely.ops import unary_union

    pts = np.array([(3.0 if k % 2 == 0 else -3.0, -30.0 + 3.0 * k) for k in range(21)])
    tris = [shapely.Polygon(pts[i : i + 3]) for i in range(len(pts) - 2)]
    each = unary_union([shapely.LineString(pts).buffer(3.0, quad_segs=8)] + [t.buffer(3.0, quad_segs=4) for t in tris])
    got = footprint([pts], 6.0)
    assert got.area == pytest.approx(each.area, rel=1e-5) and got.symmetric_difference(each).area < 0.05


def test_the_paths_are_buffered_at_once_with_the_area_of_a_buffer_each():
    """A layer's paths buffered as one multi-line (their offset curves noded in one pass) cover
    what one buffer per path united does: crossing, touching, apart, closed, a point-like path,
    a curve crossing itself and a weave, within 1e-9 of the area and no piece of either outside the other."""
    from shapely.ops import unary_union

    t = np.linspace(0.0, 2.0 * np.pi, 250)
    paths = [
        np.array([(-40.0, 0.0), (40.0, 0.0)]),  # crossed by the next
        np.array([(0.0, -40.0), (0.0, 40.0)]),
        np.array([(6.0, 10.0), (30.0, 10.0), (30.0, 30.0), (6.0, 30.0), (6.0, 10.0)]),  # a loop touching the cross
        np.array([(80.0, 80.0), (80.0, 80.0)]),  # zero length: a disk
        np.column_stack([40.0 * np.sin(t), 20.0 * np.sin(2.0 * t)]) + (-60.0, 50.0),  # a figure eight
        np.array([(3.0 if k % 2 == 0 else -3.0, -90.0 + 3.0 * k) for k in range(21)]),  # a weave
    ]
    got = footprint(paths, 6.0)
    tris = []
    for p in paths[-1:]:
        tris = [shapely.Polygon(p[i : i + 3]) for i in range(len(p) - 2)]
    each = unary_union(
        [shapely.LineString(p).buffer(3.0, quad_segs=8) for p in paths] + [unary_union(tris).buffer(3.0, quad_segs=4)]
    )
    assert got.is_valid and got.area == pytest.approx(each.area, rel=1e-9)
    assert got.difference(each).area < 1e-6 and each.difference(got).area < 1e-6
    assert footprint([], 6.0).is_empty


def test_weave_footprint_survives_resampling():
    # the same weave cut into 0.5 mm pieces (as wire-feed compensation writes it) covers the same strip
    corners = np.array([(3.0 if k % 2 == 0 else -3.0, -30.0 + 3.0 * k) for k in range(21)])
    pieces = [corners[0]]
    for a, b in zip(corners, corners[1:]):
        n = int(np.ceil(np.linalg.norm(b - a) / 0.5))
        pieces += [a + (b - a) * t for t in np.arange(1, n + 1) / n]
    strip = footprint([np.array(pieces)], 6.0).intersection(
        trimesh.path.polygons.Polygon([(-6, -27), (6, -27), (6, 27), (-6, 27)])
    )
    assert strip.area == pytest.approx(12 * 54, rel=0.01)


def test_non_planar_program_missing_its_last_wedge_fails(tmp_path, monkeypatch):
    """curved-duct (fan layers, KRL): the program as written, then the same program without its last
    6 of 58 layers (a 9.3° wedge of the bend): the 3D check must find the gap at the part's end face."""
    import json as _json
    from pathlib import Path

    from waamflow.cli import main
    from waamflow.preflight.read import read_program

    monkeypatch.setenv("WAAMFLOW_CACHE", str(tmp_path / "cache"))
    graphs = Path(__file__).resolve().parents[2] / "graphs"
    out = tmp_path / "duct"
    main(["run", str(graphs / "curved-duct.json"), "--out", str(out), "--accept-preflight"])
    pf = _json.loads((out / "preflight.json").read_text())["programs"][0]
    assert pf["coverage_method"] == "3D samples" and pf["top_gap_mm"] == pytest.approx(0.0, abs=1e-6)
    assert pf["uncovered_share"] < 0.02
    files = {p.name: p.read_text() for p in out.glob("post*.src")} | {
        p.name: p.read_text() for p in out.glob("post*.dat")
    }
    prog = read_program("krl", files)
    layers = sorted({r.layer for r in prog.runs})
    assert len(layers) == 58
    prog.runs = [r for r in prog.runs if r.layer < layers[-6]]
    import trimesh

    mesh = trimesh.load(graphs / "parts" / "duct.stl")
    part = Part("solid", "part", vertices=np.asarray(mesh.vertices), faces=np.asarray(mesh.faces))
    rep = check_program(part, prog, "post", PreflightSettings(weld_data="off"), pf["bead_width_mm"])
    gap = [p for p in rep["problems"] if p["check"] == "top_gap"]
    # 6 wedges of 1.54° at the duct's centre radius 100 mm: about 16 mm of wall never built
    assert gap and gap[0]["severity"] == "fail" and rep["top_gap_mm"] > 10
    assert rep["uncovered_share"] > 0.05


def test_a_mesh_part_without_its_mesh_is_named():
    """Part.top / Part.bottom of a solid read its mesh: a solid built without vertices names the
    part (it was a TypeError on None)."""
    box = trimesh.creation.box((10.0, 10.0, 4.0))
    part = Part("solid", "stl", vertices=np.asarray(box.vertices), faces=np.asarray(box.faces))
    assert (part.bottom, part.top) == pytest.approx((-2.0, 2.0))
    with pytest.raises(ValueError, match=r"part stl \(solid\) has no mesh"):
        Part("solid", "stl").top


def test_a_treatment_after_the_last_deposit_is_not_the_toolpath_checked(tmp_path, monkeypatch):
    """bead-trials without its posts: the last toolpath is the rolling pass (arc off throughout,
    a speed per point, the last null). The preflight read it and failed itself (TypeError on the
    null speed); it checks the last toolpath that deposits, the sequence's, as it skips a rolling
    program, and reads a null speed as not stated."""
    import json as _json
    import shutil
    from pathlib import Path

    from waamflow.cli import main
    from waamflow.preflight.read import read_toolpath

    monkeypatch.setenv("WAAMFLOW_CACHE", str(tmp_path / "cache"))
    recipe = _json.loads((Path(__file__).resolve().parents[2] / "graphs" / "bead-trials.json").read_text())
    drop = {"simulate", "post", "rolling_post", "compensate", "interpass"}
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] not in drop]
    recipe["edges"] = [e for e in recipe["edges"] if not {e["from"].split(".")[0], e["to"].split(".")[0]} & drop]
    for sub in ("parts", "trials"):  # the recipe's files, beside it
        shutil.copytree(Path(__file__).resolve().parents[2] / "graphs" / sub, tmp_path / sub)
    path = tmp_path / "no-post.json"
    path.write_text(_json.dumps(recipe))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--accept-preflight"]) == 0
    pf = _json.loads((out / "preflight.json").read_text())
    (rep,) = pf["programs"]
    assert rep["files"] == ["sequence.toolpath.json"] and rep["node"] == "sequence"
    assert not [p for p in rep["problems"] if p["check"] in ("preflight", "program")]
    assert rep["runs"] == 24 and rep["layers_deposited"] == 8
    doc = _json.loads((out / "rolling.toolpath.json").read_text())
    secs = [sec for layer in doc["layers"] for sec in layer["sections"]]
    assert len(secs) == 88 and all(sec["speed"][-1] is None and not any(sec["arc"]) for sec in secs)
    rolling = read_toolpath(doc)  # every segment travel (each section read from its first point)
    travel = sum(float(np.linalg.norm(np.diff(np.asarray(sec["points"]), axis=0), axis=1).sum()) for sec in secs)
    assert rolling.runs == [] and rolling.travel_mm == pytest.approx(travel, rel=1e-12) and travel > 2000


def test_an_arc_burning_without_wire_fails_even_where_the_part_balance_holds():
    """mpp-cross with one zone's wire feed set to 0 (or 1e-9) m/min in its XML: a third of arm A of
    layer 0 welded with no wire. Layer 0's volume ratio fell to 0.77, the part's to 0.94: the
    preflight said ok. An arc-ON motion commanded below `wire_feed_min_m_min` fails, naming the layer,
    section, point and how many motions."""
    layers = good_layers()
    text = gcode(layers)
    lines = text.splitlines()
    # layer 2's wire feed command set to 0 for its whole run
    k = [i for i, ln in enumerate(lines) if ln.startswith("M67 E0 Q")][2]
    starved = "\n".join(lines[:k] + ["M67 E0 Q0.000"] + lines[k + 1 :])
    rep = check(starved)
    (p,) = [p for p in rep["problems"] if p["check"] == "wire_feed"]
    n = len(passes(YS)) - 1
    assert p["severity"] == "fail" and p["layer"] == 2 and p["section"] == "s0" and p["value"] == n
    assert "without wire" in p["message"] and "0.00 m/min" in p["message"]
    assert p["limit"] == 0.5 and rep["verdict"] == "fail"
    assert ("wire_feed", "fail") not in kinds(check(text))  # the feed the part needs passes
    assert ("wire_feed", "warn") in kinds(check(starved, wire_feed_min="warn"))


def test_a_dome_built_to_its_top_has_no_top_gap(tmp_path):
    """A 60 mm hemispherical shell read as a surface, one wall per 1.5 mm layer up to z 60: its flat
    cap is out of the last ring's reach sideways, not above it. The 3D check took the build direction
    from layer to layer, tilted inward near the cap, and failed "the deposit ends 4.03 mm short of
    the part's top (60.00 mm)"; planar layers build up (+z): top gap 0, the cap's share is the
    uncovered check's (0.4 %), and its place a warning of the `hole` check that names the horizontal
    face."""
    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import parse_recipe

    sphere = trimesh.creation.icosphere(subdivisions=4, radius=60.0)
    dome = trimesh.Trimesh(sphere.vertices, sphere.faces[sphere.triangles_center[:, 2] > 0])
    dome.remove_unreferenced_vertices()
    dome.export(tmp_path / "dome.stl")
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
    from bench_vase import _recipe  # mesh → slice → wall-path → post, the bench's own recipe

    recipe = _recipe()
    recipe["nodes"][0]["params"].update({"path": "dome.stl", "as": "surface"})
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path), workers=1)
    pf = res.preflight
    assert pf["programs"][0]["coverage_method"] == "3D samples" and len(res.outputs["layers"]["layers"]) == 40
    assert pf["top_gap_mm"] == 0.0 and not [p for p in pf["problems"] if p["check"] == "top_gap"]
    assert pf["uncovered_share"] == pytest.approx(0.0038, abs=0.001)
    cap = [p for p in pf["problems"] if p["check"] == "hole" and "horizontal face" in p["message"]]
    assert len(cap) == 1 and cap[0]["severity"] == "warn" and cap[0]["layer"] == 39
    assert not [p for p in pf["problems"] if p["check"] in ("hole", "uncovered") and p["severity"] == "fail"]
    # each ring's metal against its slab of the shell, the section's length a bead thick: the top
    # rings, 20-35° off flat, read 0.25-0.44x of their faces' whole area a bead thick; layers 0 and 1
    # carry a second bead on the first (retrace) over the mesh's jagged bottom edge
    ratios = {L["index"]: L["volume_ratio"] for L in pf["layers"] if L.get("volume_ratio")}
    assert all(0.8 <= ratios[k] <= 1.2 for k in range(2, 40)), ratios
    assert {p["layer"] for p in pf["problems"] if p["check"] == "layer_volume_ratio"} <= {0, 1}


def test_layer_groups_select_what_a_mask_per_layer_selects():
    """The 3D coverage check groups its bead points by layer once (`Grouped`) instead of a mask
    over every point per layer (O(layers × points)): each group is exactly the rows `labels == v`
    selects, in their order."""
    from waamflow.preflight.grouped import Grouped

    rng = np.random.default_rng(4)
    labels = rng.integers(-3, 400, 20_000)
    labels[5_000:6_000] = 17  # a long run, and layers given twice apart
    groups = Grouped(labels)
    for v in [*np.unique(labels)[::7], -3, 17, 399, 1_000, -10]:
        assert np.array_equal(groups.rows(v), np.flatnonzero(labels == v))
    assert sum(len(groups.rows(v)) for v in np.unique(labels)) == len(labels)


def test_a_horizontal_cap_over_an_opening_is_uncovered_not_a_top_gap(tmp_path):
    """compas_slicer's facade_infill (an open surface, 2 mm layers) failed "the deposit ends 6.00 mm
    short of the part's top (200.00 mm); the last deposited layer is 99" with its deposit at 200 mm:
    a horizontal face of the part at its top spans an opening 6 mm high, and the face's points lie
    above the last bead below the opening. Walls laid on planar layers never build a horizontal face
    of a surface (no layer cuts it); the uncovered check names it. Here: a web to z 24, a 20 mm cap
    at z 29.8 over it, a second web to 30 mm."""
    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import parse_recipe

    def quad(a, b, c, d):
        return [a, b, c, a, c, d]

    tris = (
        quad((0, 0, 0), (0, 60, 0), (0, 60, 24), (0, 0, 24))  # web 1, to z 24
        + quad((-10, 0, 29.8), (10, 0, 29.8), (10, 60, 29.8), (-10, 60, 29.8))  # the cap above it
        + quad((40, 0, 0), (40, 60, 0), (40, 60, 30), (40, 0, 30))  # web 2, to the top
    )
    v = np.array(tris, float)
    trimesh.Trimesh(v, np.arange(len(v)).reshape(-1, 3)).export(tmp_path / "cap.stl")
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
    from bench_vase import _recipe

    recipe = _recipe()
    recipe["nodes"][0]["params"].update({"path": "cap.stl", "as": "surface"})
    recipe["nodes"][1]["params"].update({"layer_height": 2.0})
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path), workers=1)
    pf = res.preflight
    assert pf["programs"][0]["coverage_method"] == "3D samples"
    assert pf["programs"][0]["deposit_top_mm"] == pytest.approx(30.0)
    assert pf["top_gap_mm"] == 0.0 and not [p for p in pf["problems"] if p["check"] == "top_gap"]
    (unc,) = [p for p in pf["problems"] if p["check"] == "uncovered"]
    cap = 20 * 60 / (20 * 60 + 24 * 60 + 30 * 60)  # the cap's share of the part's area: 27.8 %
    assert unc["severity"] == "fail" and pf["uncovered_share"] == pytest.approx(cap, abs=0.03)
    assert "% of the part is horizontal faces of the surface" in unc["message"]
    assert "fan-slice" in unc["message"] and "mask section" not in unc["message"]
