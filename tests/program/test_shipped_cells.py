"""The Fanuc and Yaskawa cells (#28 item 4): arms written from the vendors' data sheets, the same
2-axis tilt/rotate positioner as the KUKA and ABB cells. Their joint ranges, speeds and reach are
the data-sheet numbers cited in the URDF and the cell's `source`; the shipped curved-duct builds on
each with the `gravity` policy: 0 unreachable stretches, 0 collisions."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.trajectory.cell import load_cell
from waamflow.trajectory.kinematics import load_arm

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"

# cell → (URDF, data-sheet reach mm (wrist centre), J1 range deg, J2 range deg, max speeds deg/s, words in `source`)
DATASHEET = {
    "m20id25_tilt_rotate": (
        "fanuc_m20id_25.urdf",
        1831.0,
        (-170.0, 170.0),
        (-100.0, 160.0),
        (210, 210, 265, 420, 420, 720),
        ("FANUC M-20iD/25", "1831 mm", "ARC Mate 120iD"),
    ),
    "ar2010_tilt_rotate": (
        "yaskawa_ar2010.urdf",
        2010.0,
        (-180.0, 180.0),
        (-105.0, 155.0),
        (210, 210, 220, 435, 435, 700),
        ("Yaskawa Motoman AR2010", "2010 mm"),
    ),
}


def wrist_reach_mm(urdf: str) -> float:
    """The largest horizontal distance of the wrist centre (joint 5) from the J1 axis: J2 leaned
    forward to horizontal, J3 scanned over its range (what a data sheet's 'reach' measures)."""
    import pinocchio as pin

    arm = load_arm(urdf)
    model = arm.model
    data = model.createData()
    j5 = model.getJointId("joint_5")
    best = 0.0
    for j3 in np.radians(np.arange(-180.0, 180.01, 0.25)):
        q = np.zeros(model.nq)
        q[1], q[2] = np.radians(90.0), np.clip(j3, arm.lower[2], arm.upper[2])
        pin.forwardKinematics(model, data, q)
        p = data.oMi[j5].translation
        best = max(best, float(np.hypot(p[0], p[1])) * 1000.0)
    return best


@pytest.mark.parametrize("cell_name", sorted(DATASHEET))
def test_the_arm_is_the_data_sheets(cell_name):
    urdf, reach, j1, j2, speeds, words = DATASHEET[cell_name]
    cell = load_cell(cell_name)
    assert cell.robot_urdf == urdf and cell.positioner is not None and cell.axes == 2
    assert cell.positioner.urdf == load_cell("irb4600_tilt_rotate").positioner.urdf  # the same positioner
    assert all(w in cell.source for w in words), cell.source
    text = (Path(__file__).resolve().parents[2] / "backend/waamflow/data/robots" / urdf).read_text()
    assert all(w.split(" (")[0] in text for w in words[:2])  # cited in the URDF too
    arm = load_arm(urdf, home_deg=cell.robot_home_deg)
    assert np.degrees([arm.lower[0], arm.upper[0]]) == pytest.approx(j1, abs=0.01)
    assert np.degrees([arm.lower[1], arm.upper[1]]) == pytest.approx(j2, abs=0.01)
    assert np.degrees(arm.qd_max) == pytest.approx(speeds, abs=0.01)
    assert wrist_reach_mm(urdf) == pytest.approx(reach, abs=1.0)
    from waamflow.program.profiles import load_profiles

    fmt, profile = VENDOR_POST[cell_name]  # the controller's profile names its shipped cell
    spec = load_profiles()[profile]
    assert spec["post"]["format"] == fmt and f"Shipped cell for it: {cell_name}" in spec["description"]


def _duct_on(cell: str, policy: str = "gravity") -> dict:
    recipe = json.loads((GRAPHS / "curved-duct.json").read_text())
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] != "post"]
    recipe["edges"] = [e for e in recipe["edges"] if "post." not in (e["from"][:5], e["to"][:5])]
    next(n for n in recipe["nodes"] if n["id"] == "sim")["params"].update({"cell": cell, "positioner_policy": policy})
    result = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(GRAPHS))
    return json.loads(result.artifacts["sim.simulation.json"])


