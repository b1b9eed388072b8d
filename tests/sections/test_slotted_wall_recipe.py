"""graphs/mpp-slotted-wall.json: the mask that stops fitting at the slot, and the second mask that fixes it."""

import json
from pathlib import Path

import pytest

from waamflow.cli import main

RECIPE = Path(__file__).resolve().parents[2] / "graphs" / "mpp-slotted-wall.json"
BS1_ONLY = (
    'mask.masks=[{"id": "bs1", "from_layer": 0, "sections": [{"id": "A", '
    '"curve": [[-2, -5], [102, -5], [102, 5], [-2, 5]]}]}]'
)


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("WAAMFLOW_CACHE", str(tmp_path / "cache"))


def test_one_mask_fails_at_the_first_layer_of_the_slot(tmp_path, cache, capsys):
    out = tmp_path / "fail"
    assert main(["run", str(RECIPE), "--out", str(out), "--set", BS1_ONLY]) == 3
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("error: node 'mask', layer 5, section 'bs1/A'")
    assert "2 separate regions (areas 240.0, 240.0 mm²)" in err
    assert not (out / "summary.json").exists()


def test_second_mask_from_layer_5_plans_every_layer(tmp_path, cache):
    out = tmp_path / "ok"
    assert main(["run", str(RECIPE), "--out", str(out)]) == 0
    tp = json.loads((out / "sequence.toolpath.json").read_text())
    keys = [[s["key"] for s in l["sections"]] for l in tp["layers"]]
    assert keys[:5] == [["bs1/A"]] * 5
    assert keys[5:] == [["bs2/R", "bs2/L"], ["bs2/L", "bs2/R"]] * 2 + [["bs2/R", "bs2/L"]]  # alternate
    lengths = [[s["length_mm"] for s in l["sections"]] for l in tp["layers"]]
    assert lengths[0] == [100.0] and lengths[9] == [40.0, 40.0]


def test_a_guide_crossing_four_times_fails_naming_layer_and_section(tmp_path, cache, capsys):
    bad = "guide.guides.bs1/A=[[-5, 0], [105, 0], [105, 2], [-5, 2]]"
    assert main(["run", str(RECIPE), "--out", str(tmp_path / "g"), "--set", bad]) == 3
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err == (
        "error: node 'guide', layer 0, section 'bs1/A': guide crosses the section boundary 4 times (needs exactly 2)"
    )
