"""Fanuc TP programs (#28 item 4): a structural checker of the .LS files, the weld as Arc Start /
Arc End with schedules numbered from the zones' weld values, the schedule table read back equal to
the zones, lengths read back equal to the program's statistics, refusals."""

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from waamflow.core.moves import flatten
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe
from waamflow.preflight.read import read_tp
from waamflow.program import PlanSettings, TpSettings, plan_program, write_tp
from waamflow.program.tp import speed_text

from tp_check import check_ls, check_program, read_schedules

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture(scope="module")
def cross():
    recipe = apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), [("format", "tp")])
    return execute(build_graph(recipe), resolver=FileResolver(GRAPHS), preflight=True)


def test_mpp_cross_as_tp_programs(cross):
    program = cross.outputs["post"]["program"]
    assert program.format == "tp" and program.name == "POST" and program.main_suffix == "LS"
    names = program.file_names("post")
    assert names["LS"] == "POST.LS" and names["L003.LS"] == "POST_L003.LS" and names["SCHED.CSV"] == "POST_SCHED.CSV"
    info = check_program(program.files)
    assert info["programs"] == 9 and info["arcs"] == program.stats["arc_on_count"] == 24
    assert info["motions"] == program.stats["motions"] == 502
    assert info["schedules"] == program.stats["weld_schedules"] == 6
    main = program.files["LS"]
    assert re.findall(r"CALL (\S+) ;", main) == [f"POST_L{k:03d}" for k in range(8)]
    # read back by the preflight's reader: the arc-ON length is the program's deposition length
    read = read_tp(program.files)
    assert sum(r.length for r in read.runs) == pytest.approx(program.stats["deposition_length_mm"], abs=0.01)
    assert len(read.runs) == 24 and all(r.weld.all() for r in read.runs) and not read.notes


def test_artifacts_as_written_pass_the_checker(cross):
    """The trace comments the node stamps into the main program keep the numbering and LINE_COUNT."""
    files = {k.lstrip("/"): v.decode() for k, v in cross.artifacts.items() if k.lstrip("/").startswith("POST")}
    assert set(files) == {"POST.LS", "POST_SCHED.CSV", *(f"POST_L{k:03d}.LS" for k in range(8))}
    info = check_ls(files["POST.LS"])
    assert info["calls"] and "  ! waamflow " in files["POST.LS"] and "! recipe sha256 " in files["POST.LS"]
    assert check_program(files)["programs"] == 9


def test_schedules_are_the_zones_weld_values(cross):
    """Every welded segment's wire feed, current and travel speed (the zone's) is its Arc Start
    schedule's in the table, read through the programs as written."""
    program = cross.outputs["post"]["program"]
    moves = flatten(cross.outputs["sequence"]["toolpath"])
    table = read_schedules(program.files["SCHED.CSV"])
    rows = {k: {c: float(v) for c, v in r.items() if c not in ("schedule", "zones") and v} for k, r in table.items()}
    seg = np.flatnonzero(moves.arc[: len(moves.points) - 1])
    wfs = np.concatenate([r.wfs for r in read_tp(program.files).runs])
    assert len(wfs) == len(seg)
    expected = np.array(
        [moves.zone_params[(int(moves.section[i]), int(moves.zone[i]))]["wire_feed_speed"] for i in seg]
    )
    assert np.allclose(wfs, expected, atol=1e-9)
    assert sorted(set(expected)) == [1.6, 2.0, 2.4, 3.0, 3.2, 4.0]
    # each welded zone's values are one schedule's row, and the row names the zone
    for (sec, z), params in moves.zone_params.items():
        if not any(moves.arc[i] and moves.section[i] == sec and moves.zone[i] == z for i in seg):
            continue
        want = {
            "current_A": params["current"],
            "wire_feed_speed_m_min": params["wire_feed_speed"],
            "travel_speed_mm_s": params["travel_speed"],
        }
        hits = [k for k, r in rows.items() if all(r.get(c) == pytest.approx(v) for c, v in want.items())]
        assert len(hits) == 1 and moves.zone_ids[z] in table[hits[0]]["zones"].split(), (sec, z)
    # the table is in the main program's comments too, and the post says to enter it
    assert "! sched 2: 103A ;" in program.files["LS"]
    warns = [w["message"] for w in cross.warnings if w["node"] == "post"]
    assert sum("must be entered on the controller" in w for w in warns) == 6  # 5 named, then the rest
    assert any("weld schedule 6 must be entered on the controller as well" in w for w in warns)


def test_a_run_is_weld_commanded_by_a_schedule_with_values(cross):
    """The reader takes the weld from the table: a schedule emptied there, or missing, commands no weld."""
    program = cross.outputs["post"]["program"]
    files = dict(program.files)
    rows = files["SCHED.CSV"].splitlines()
    files["SCHED.CSV"] = "\n".join([rows[0], "1,,,,,6,start", *rows[2:]]) + "\n"  # schedule 1: no values
    runs = read_tp(files).runs
    assert len(runs) == 24 and sum(not r.weld[0] for r in runs) == 8  # layer by layer, bs1/A starts with 1
    assert all(np.isnan(r.wfs[0]) == (not r.weld[0]) for r in runs)
    files["SCHED.CSV"] = "\n".join(rows[:2] + rows[3:]) + "\n"  # schedule 2 missing
    read = read_tp(files)
    assert any("schedule 2 not in the table" in n for n in read.notes)
    assert not all(r.weld.all() for r in read.runs)


