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

        tp, _, _ = plan_for_build(
            load_recipe(settings.graphs_dir / "mpp-cross.json"), FileResolver(settings.graphs_dir)
        )
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
        assert res["next"]["adaptation"]["speed_factor_max"] < 1.0  # more metal needed: slower
    # restart: a new app on the same data folder
    with TestClient(create_app(settings)) as c:
        d = c.get(f"/api/builds/{bid}").json()
        assert d["next_layer"] == 1 and d["layers_scanned"] == 1
        assert [e["action"] for e in d["log"]] == [
            "start",
            "program",
            "scan_refused",
            "scan_refused",
            "scan",
            "program",
        ]
        assert [x["id"] for x in c.get("/api/builds").json()] == [bid]
        p1 = c.get(f"/api/builds/{bid}/program").json()
        assert p1["layer"] == 1 and p1["files"]["post.gcode"] == res["next"]["files"]["post.gcode"]
        assert c.get("/api/builds/ffffffffffff").status_code == 404
        assert c.get("/api/builds/not-an-id").status_code == 422


def test_interpass_temperature_over_rest_surface_and_3d(settings):
    with TestClient(create_app(settings)) as c:
        rid = c.post("/api/runs", json={"graph": "mpp-cross"}).json()["id"]
        assert wait(c, rid, timeout=120)["status"] == "done"
        bad_target = c.post("/api/builds", json={"run": rid, "interpass_c": -80})
        assert bad_target.status_code == 422 and "interpass_c" in bad_target.text
        b = c.post("/api/builds", json={"run": rid, "interpass_c": 180, "max_dwell_s": 600}).json()
        bid = b["id"]
        assert b["interpass"]["target_c"] == 180 and b["interpass"]["max_dwell_s"] == 600
        c.get(f"/api/builds/{bid}/program")
        from waamflow.asbuilt.run import plan_for_build
        from waamflow.engine.executor import FileResolver
        from waamflow.engine.recipe import load_recipe

        tp, _, _ = plan_for_build(
            load_recipe(settings.graphs_dir / "mpp-cross.json"), FileResolver(settings.graphs_dir)
        )
        tr0 = layer_track(tp.items[0])
        body = _xyz(synth_scan(tr0, tr0.planned_height() - 0.3, Disturbance(), np.random.default_rng(0)))
        for t in ("nan", "-60", "2500", "inf"):
            r = c.post(f"/api/builds/{bid}/scans", params={"layer": 0, "interpass_temp_c": t}, content=body)
            assert r.status_code == 422, (t, r.text)
            assert (
                r.json()["detail"]["field"].endswith("interpass_temp_c")
                and "interpass_temp_c" in r.json()["detail"]["message"]
            )
        r = c.post(f"/api/builds/{bid}/scans", params={"layer": 0, "interpass_temp_c": 400}, content=body)
        assert r.status_code == 200, r.text
        nxt = r.json()["next"]
        d = nxt["adaptation"]["interpass"]
        # τ 289.5 s after layer 0; 289.5 ln(380/160) − 0.906 s of travel = 249.5 s
        assert d["target_c"] == 180 and d["dwell_s"] == pytest.approx(249.5, abs=0.1)
        assert f"G4 P{d['dwell_s']:g} ; interlayer dwell" in nxt["files"]["post.gcode"]
        det = c.get(f"/api/builds/{bid}").json()
        assert det["layers"][0]["interpass_measured_c"] == 400
        assert det["plan_layers"] == list(range(8)) and (
            det["layers_added"],
            det["layers_dropped"],
            det["skipped"],
        ) == (0, 0, [])
        assert det["programs"][-1] == {**det["programs"][-1], "layer": 1, "dwell_s": d["dwell_s"]}
        assert det["log"][-1]["action"] == "program" and det["log"][-1]["dwell_s"] == d["dwell_s"]
        # which scan and which program: the bytes as received and the text handed out, by SHA-256
        import hashlib

        scan_log = next(e for e in det["log"] if e["action"] == "scan")
        assert scan_log["scan_file"] == "scan_00000.bin" and scan_log["scan_bytes"] == len(body)
        assert scan_log["scan_sha256"] == hashlib.sha256(body).hexdigest()[:16]
        assert det["log"][-1]["sha256"] == {
            "post.gcode": hashlib.sha256(nxt["files"]["post.gcode"].encode()).hexdigest()[:16]
        }
        sf = c.get(f"/api/builds/{bid}/surface").json()
        assert [x["layer"] for x in sf["layers"]] == [0]
        lay = sf["layers"][0]
        assert len(lay["x"]) == len(lay["deviation"]) == tr0.n == 510
        devs = [x for x in lay["deviation"] if x is not None]
        assert len(devs) > 480 and np.mean(devs) == pytest.approx(-0.3, abs=0.03)
        assert c.get(f"/api/builds/{bid}/surface", params={"layer": 3}).json()["layers"] == []
        # no 3D preview on this server: said so
        v = c.post(f"/api/builds/{bid}/view", json={})
        assert v.status_code == 409 and "3D preview" in v.json()["detail"]["message"]
