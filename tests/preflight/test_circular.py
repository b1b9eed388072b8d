"""Circular motions read as the controller runs them. A KRL `CIRC aux, end` or a RAPID
`MoveC`/`ArcC` was read as two straight moves, start → auxiliary point → end (each chord inside its
arc): thin-wall-panel with arcs fitted (`arc_tolerance` 0.05 mm) read 22,000.9 mm of deposit in KRL
and RAPID where the program welds 22,057.5, and warned of metal outside the part (0.06 %) that its
G-code twin, G2/G3 read as arcs, did not. Fanuc TP `C`/`A` and INFORM MOVC/MOVS motions, skipped or read as
straight moves, are `unreadable`."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.preflight import run_preflight
from waamflow.preflight.read import read_inform, read_tp
from waamflow.preflight.read.core import circle_through

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def _arc_len(pts: np.ndarray, p0: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(np.vstack([p0, pts]), axis=0), axis=1).sum())


@pytest.mark.parametrize("turn", [1.0, -1.0])
def test_a_half_circle_through_its_middle(turn):
    r = 40.0
    p0, via, p1 = np.array([r, 0.0, 5.0]), np.array([0.0, turn * r, 5.0]), np.array([-r, 0.0, 5.0])
    pts = circle_through(p0, via, p1)
    assert np.linalg.norm(pts[:, :2], axis=1) == pytest.approx(r, abs=1e-9) and np.allclose(pts[:, 2], 5.0)
    assert np.array_equal(pts[-1], p1) and len(pts) == 36  # 180° in 5° steps
    assert np.sign(pts[len(pts) // 2 - 1, 1]) == turn  # the side the auxiliary point is on
    assert _arc_len(pts, p0) == pytest.approx(math.pi * r, rel=1e-3)


def test_three_quarters_in_a_tilted_plane_and_a_line():
    # the circle of radius 10 about (1, 2, 3) in the plane x = y, from 0° through 200° to 270°
    c, r = np.array([1.0, 2.0, 3.0]), 10.0
    e1, e2 = np.array([1.0, 1.0, 0.0]) / math.sqrt(2), np.array([0.0, 0.0, 1.0])

    def at(deg):
        return c + r * (math.cos(math.radians(deg)) * e1 + math.sin(math.radians(deg)) * e2)

    pts = circle_through(at(0), at(200), at(270))
    assert np.linalg.norm(pts - c, axis=1) == pytest.approx(r, abs=1e-9)
    assert _arc_len(pts, at(0)) == pytest.approx(1.5 * math.pi * r, rel=1e-3)
    line = circle_through(np.zeros(3), np.array([1.0, 0, 0]), np.array([3.0, 0, 0]))
    assert np.array_equal(line, [[1.0, 0, 0], [3.0, 0, 0]])


@pytest.fixture(scope="module")
def panel_arcs():
    """thin-wall-panel with arc fitting on (0.05 mm), in G-code, KRL and RAPID."""
    out = {}
    for fmt in ("gcode", "krl", "rapid"):
        g = build_graph(
            apply_overrides(
                load_recipe(GRAPHS / "thin-wall-panel.json"),
                parse_set([f"post.format={fmt}", "post.arc_tolerance=0.05"]),
            )
        )
        res = execute(g, resolver=FileResolver(GRAPHS), workers=1)
        out[fmt] = (g, res, run_preflight(g, res.outputs, res.artifacts))
    return out


def test_fitted_arcs_read_as_the_gcode_twin(panel_arcs):
    g, res, rep = panel_arcs["gcode"]
    ref = rep["programs"][0]["wire_part_volume_ratio"]
    for fmt in ("krl", "rapid"):
        g, res, rep = panel_arcs[fmt]
        text = "".join(v.decode() for k, v in res.artifacts.items() if k.endswith((".src", ".mod")))
        assert text.count("CIRC " if fmt == "krl" else "ArcC ") >= 30, fmt  # arcs were fitted
        assert rep["verdict"] == "ok" and not rep["problems"], (fmt, rep["problems"])
        prog = rep["programs"][0]
        assert prog["wire_part_volume_ratio"] == pytest.approx(ref, abs=0.002), fmt
        assert prog["outside_share"] == 0.0
        stats = res.outputs["post"]["program"].stats
        from waamflow.preflight.read import read_program

        files = {k: v.decode() for k, v in res.artifacts.items() if k.endswith((".src", ".dat", ".mod"))}
        dep = sum(r.length for r in read_program(fmt, files).runs)
        assert dep == pytest.approx(stats["deposition_length_mm"], rel=1e-4), fmt  # 22,057.9 of 22,057.5 mm


def test_fanuc_and_yaskawa_circular_motions_are_unreadable():
    tp = "\n".join(
        [
            "/PROG  P",
            "/MN",
            "   1:  UFRAME_NUM=1 ;",
            "   2:L P[1] 100mm/sec FINE    ;",
            "   3:  Arc Start[1] ;",
            "   4:C P[2] 8mm/sec CNT100    ;",
            "    :  P[3] 8mm/sec CNT100    ;",
            "   5:  Arc End[1] ;",
            "/POS",
            "P[1]{ X = 0.000 mm, Y = 0.000 mm, Z = 1.500 mm, W = 180.000 deg, P = 0.000 deg, R = 0.000 deg};",
            "P[2]{ X = 10.000 mm, Y = 10.000 mm, Z = 1.500 mm, W = 180.000 deg, P = 0.000 deg, R = 0.000 deg};",
            "P[3]{ X = 20.000 mm, Y = 0.000 mm, Z = 1.500 mm, W = 180.000 deg, P = 0.000 deg, R = 0.000 deg};",
            "/END",
        ]
    )
    sched = "schedule,voltage_V,current_A,wire_feed_speed_m_min,job\n1,20,150,5,\n"
    (msg,) = read_tp({"P.LS": tp, "P_SCHED.CSV": sched}).unplaced
    assert "line 4: C P[2]" in msg and "circular" in msg
    job = "\n".join(
        [
            "/JOB",
            "//NAME J",
            "//POS",
            "///NPOS 3,0,0,0,0,0",
            "///TOOL 1",
            "///POSTYPE USER",
            "///USER 1",
            "C00000=0.000,0.000,1.500,180.0000,0.0000,180.0000",
            "C00001=10.000,10.000,1.500,180.0000,0.0000,180.0000",
            "C00002=20.000,0.000,1.500,180.0000,0.0000,180.0000",
            "//INST",
            "NOP",
            "MOVL C00000 V=100.0",
            "ARCON AC=150 AV=20.0",
            "MOVC C00001 V=8.0",
            "MOVC C00002 V=8.0",
            "ARCOF",
            "END",
        ]
    )
    msgs = read_inform({"J.JBI": job}).unplaced
    assert len(msgs) == 2 and all("circular or spline" in m for m in msgs) and "J line 15: MOVC C00001" in msgs[0]
