"""simulate-robot, estimate-time and calibrate-robot through the engine (thin adapters)."""

import csv
import io
import json

import pytest

from waamflow.core.errors import InputFileError
from waamflow.core.moves import DEPOSIT, flatten
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.trajectory.profile import load_profile

OR_NODES = [
    {"id": "or", "type": "rectangle", "params": {"length": 43, "width": 21.5, "layer_count": 1}},
    {"id": "mask", "type": "mask", "params": {"masks": []}},
    {"id": "strategy", "type": "strategy", "params": {"default": {"pattern": "$pattern", "speed": 40}}},
]
OR_EDGES = [("or.layers", "mask.layers"), ("mask.sections", "strategy.sections")]


def run(extra_nodes, extra_edges, base_dir=".", pattern="raster"):
    data = {
        "format": "waamflow/1",
        "name": "t",
        "inputs": {"pattern": pattern},
        "nodes": OR_NODES + extra_nodes,
        "edges": [{"from": a, "to": b} for a, b in OR_EDGES + extra_edges],
    }
    return execute(build_graph(parse_recipe(data)), resolver=FileResolver(base_dir))


def test_simulate_robot_artifacts_and_numbers():
    r = run([{"id": "sim", "type": "simulate-robot", "params": {}}], [("strategy.toolpath", "sim.toolpath")])
    sim = json.loads(r.artifacts["sim.simulation.json"])
    for k in (
        "total_time_s",
        "programmed_length_mm",
        "actual_length_mm",
        "length_ratio",
        "arc_on_time_s",
        "arc_on_length_mm",
        "deposited_volume_mm3",
        "max_deviation_mm",
        "mean_deviation_mm",
        "time_inside_s",
        "time_outside_s",
        "arc_off_time_inside_s",
    ):
        assert isinstance(sim[k], float), k
    assert sim["programmed_length_mm"] == pytest.approx(387.910, abs=1e-3)
    assert sim["total_time_s"] == pytest.approx(11.580, rel=0.03)
    assert sim["estimate"]["total_time_s"] > 0 and sim["estimate_total_time_s"] == sim["estimate"]["total_time_s"]
    assert sim["ik_max_position_error_mm"] < 0.01
    rows = list(csv.DictReader(io.StringIO(r.artifacts["sim.trace.csv"].decode())))
    assert list(rows[0]) == ["t", "x", "y", "z", "speed", "arc", "deviation"]
    assert float(rows[-1]["t"]) == pytest.approx(sim["total_time_s"], abs=0.012)
    dep = list(csv.DictReader(io.StringIO(r.artifacts["sim.deposit.csv"].decode())))
    assert len(dep) == 9 and sum(int(d["arc"]) for d in dep) == 5
    res = r.outputs["sim"]["simulation"]
    assert set(res.trace) >= {"t", "x", "y", "z", "speed", "arc", "deviation", "s", "layer", "section"}
    assert res.programmed.shape == (10, 3)


def test_speed_override_and_no_kinematics():
    r = run(
        [{"id": "sim", "type": "simulate-robot", "params": {"speed_override": 10, "kinematics": False}}],
        [("strategy.toolpath", "sim.toolpath")],
    )
    sim = json.loads(r.artifacts["sim.simulation.json"])
    assert "ik_samples" not in sim
    # 5 passes at 10 mm/s, 4 returns at 40 mm/s (arc OFF keeps its programmed speed)
    assert sim["arc_on_time_s"] == pytest.approx(5 * 43 / 10, rel=0.05)


def test_estimate_time_node():
    r = run(
        [{"id": "est", "type": "estimate-time", "params": {}}],
        [("strategy.toolpath", "est.toolpath")],
        pattern="semicircular",
    )
    est = json.loads(r.artifacts["est.estimate.json"])
    assert est["passes"] == 5 and est["sections"] == 1 and est["notes"] == []
    # the study's closed-form model (Table 5) written out by hand for this program: 5 passes of
    # L = 43 mm at TS = 40 mm/s joined by 4 semicircular links of programmed length Lt, with the
    # shipped profile's own semicircular entry at 40 mm/s, arc ON throughout
    e = load_profile("kuka_kr100ha_krc2").time_model["40_on_semicircular"]
    L, TS, n = 43.0, 40.0, 5
    moves = flatten(r.outputs["strategy"]["toolpath"])
    assert (moves.kind == DEPOSIT).all() and moves.arc.all() and moves.dwell_before.sum() == 0
    Lt = (float(moves.segment_lengths.sum()) - n * L) / (n - 1)
    assert Lt == pytest.approx(6.9487, abs=1e-4)  # a half circle of radius 2.215 mm as 17 chords
    first = e["T_init_accel"] + (L - e["L_init_accel"] - e["L_decel"]) / TS
    middle = (n - 2) * (L - e["L_accel"] - e["L_decel"]) / TS
    last = (L - e["L_accel"] - e["L_final_decel"]) / TS + e["T_final_decel"]
    links = (n - 1) * (e["T_trans"] + (Lt - e["L_trans_ref"]) / TS)
    assert est["total_time_s"] == pytest.approx(first + middle + last + links, rel=1e-6)


