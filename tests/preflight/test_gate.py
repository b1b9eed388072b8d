"""A failed preflight keeps the program inside waamflow: CLI exit 4 with one `error:` line naming the
node and layer, the folder without the program; `--accept-preflight` writes it with the acceptance
in its header; the REST API does the same with `accept_preflight`."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from waamflow.cli import main

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("WAAMFLOW_CACHE", str(tmp_path / "cache"))


def test_missing_top_layers_exit_4_and_no_program(tmp_path, capsys):
    out = tmp_path / "out"
    # 6 of the cross's 8 layers: the program would stop 3 mm below the part's top
    rc = main(["run", str(GRAPHS / "mpp-cross.json"), "--out", str(out), "--set", "layers.layer_count=6"])
    err = capsys.readouterr().err
    assert rc == 4
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and "node 'post'" in lines[0] and "layer 5" in lines[0] and "top_gap" in lines[0]
    assert not (out / "post.gcode").exists()
    pf = json.loads((out / "preflight.json").read_text())
    assert pf["verdict"] == "fail" and pf["withheld"] == ["post.gcode"] and pf["accepted"] is False
    assert pf["top_gap_mm"] == pytest.approx(3.0, abs=1e-6)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "preflight_failed" and "post.gcode" not in summary["artifacts"]

    rc = main(
        [
            "run",
            str(GRAPHS / "mpp-cross.json"),
            "--out",
            str(out),
            "--set",
            "layers.layer_count=6",
            "--accept-preflight",
        ]
    )
    assert rc == 0
    head = (out / "post.gcode").read_text().splitlines()[0]
    assert head.startswith("; waamflow preflight: FAILED, accepted by the user (--accept-preflight)")
    assert "top_gap" in head and len(head) < 200  # short enough for any controller's line limit
    assert json.loads((out / "preflight.json").read_text())["accepted"] is True


def test_api_withholds_the_program_unless_accepted(tmp_path):
    from fastapi.testclient import TestClient

    from waamflow.api.app import create_app
    from waamflow.settings import Settings

    app = create_app(Settings(data_dir=tmp_path / "data", graphs_dir=GRAPHS, start_viewer=False, layer_workers=1))
    with TestClient(app) as client:
        for accept, has_program in ((False, False), (True, True)):
            r = client.post(
                "/api/runs", json={"graph": "mpp-cross", "accept_preflight": accept, "recipe": _cross_with_layers(6)}
            )
            assert r.status_code == 202, r.text
            run_id = r.json()["id"]
            for _ in range(600):
                run = client.get(f"/api/runs/{run_id}").json()
                if run["status"] not in ("queued", "running"):
                    break
                time.sleep(0.1)
            assert run["status"] == "done"
            assert run["summary"]["preflight"]["verdict"] == "fail"
            names = {a["name"] for a in client.get(f"/api/runs/{run_id}/artifacts").json()}
            assert ("post.gcode" in names) is has_program and "preflight.json" in names


def _cross_with_layers(n: int) -> dict:
    doc = json.loads((GRAPHS / "mpp-cross.json").read_text())
    next(x for x in doc["nodes"] if x["id"] == "layers")["params"]["layer_count"] = n
    return doc
