import json

import pytest

import toy_nodes as toy
from waamflow.cli import main


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("WAAMFLOW_CACHE", str(tmp_path / "cache"))


def write(tmp_path, data, name="r.json"):
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return p


def test_run_writes_artifacts_and_rerun_reports_cached(tmp_path, capsys):
    data = toy.chain(stack={"count": 8}, area={"scale": "$scale"}, inputs={"scale": 1.0})
    p = write(tmp_path, data)
    out = tmp_path / "out"
    assert main(["run", str(p), "--out", str(out)]) == 0
    s1 = json.loads((out / "summary.json").read_text())
    assert s1["status"] == "done" and s1["layer_count"] == 8
    assert float((out / "area.area.txt").read_text()) == pytest.approx(8 * 144)
    assert not any(v["cached"] for v in s1["nodes"].values())
    # change the downstream param only, in a new process-like run (disk cache)
    assert main(["run", str(p), "--out", str(out), "--set", "scale=2"]) == 0
    s2 = json.loads((out / "summary.json").read_text())
    assert s2["nodes"]["stack"]["cached"] and s2["nodes"]["grow"]["cached"]
    assert not s2["nodes"]["area"]["cached"]
    assert float((out / "area.area.txt").read_text()) == pytest.approx(2 * 8 * 144)
    assert not [p for p in tmp_path.iterdir() if ".partial-" in p.name]


def test_invalid_recipe_exit_2_one_error_line(tmp_path, capsys):
    data = toy.chain()
    data["edges"][1]["to"] = "area.nope"
    p = write(tmp_path, data)
    assert main(["run", str(p), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "node 'area'" in err[0] and "nope" in err[0]
    assert not (tmp_path / "o").exists()


def test_not_json_and_missing_file_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{nope")
    assert main(["run", str(bad)]) == 2
    assert main(["run", str(tmp_path / "missing.json")]) == 2
    assert main(["run", str(write(tmp_path, toy.chain())), "--set", "unknown=3"]) == 2


def test_planning_failure_exit_3_names_layer_and_section(tmp_path, capsys):
    data = toy.recipe(
        [("stack", "toy-stack", {"count": 30}), ("mask", "toy-fail", {"fail_at": 24})],
        [("stack.layers", "mask.layers")],
    )
    out = tmp_path / "o"
    assert main(["run", str(write(tmp_path, data)), "--out", str(out)]) == 3
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith("error:") and "node 'mask'" in line and "layer 24" in line and "bs1/A" in line
    assert not out.exists()


def test_nodes_catalog_has_schemas(capsys):
    assert main(["nodes"]) == 0
    cat = json.loads(capsys.readouterr().out)["nodes"]
    grow = next(n for n in cat if n["type"] == "toy-grow")
    assert grow["per_layer"] is True
    assert grow["inputs"][0] == {
        "name": "layers",
        "type": "layers",
        "description": "",
        "optional": False,
        "color": "#4cc9f0",
    }
    assert grow["params_schema"]["properties"]["distance"]["unit"] == "mm"


def test_serve_takes_the_same_workers_setting_as_run():
    """CONTRACT: `run --workers N` and the same setting for `serve` (`--layer-workers` kept as alias)."""
    from waamflow.cli import build_parser

    p = build_parser()
    assert p.parse_args(["serve", "--workers", "3"]).layer_workers == 3
    assert p.parse_args(["serve", "--layer-workers", "2"]).layer_workers == 2
    assert p.parse_args(["run", "x.json", "--workers", "4"]).workers == 4
