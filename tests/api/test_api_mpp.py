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


def _save_as(client, src: str, dst: str) -> None:
    assert client.put(f"/api/graphs/{dst}", json=client.get(f"/api/graphs/{src}").json()).status_code == 201
    xml = client.get(f"/api/graphs/{src}/params").text
    assert (
        client.put(f"/api/graphs/{dst}/params", content=xml, headers={"content-type": "application/xml"}).status_code
        == 204
    )


def test_xml_edit_flows_into_toolpath_and_gcode(client):
    _save_as(client, "mpp-cross", "my-cross")
    xml = client.get("/api/graphs/my-cross/params")
    assert xml.status_code == 200 and "<parameters" in xml.text
    # the long arm's start zone on layer 0: 6 mm/s → 5 mm/s
    edited = re.sub(
        r'(<layer index="0".*?<section id="bs1/A">\s*<zone id="start"[^>]*>.*?<travel_speed unit="mm/s">)6(<)',
        r"\g<1>5\2",
        xml.text,
        count=1,
        flags=re.S,
    )
    assert edited != xml.text
    assert (
        client.put(
            "/api/graphs/my-cross/params", content=edited, headers={"content-type": "application/xml"}
        ).status_code
        == 204
    )
    run = wait(client, client.post("/api/runs", json={"graph": "my-cross"}).json()["id"])
    assert run["status"] == "done", run["error"]
    tp = client.get(f"/api/runs/{run['id']}/artifacts/zone.toolpath.json").json()
    a0 = next(s for s in tp["layers"][0]["sections"] if s["key"] == "bs1/A")
    start_speeds = {sp for sp, z, arc in zip(a0["speed"], a0["zone"], a0["arc"]) if z == "start" and arc}
    assert start_speeds == {5.0}
    a1 = next(s for s in tp["layers"][1]["sections"] if s["key"] == "bs1/A")
    assert {sp for sp, z, arc in zip(a1["speed"], a1["zone"], a1["arc"]) if z == "start" and arc} == {6.0}
    gcode = client.get(f"/api/runs/{run['id']}/artifacts/post.gcode").text
    assert "F300" in gcode and "F360" in gcode  # 5 and 6 mm/s in mm/min
    # the run's merged XML keeps the edit; the stored XML is exactly what was saved
    merged = client.get(f"/api/runs/{run['id']}/artifacts/zone.params.xml").text
    assert merged.count('<travel_speed unit="mm/s">5<') == 1
    assert client.get("/api/graphs/my-cross/params").text == edited
    log = client.get(f"/api/runs/{run['id']}/log").json()
    assert log[-1]["kind"] == "run_finished"


def test_invalid_xml_is_422_naming_the_place(client):
    _save_as(client, "mpp-cross", "mine")
    xml = client.get("/api/graphs/mine/params").text
    bad = xml.replace('<current unit="A">91</current>', '<current unit="A">lots</current>', 1)
    r = client.put("/api/graphs/mine/params", content=bad, headers={"content-type": "application/xml"})
    assert r.status_code == 422
    text = r.json()["detail"]["text"]
    assert "layer 0" in text and "bs1/A" in text
    r = client.put(
        "/api/graphs/mine/params",
        content=b"<!DOCTYPE x [<!ENTITY e 'x'>]><parameters>&e;</parameters>",
        headers={"content-type": "application/xml"},
    )
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


def test_unsaved_run_never_changes_the_saved_graph_or_xml(client):
    """The data-loss scenario: save as, edit (a new mask from layer 4), run without saving."""
    _save_as(client, "mpp-cross", "copy")
    saved_recipe = client.get("/api/graphs/copy").json()
    saved_xml = client.get("/api/graphs/copy/params").content
    edited = client.get("/api/graphs/copy").json()
    mask = next(n for n in edited["nodes"] if n["type"] == "mask")
    first = mask["params"]["masks"][0]
    mask["params"]["masks"].append({**first, "id": "bs2", "from_layer": 4})
    draft = saved_xml.decode().replace('<current unit="A">91</current>', '<current unit="A">180</current>', 1)
    for body in (
        {"graph": "copy", "recipe": edited},
        {"graph": "copy", "recipe": edited, "params_xml": draft},
        {"graph": "copy"},
    ):
        run = wait(client, client.post("/api/runs", json=body).json()["id"])
        assert run["status"] == "done", run["error"]
        assert client.get("/api/graphs/copy/params").content == saved_xml
        assert client.get("/api/graphs/copy").json() == saved_recipe
    # the draft reached that run: its merged XML holds the edited current
    runs = client.get("/api/runs").json()
    merged = client.get(f"/api/runs/{runs[1]['id']}/artifacts/zone.params.xml").text
    assert '<current unit="A">180</current>' in merged
    # an invalid draft is refused before anything runs, naming the place
    bad = saved_xml.decode().replace('<current unit="A">91</current>', '<current unit="A">lots</current>', 1)
    r = client.post("/api/runs", json={"graph": "copy", "params_xml": bad})
    assert r.status_code == 422 and "bs1/A" in r.json()["detail"]["text"]


def test_examples_are_read_only(client):
    recipe = client.get("/api/graphs/mpp-cross").json()
    xml = client.get("/api/graphs/mpp-cross/params").content
    for r in (
        client.put("/api/graphs/mpp-cross", json=recipe),
        client.delete("/api/graphs/mpp-cross"),
        client.put("/api/graphs/mpp-cross/params", content=xml, headers={"content-type": "application/xml"}),
        client.put("/api/graphs/mpp-cross/files/x.stl", content=b"solid x"),
    ):
        assert r.status_code == 409 and "save as" in r.json()["detail"]["message"]
    assert client.get("/api/graphs/mpp-cross/params").content == xml
    assert next(g for g in client.get("/api/graphs").json() if g["name"] == "mpp-cross")["example"] is True


def test_unsaved_recipe_runs_with_its_draft_xml(client):
    """An unsaved recipe (no graph) runs with the XML draft shown in the GUI: `params_xml` with `recipe` alone."""
    recipe = client.get("/api/graphs/mpp-cross").json()
    for n in recipe["nodes"]:
        if n["type"] == "zone":
            n["params"].pop("parameters", None)
    xml = client.get("/api/graphs/mpp-cross/params").text
    draft = xml.replace('<current unit="A">91</current>', '<current unit="A">180</current>', 1)
    run = wait(client, client.post("/api/runs", json={"recipe": recipe, "params_xml": draft}).json()["id"])
    assert run["status"] == "done", run["error"]
    merged = client.get(f"/api/runs/{run['id']}/artifacts/zone.params.xml").text
    assert '<current unit="A">180</current>' in merged
    # an invalid draft is still refused before anything runs
    bad = xml.replace('<current unit="A">91</current>', '<current unit="A">lots</current>', 1)
    assert client.post("/api/runs", json={"recipe": recipe, "params_xml": bad}).status_code == 422
