"""Interpass dwell from a measured temperature (#29 item 3): the lumped heat model turns (measured,
target) into seconds; the next layer's program waits that long with the dialect's wait command,
states it in its header; the log and asbuilt.json say it; no temperature, no change."""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from waamflow.asbuilt import BuildSession, Disturbance, synth_scan
from waamflow.asbuilt.dwell import DwellRule, check_temperature, interpass_dwell, time_constants
from waamflow.asbuilt.run import dwell_rule_of, plan_for_build
from waamflow.engine.executor import FileResolver
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe
from waamflow.process.interpass import HeatModel

ROOT = Path(__file__).resolve().parents[2]


def _cross(fmt: str = "gcode"):
    recipe = apply_overrides(load_recipe(ROOT / "graphs" / "mpp-cross.json"), [("format", fmt)])
    tp, post, _ = plan_for_build(recipe, FileResolver(ROOT / "graphs"))
    return tp, post, dwell_rule_of(build_graph(recipe))


def _session(tmp_path, fmt="gcode", name="b"):
    tp, post, rule = _cross(fmt)
    s = BuildSession.create(tmp_path / name, tp, {"id": name, "layers": 8, "interpass": rule.to_dict()}, post=post)
    s.next_program()
    return s


def _scan0(s):
    tr = s.tracks[0]
    return synth_scan(tr, tr.planned_height(), Disturbance(), np.random.default_rng(0))


def test_dwell_by_the_heat_model_numbers():
    rule = DwellRule(HeatModel(interpass_c=200.0, ambient_c=20.0), max_dwell_s=600.0)
    # τ ln((T − Ta)/(Tt − Ta)) less the travel: 300 s · ln(330/180) − 1 s
    d350 = interpass_dwell(350.0, 300.0, rule, travel_s=1.0)
    assert d350["dwell_s"] == pytest.approx(300 * math.log(330 / 180) - 1, abs=1e-3) == pytest.approx(180.84, abs=0.01)
    d500 = interpass_dwell(500.0, 300.0, rule, travel_s=1.0)
    assert d500["dwell_s"] == pytest.approx(300 * math.log(480 / 180) - 1, abs=1e-3) == pytest.approx(293.25, abs=0.01)
    assert d500["dwell_s"] > d350["dwell_s"] and not d500["clamped"]
    assert interpass_dwell(180.0, 300.0, rule)["dwell_s"] == 0.0  # already under the target
    hot = interpass_dwell(1500.0, 300.0, rule)  # 300 ln(1480/180) = 632 s > 600
    assert hot["dwell_s"] == 600.0 and hot["clamped"] and hot["needed_s"] == pytest.approx(632.06, abs=0.01)
    for bad in (float("nan"), float("inf"), -50.1, 2000.5):
        with pytest.raises(ValueError, match="interpass_temp_c"):
            check_temperature(bad)


def test_cross_time_constants_grow_with_the_part():
    tp, _, rule = _cross()
    assert rule.model.interpass_c == 200.0 and rule.source.startswith("default heat model")
    taus = time_constants([lp for lp in tp.items if lp is not None], rule.model)
    assert len(taus) == 8 and taus[0] == pytest.approx(289.5, abs=0.05)
    assert all(b > a for a, b in zip(taus, taus[1:]))


def test_hotter_part_waits_longer_in_the_next_program(tmp_path):
    out = {}
    for t in (350.0, 500.0):
        s = _session(tmp_path, name=f"b{int(t)}")
        s.add_scan(_scan0(s), interpass_c=t)
        p = s.next_program("cell")
        d = p["adaptation"]["interpass"]
        # τ after layer 0 of the cross 289.5 s, 0.906 s of travel to layer 1's start
        assert d["tau_s"] == pytest.approx(289.5, abs=0.05) and d["travel_s"] == pytest.approx(0.906, abs=0.001)
        assert d["dwell_s"] == pytest.approx(d["tau_s"] * math.log((t - 20) / 180) - d["travel_s"], abs=0.02)
        g = p["files"]["post.gcode"]
        waits = [float(x) for x in re.findall(r"^G4 P([\d.]+) ; interlayer dwell", g, re.M)]
        assert waits == [pytest.approx(d["dwell_s"], abs=0.01)]
        head = g.split("\n")[:2]
        assert head[0].startswith("; as-built build") and f"measured {t:g} degC after layer 0" in head[1]
        log = s.state["log"][-1]
        assert log["action"] == "program" and log["dwell_s"] == d["dwell_s"] and log["interpass_measured_c"] == t
        doc = json.loads((tmp_path / f"b{int(t)}" / "asbuilt.json").read_text())
        assert doc["layers"][0]["interpass_measured_c"] == t
        assert doc["programs"][-1]["layer"] == 1 and doc["programs"][-1]["dwell_s"] == d["dwell_s"]
        out[t] = d["dwell_s"]
    assert out[350.0] == pytest.approx(174.57, abs=0.02) and out[500.0] == pytest.approx(283.05, abs=0.02)


def test_no_temperature_keeps_the_program(tmp_path):
    a = _session(tmp_path, name="a")
    a.add_scan(_scan0(a))
    pa = a.next_program()
    assert "interpass" not in pa["adaptation"] and "dwell_s" not in a.state["log"][-1]
    assert not re.search(r"^G4 P[\d.]+ ; interlayer dwell", pa["files"]["post.gcode"], re.M)
    cold = _session(tmp_path, name="c")
    cold.add_scan(_scan0(cold), interpass_c=150.0)  # under the target: no wait
    pc = cold.next_program()
    assert pc["adaptation"]["interpass_dwell_s"] == 0.0
    body = lambda g: [ln for ln in g.split("\n") if not ln.startswith(";")]  # noqa: E731
    assert body(pc["files"]["post.gcode"]) == body(pa["files"]["post.gcode"])


@pytest.mark.parametrize(
    "fmt, pattern",
    [
        ("krl", r"^\s*WAIT SEC ([\d.]+) ; interlayer dwell"),
        ("rapid", r"^\s*WaitTime\\InPos, ([\d.]+); ! interlayer dwell"),
    ],
)
def test_dwell_is_the_dialects_wait(tmp_path, fmt, pattern):
    s = _session(tmp_path, fmt)
    s.add_scan(_scan0(s), interpass_c=350.0)
    p = s.next_program()
    text = "\n".join(p["files"].values())
    waits = [float(x) for x in re.findall(pattern, text, re.M)]
    assert waits == [pytest.approx(174.57, abs=0.02)]
    assert "measured 350 degC after layer 0" in text.split("interlayer dwell")[0]  # stated in the header


def test_bad_temperature_is_refused_by_the_session(tmp_path):
    s = _session(tmp_path)
    with pytest.raises(ValueError, match="interpass_temp_c = nan"):
        s.add_scan(_scan0(s), interpass_c=float("nan"))
    assert s.next_layer == 0


@pytest.mark.parametrize(
    "fmt, main, pattern", [("tp", "post.ls", r"WAIT ([\d.]+)\(sec\)"), ("inform", "post.jbi", r"^TIMER T=([\d.]+)")]
)
def test_fanuc_and_yaskawa_wait_and_short_header(tmp_path, fmt, main, pattern):
    s = _session(tmp_path, fmt)
    s.add_scan(_scan0(s), interpass_c=350.0)
    files = s.next_program()["files"]
    waits = [float(x) for text in files.values() for x in re.findall(pattern, text, re.M)]
    assert waits == [pytest.approx(174.57, abs=0.02)]
    head = {k.lower(): v for k, v in files.items()}[main]
    assert "interpass: part measured 350 d" in head  # 32-character comment lines in the main program
