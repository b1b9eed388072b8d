"""The mask canvas shows a helix lap by lap (/api/preview). thin-wall-panel's tube is one helix of
15 laps, laid in layer 0 (one ignition): the canvas drew all 15 laps on layer 0 and nothing of the
tube on layers 1-14, as if the tube were not built there."""

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from waamflow.api.app import create_app
from waamflow.settings import Settings

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("helix")
    g = tmp / "graphs"
    g.mkdir()
    shutil.copy(ROOT / "graphs" / "thin-wall-panel.json", g / "thin-wall-panel.json")
    shutil.copytree(ROOT / "graphs" / "parts", g / "parts")
    s = Settings(data_dir=tmp / "data", graphs_dir=g, start_viewer=False, static_dir=None, workers=1)
    with TestClient(create_app(s)) as c:
        yield c


def _tube(client, node, layer):
    recipe = json.loads((ROOT / "graphs" / "thin-wall-panel.json").read_text())
    r = client.post("/api/preview", json={"graph": "thin-wall-panel", "recipe": recipe, "node": node, "layer": layer})
    assert r.status_code == 200, r.text
    return [p for p in r.json()["paths"] if p["key"] == "tube0"], r.json()


@pytest.mark.parametrize("node", ["walls", "sequence"])
@pytest.mark.parametrize("layer", [0, 5, 14])
def test_each_layer_shows_its_lap_of_the_helix(client, node, layer):
    (lap,), data = _tube(client, node, layer)
    z = np.array(lap["points"])[:, 2]
    top = data["layer"]["z"]
    assert top == pytest.approx(2.0 * (layer + 1))
    assert z.max() == pytest.approx(top, abs=1e-6) and z.min() >= top - 2.0 - 1e-6  # within the layer's 2 mm
    xy = np.array(lap["points"])[:, :2]
    one_lap = float(np.hypot(*np.diff(xy, axis=0).T).sum())
    assert one_lap == pytest.approx(2 * math.pi * 8.0, rel=0.01)  # a lap of the tube's 8 mm centre line
    assert lap["climbs"] == {"from_layer": 0, "laps": 15, "z_from": 2.0, "z_to": 30.0}
    assert all(lap["arc"])