def test_metal_balance_is_checked(cross):
    """The preflight reads the wire feed from the schedule table: no 'without a wire feed' warning."""
    probs = cross.preflight["programs"][0]["problems"]
    assert not any("without a wire feed" in p["message"] for p in probs)
    assert cross.preflight["verdict"] == "ok"


def test_same_plan_same_bytes_and_a_cut_layer(cross):
    moves = flatten(cross.outputs["sequence"]["toolpath"])
    plan = plan_program(moves, PlanSettings())
    assert write_tp(plan) == write_tp(plan)
    cut = write_tp(plan, TpSettings(max_points_per_program=20))
    info = check_program(cut)
    assert info["programs"] > 9 and "L002_1.LS" in cut and info["motions"] == 502
    # cut only with the arc off (a bead never spans two programs: check_ls has each end arc-off)
    full = {k: check_ls(v)["positions"] for k, v in write_tp(plan).items() if k.endswith(".LS") and k != "LS"}
    parts = {k: check_ls(v)["positions"] for k, v in cut.items() if k.endswith(".LS") and k != "LS"}
    for k, n in full.items():
        mine = [m for p, m in parts.items() if p.split(".")[0].split("_")[0] == k.split(".")[0]]
        assert sum(mine) == n and len(mine) == 2 and max(mine) < n, (k, mine)
    assert sum(r.length for r in read_tp(cut).runs) == pytest.approx(plan.stats["deposition_length_mm"], abs=0.01)


def test_speed_units_and_orientation(cross):
    assert speed_text(8.0) == "8mm/sec" and speed_text(8.3) == "50cm/min" and speed_text(0.1) == "1cm/min"
    program = cross.outputs["post"]["program"]
    pos = re.findall(
        r"Z = +([-\d.]+) mm,\n\tW = +([-\d.]+) deg,\tP = +([-\d.]+) deg,\tR = +([-\d.]+) deg", program.files["L002.LS"]
    )
    z = np.array([[float(v) for v in p] for p in pos])
    down = np.isclose(z[:, 0], 4.5)
    assert down.sum() > 10
    # a vertical torch (tool z down, tool x = world -X): W 180, P 0, R 180 (R = Rz(R) Ry(P) Rx(W))
    assert (
        np.allclose(np.abs(z[down, 1]), 180.0)
        and np.allclose(z[down, 2], 0.0)
        and np.allclose(np.abs(z[down, 3]), 180.0)
    )


def test_curved_duct_writes_the_positioner_as_group_2():
    """On the shipped positioner cell every P[i] carries GP2 J1 (tilt), J2 (turn) in degrees —
    the simulation's angles — DEFAULT_GROUP 1,1 and every motion COORD."""
    import json

    from waamflow.engine.recipe import parse_recipe
    from waamflow.trajectory.cell import load_cell, positioner_angles

    doc = json.loads((GRAPHS / "curved-duct.json").read_text())
    next(n for n in doc["nodes"] if n["id"] == "fan")["params"]["layer_count"] = 6
    post = next(n for n in doc["nodes"] if n["type"] == "post-process")
    assert post["params"].get("cell") == "kr150_tilt_rotate"  # the shipped duct runs on a positioner cell
    doc["nodes"].append(
        {
            "id": "tp",
            "type": "post-process",  # beside the KRL post the simulation runs
            "params": {**post["params"], "format": "tp", "profile": "fanuc_r30ib_arctool"},
        }
    )
    doc["edges"].append({"from": "bead.toolpath", "to": "tp.toolpath"})
    result = execute(build_graph(parse_recipe(doc)), resolver=FileResolver(GRAPHS))
    program = result.outputs["tp"]["program"]
    info = check_program(program.files)
    assert all("DEFAULT_GROUP\t= 1,1,*,*,*;" in v for k, v in program.files.items() if k.endswith(".LS") and k != "LS")
    moves = flatten(result.outputs["bead"]["toolpath"])
    angles = positioner_angles(
        load_cell("kr150_tilt_rotate"), moves, post["params"].get("positioner_policy", "gravity")
    )
    joints = np.array(info["joints"])
    assert joints.shape == (len(moves.points), 2) == angles.shape
    assert np.allclose(joints, angles, atol=1e-3)
    assert len(np.unique(np.round(joints[:, 0], 3))) == 6  # the table tilts once per layer
    sim = json.loads(result.artifacts["sim.simulation.json"])
    assert joints[:, 0].min() == pytest.approx(sim["positioner_e1_min_deg"], abs=1e-3)
    assert joints[:, 0].max() == pytest.approx(sim["positioner_e1_max_deg"], abs=1e-3)
    assert sum(r.length for r in read_tp(program.files).runs) == pytest.approx(
        program.stats["deposition_length_mm"], abs=0.01
    )


def test_refusals():
    with pytest.raises(ValueError, match="36|24"):
        TpSettings(program_name="A" * 25)
    with pytest.raises(ValueError, match="group 2"):
        replace(TpSettings(), external_axes=np.zeros((1, 4)))
    with pytest.raises(ValueError, match="cnt"):
        TpSettings(cnt=101)
