"""The MPP flow through the REST API on the shipped mpp-cross recipe: XML in, speeds out."""

import re
import shutil
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from api_util import wait_for_run as wait
from waamflow.api.app import create_app
from waamflow.settings import Settings

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture()
def client(tmp_path):
    gdir = tmp_path / "graphs"
    shutil.copytree(GRAPHS, gdir)
    s = Settings(data_dir=tmp_path / "data", graphs_dir=gdir, start_viewer=False, static_dir=None, workers=1)
    with TestClient(create_app(s)) as c:
        yield c




def test_process_parameters_table(client):
    params = {p["name"]: p for p in client.get("/api/process-parameters").json()}
    assert params["wire_feed_speed"]["unit"] == "m/min" and params["travel_speed"]["unit"] == "mm/s"
    assert params["current"]["maximum"] == 1000


def test_xml_edit_flows_into_toolpath_and_gcode(client):
    xml = client.get("/api/graphs/mpp-cross/params")
    assert xml.status_code == 200 and "<parameters" in xml.text
    # the long arm's start zone on layer 0: 6 mm/s → 5 mm/s
    edited = re.sub(r'(<layer index="0".*?<section id="bs1/A">\s*<zone id="start"[^>]*>.*?<travel_speed unit="mm/s">)6(<)',
                    r"\g<1>5\2", xml.text, count=1, flags=re.S)
    assert edited != xml.text
    assert client.put("/api/graphs/mpp-cross/params", content=edited,
                      headers={"content-type": "application/xml"}).status_code == 204
    run = wait(client, client.post("/api/runs", json={"graph": "mpp-cross"}).json()["id"])
    assert run["status"] == "done", run["error"]
    tp = client.get(f"/api/runs/{run['id']}/artifacts/zone.toolpath.json").json()
    a0 = next(s for s in tp["layers"][0]["sections"] if s["key"] == "bs1/A")
    start_speeds = {sp for sp, z, arc in zip(a0["speed"], a0["zone"], a0["arc"]) if z == "start" and arc}
    assert start_speeds == {5.0}
    a1 = next(s for s in tp["layers"][1]["sections"] if s["key"] == "bs1/A")
    assert {sp for sp, z, arc in zip(a1["speed"], a1["zone"], a1["arc"]) if z == "start" and arc} == {6.0}
    gcode = client.get(f"/api/runs/{run['id']}/artifacts/post.gcode").text
    assert "F300" in gcode and "F360" in gcode  # 5 and 6 mm/s in mm/min
    # the stored XML still holds the edit after the run (values kept, merged with the new template)
    assert client.get("/api/graphs/mpp-cross/params").text.count('<travel_speed unit="mm/s">5<') == 1
    log = client.get(f"/api/runs/{run['id']}/log").json()
    assert log[-1]["kind"] == "run_finished"


def test_invalid_xml_is_422_naming_the_place(client):
    xml = client.get("/api/graphs/mpp-cross/params").text
    bad = xml.replace('<current unit="A">200</current>', '<current unit="A">lots</current>', 1)
    r = client.put("/api/graphs/mpp-cross/params", content=bad, headers={"content-type": "application/xml"})
    assert r.status_code == 422
    text = r.json()["detail"]["text"]
    assert "layer 0" in text and "bs1/A" in text
    r = client.put("/api/graphs/mpp-cross/params", content=b"<!DOCTYPE x [<!ENTITY e 'x'>]><parameters>&e;</parameters>",
                   headers={"content-type": "application/xml"})
    assert r.status_code == 422


def test_unsaved_recipe_runs_with_graph_files(client):
    recipe = client.get("/api/graphs/mpp-cross").json()
    recipe["inputs"]["format"] = "rapid"
    run = wait(client, client.post("/api/runs", json={"graph": "mpp-cross", "recipe": recipe}).json()["id"])
    assert run["status"] == "done"
    names = {a["name"] for a in client.get(f"/api/runs/{run['id']}/artifacts").json()}
    assert "post.mod" in names and "post.gcode" not in names


def test_preview_real_layer_with_sections_and_zones(client):
    recipe = client.get("/api/graphs/mpp-cross").json()
    body = client.post("/api/preview", json={"recipe": recipe, "node": "zone", "layer": 3, "graph": "mpp-cross"}).json()
    assert body["error"] is None and body["layer_count"] == 8
    assert body["layer"]["index"] == 3 and body["layer"]["z"] == pytest.approx(6.0)
    assert sorted(s["key"] for s in body["sections"]) == ["bs1/A", "bs1/B", "bs1/C"]
    a = next(p for p in body["paths"] if p["key"] == "bs1/A")
    assert {"start", "end"} <= set(a["zone"]) and a["zone_colors"]["start"].startswith("#")
    # a mask curve that now misses the part: the preview reports the layer and section, not a 4xx
    recipe["nodes"][2]["params"]["masks"][0]["sections"][1]["curve"] = [[200, 200], [210, 200], [210, 210], [200, 210]]
    body = client.post("/api/preview", json={"recipe": recipe, "node": "zone", "layer": 2}).json()
    assert (body["error"]["section"], body["error"]["layer"]) == ("bs1/B", 2)  # only layer 2 is planned
    assert body["layer"]["index"] == 2  # the layer is still shown
