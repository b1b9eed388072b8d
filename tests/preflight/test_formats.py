"""The same plan written in every format reads back to the same deposit: the preflight's readers
agree with each other (G-code, KRL with analog outputs, RAPID welddata, CL CSV, print points)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from waamflow.cli import main

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture(scope="module")
def reports(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("formats")
    mp = pytest.MonkeyPatch()
    mp.setenv("WAAMFLOW_CACHE", str(tmp / "cache"))
    out = {}
    for fmt, extra in (
        ("gcode", []),
        ("krl", []),
        ("rapid", []),
        ("csv", []),
        ("printpoints", []),
        ("marlin", ["--set", "post.profile=marlin"]),
    ):  # fan PWM: values written ×12.75
        sets = ["--set", f"format={'gcode' if fmt == 'marlin' else fmt}", *extra]
        assert main(["run", str(GRAPHS / "mpp-cross.json"), "--out", str(tmp / fmt), *sets]) == 0
        out[fmt] = json.loads((tmp / fmt / "preflight.json").read_text())["programs"][0]
    mp.undo()
    return out


def test_every_format_passes_and_reads_back_the_same_deposit(reports):
    ref = reports["gcode"]
    assert ref["wire_part_volume_ratio"] == pytest.approx(0.966, abs=0.001)
    for fmt, rep in reports.items():
        assert rep["verdict"] == "ok", (fmt, rep["problems"])
        assert rep["runs"] == ref["runs"] == 24 and rep["layers_deposited"] == 8, fmt
        assert rep["uncovered_share"] == pytest.approx(ref["uncovered_share"], abs=1e-4), fmt
        assert rep["start_spread_mm"] == pytest.approx(ref["start_spread_mm"], abs=1e-3), fmt
        assert rep["min_arc_run_mm"] == pytest.approx(ref["min_arc_run_mm"], abs=1e-2), fmt
    for fmt in ("krl", "rapid", "csv", "marlin"):  # the formats that command the wire feed
        assert reports[fmt]["weld_data_missing"] == 0
        # Marlin's PWM writes whole steps of 1/12.75 m/min: half a step (0.039 m/min) on the smallest feed
        # (2.4 m/min) is at most 1.6 % of the metal, the bound for Marlin (measured 0.968 vs 0.966)
        tol = 0.016 if fmt == "marlin" else 2e-3
        assert reports[fmt]["wire_part_volume_ratio"] == pytest.approx(ref["wire_part_volume_ratio"], abs=tol), fmt