@pytest.mark.parametrize("cell_name", sorted(DATASHEET))
def test_curved_duct_builds_on_the_cell(cell_name):
    sim = _duct_on(cell_name)
    assert sim["unreachable_stretches"] == 0 and sim["joint_limit_stretches"] == 0
    assert sim["near_singular_stretches"] == 0 and sim["ik_max_position_error_mm"] < 0.01
    assert sim["collision_count"] == 0 and sim["collision_samples_checked"] > 200
    assert sim["positioner_e1_max_deg"] == pytest.approx(89.32, abs=0.01)  # the table levels every layer


# cell → (format, machine profile): each vendor's arm writes its own controller's program
VENDOR_POST = {
    "m20id25_tilt_rotate": ("tp", "fanuc_r30ib_arctool"),
    "ar2010_tilt_rotate": ("inform", "yaskawa_yrc1000"),
}
ANGLE_TOL = 1e-3  # deg: the positioner angles in the programs vs the simulation's (as the KRL/RAPID/G-code checks)


@pytest.mark.parametrize("cell_name", sorted(VENDOR_POST))
def test_the_vendors_program_on_its_cell_carries_the_simulated_positioner_angles(cell_name):
    """curved-duct on the cell, simulated, and post-processed for the cell's controller (Fanuc TP:
    group 2 J1/J2; Yaskawa INFORM: station 1 EC pulses): the program passes its structural
    checker, has one positioner position per toolpath point, and those angles are the
    simulation's (E1 once per layer, E1/E2 extremes as the simulation reports them)."""
    from inform_check import check_program as check_inform
    from tp_check import check_program as check_tp

    from waamflow.core.moves import flatten
    from waamflow.program.profiles import load_profiles
    from waamflow.trajectory.cell import positioner_angles

    fmt, profile = VENDOR_POST[cell_name]
    doc = json.loads((GRAPHS / "curved-duct.json").read_text())
    next(n for n in doc["nodes"] if n["id"] == "fan")["params"]["layer_count"] = 8
    for node in doc["nodes"]:
        if node["id"] in ("sim", "post"):
            node["params"]["cell"] = cell_name
    post = next(n for n in doc["nodes"] if n["id"] == "post")
    doc["nodes"].append(
        {"id": "vendor", "type": "post-process", "params": {**post["params"], "format": fmt, "profile": profile}}
    )
    doc["edges"].append({"from": "bead.toolpath", "to": "vendor.toolpath"})
    result = execute(build_graph(parse_recipe(doc)), resolver=FileResolver(GRAPHS))
    assert result.warnings == [] or all(w["node"] == "vendor" for w in result.warnings)
    sim = json.loads(result.artifacts["sim.simulation.json"])
    assert sim["unreachable_stretches"] == 0 and sim["collision_count"] == 0
    files = result.outputs["vendor"]["program"].files
    moves = flatten(result.outputs["bead"]["toolpath"])
    angles = positioner_angles(load_cell(cell_name), moves, post["params"].get("positioner_policy", "gravity"))
    if fmt == "tp":
        got = np.array(check_tp(files)["joints"])
    else:
        pulses = np.array(check_inform(files)["station"], float)
        got = pulses / np.array(load_profiles()[profile]["post"]["station_pulses_per_deg"])
    assert got.shape == (len(moves.points), 2) == angles.shape
    assert np.abs(got - angles).max() <= ANGLE_TOL
    assert len(np.unique(np.round(got[:, 0], 3))) == 8  # the table tilts once per layer
    assert got[:, 0].min() == pytest.approx(sim["positioner_e1_min_deg"], abs=ANGLE_TOL)
    assert got[:, 0].max() == pytest.approx(sim["positioner_e1_max_deg"], abs=ANGLE_TOL)
    assert got[:, 1].min() == pytest.approx(sim["positioner_e2_min_deg"], abs=ANGLE_TOL)
    assert got[:, 1].max() == pytest.approx(sim["positioner_e2_max_deg"], abs=ANGLE_TOL)