def test_calibrate_robot_node(tmp_path):
    """'Measure' a robot that speeds up 25 % slower than the shipped profile (simulate-robot with
    that profile file), then fit the shipped profile to its trace with calibrate-robot."""
    shipped = load_profile("kuka_kr100ha_krc2")
    truth = shipped.with_values(name="truth", path_acc=0.75 * shipped.path_acc)
    (tmp_path / "truth.json").write_text(json.dumps(truth.to_json()))
    strategy = {
        "id": "strategy",
        "type": "strategy",
        "params": {"default": {"pattern": "triangular", "angle_deg": 60, "speed": 40}},
    }

    def recipe(node):
        return {
            "format": "waamflow/1",
            "name": "cal",
            "inputs": {},
            "nodes": OR_NODES[:2] + [strategy, node],
            "edges": [{"from": a, "to": b} for a, b in OR_EDGES + [("strategy.toolpath", f"{node['id']}.toolpath")]],
        }

    meas = execute(
        build_graph(
            parse_recipe(
                recipe(
                    {
                        "id": "robot",
                        "type": "simulate-robot",
                        "params": {"profile_file": "truth.json", "kinematics": False},
                    }
                )
            )
        ),
        resolver=FileResolver(tmp_path),
    )
    (tmp_path / "m.csv").write_bytes(meas.artifacts["robot.trace.csv"])
    r = execute(
        build_graph(
            parse_recipe(
                recipe({"id": "cal", "type": "calibrate-robot", "params": {"trace": "m.csv", "fit": ["path_acc"]}})
            )
        ),
        resolver=FileResolver(tmp_path),
    )
    prof = json.loads(r.artifacts["cal.profile.json"])
    assert prof["path_acc"] == pytest.approx(truth.path_acc, rel=0.05)
    cal = json.loads(r.artifacts["cal.calibration.json"])
    assert cal["fit_cost_after"] < 0.1 * cal["fit_cost_before"]
    assert cal["fit_rms_position_error_mm"] < 0.05


def test_calibrate_robot_bad_csv_names_the_row(tmp_path):
    (tmp_path / "bad.csv").write_text(
        "t,x,y,z\n" + "".join(f"{i * 0.012},{i},0,0\n" for i in range(12)) + "0.5,1,x,0\n"
    )
    data = {
        "format": "waamflow/1",
        "name": "cal",
        "inputs": {"pattern": "raster"},
        "nodes": OR_NODES + [{"id": "cal", "type": "calibrate-robot", "params": {"trace": "bad.csv"}}],
        "edges": [{"from": a, "to": b} for a, b in OR_EDGES + [("strategy.toolpath", "cal.toolpath")]],
    }
    with pytest.raises(InputFileError, match="row 14"):
        execute(build_graph(parse_recipe(data)), resolver=FileResolver(tmp_path))


def test_contract_example_speed_param():
    """The contract's example recipe passes `speed` to simulate-robot: it overrides arc-ON speeds."""
    r = run(
        [{"id": "sim", "type": "simulate-robot", "params": {"speed": 10, "kinematics": False}}],
        [("strategy.toolpath", "sim.toolpath")],
    )
    sim = json.loads(r.artifacts["sim.simulation.json"])
    assert sim["arc_on_time_s"] == pytest.approx(5 * 43 / 10, rel=0.05)


def test_unreachable_cell_warns_through_the_engine():
    r = run(
        [{"id": "sim", "type": "simulate-robot", "params": {"base_xyz_mm": [-4000, 0, -600]}}],
        [("strategy.toolpath", "sim.toolpath")],
    )
    warns = [w for w in r.warnings if w.get("node") == "sim"]
    assert warns and "unreachable" in warns[0]["message"]
    assert warns[0]["layer"] == 0 and warns[0]["section"] == "region0"
    sim = json.loads(r.artifacts["sim.simulation.json"])
    assert sim["unreachable_stretches"] >= 1 and sim["total_time_s"] > 0
