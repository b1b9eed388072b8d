"""Live builds over REST (#29): start from a run, post scans, get the next layer's program; a
server restart mid-build resumes; bad scans are 422 with the reason."""

import shutil
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from api_util import wait_for_run as wait
from waamflow.api.app import create_app
from waamflow.asbuilt import Disturbance, synth_scan
from waamflow.asbuilt.track import layer_track
from waamflow.settings import Settings

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture()
def settings(tmp_path):
    g = tmp_path / "graphs"
    g.mkdir()
    for f in ("mpp-cross.json", "mpp-cross.params.xml"):
        shutil.copy(ROOT / "graphs" / f, g / f)
    shutil.copytree(ROOT / "graphs" / "parts", g / "parts")
    return Settings(data_dir=tmp_path / "data", graphs_dir=g, start_viewer=False, static_dir=None, workers=1)


def _xyz(scan) -> bytes:
    return "".join(f"{x:.4f} {y:.4f} {z:.4f}\n" for x, y, z in scan.points).encode()


def test_build_over_rest_resumes_after_restart(settings):
    with TestClient(create_app(settings)) as c:
        rid = c.post("/api/runs", json={"graph": "mpp-cross"}).json()["id"]
        assert wait(c, rid, timeout=120)["status"] == "done"
        assert c.post("/api/builds", json={"run": "0" * 12}).status_code == 404
        r = c.post("/api/builds", json={"run": rid})
        assert r.status_code == 201, r.text
        b = r.json()
        bid = b["id"]
        assert b["layers_planned"] == 8 and b["next_layer"] == 0 and b["status"] == "building"
        p0 = c.get(f"/api/builds/{bid}/program").json()
        assert p0["layer"] == 0 and p0["adaptation"]["adapted"] is False and "post.gcode" in p0["files"]
        # the scan of layer 0, 0.3 mm low everywhere
        from waamflow.asbuilt.run import plan_for_build  # the same plan, to make the scan
        from waamflow.engine.executor import FileResolver
        from waamflow.engine.recipe import load_recipe

        tp, _, _ = plan_for_build(load_recipe(settings.graphs_dir / "mpp-cross.json"), FileResolver(settings.graphs_dir))
        tracks = [layer_track(lp) for lp in tp.items]
        rng = np.random.default_rng(0)
        s0 = synth_scan(tracks[0], tracks[0].planned_height() - 0.3, Disturbance(), rng)
        bad = c.post(f"/api/builds/{bid}/scans", params={"layer": 1}, content=_xyz(s0))
        assert bad.status_code == 422 and "expects layer 0" in bad.json()["detail"]["message"]
        nan = c.post(f"/api/builds/{bid}/scans", params={"layer": 0}, content=b"0 0 1\n1 1 nan\n")
        assert nan.status_code == 422 and "NaN" in nan.json()["detail"]["message"]
        r = c.post(f"/api/builds/{bid}/scans", params={"layer": 0}, content=_xyz(s0))
        assert r.status_code == 200, r.text
        res = r.json()
        assert res["layer"]["mean_error_mm"] == pytest.approx(-0.3, abs=0.05)
        assert res["next"]["layer"] == 1 and res["next"]["adaptation"]["adapted"] is True
        assert res["next"]["adaptation"]["speed_factor_max"] < 1.0            # more metal needed: slower
    # restart: a new app on the same data folder
    with TestClient(create_app(settings)) as c:
        d = c.get(f"/api/builds/{bid}").json()
        assert d["next_layer"] == 1 and d["layers_scanned"] == 1
        assert [e["action"] for e in d["log"]] == ["start", "program", "scan_refused", "scan_refused", "scan", "program"]
        assert [x["id"] for x in c.get("/api/builds").json()] == [bid]
        p1 = c.get(f"/api/builds/{bid}/program").json()
        assert p1["layer"] == 1 and p1["files"]["post.gcode"] == res["next"]["files"]["post.gcode"]
        assert c.get("/api/builds/ffffffffffff").status_code == 404
        assert c.get("/api/builds/not-an-id").status_code == 422
