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


def _mesh_recipe(tmp_path, triangles: int):
    stl = tmp_path / "part.stl"
    with open(stl, "wb") as fh:  # sparse: only the size counts
        fh.write(b"part".ljust(80, b" ") + triangles.to_bytes(4, "little"))
        fh.truncate(84 + 50 * triangles)
    rec = {"format": "waamflow/1", "name": "p", "nodes": [{"id": "m", "type": "mesh", "params": {"path": "part.stl"}}]}
    (tmp_path / "r.json").write_text(json.dumps(rec))
    return tmp_path / "r.json"


def test_a_large_mesh_starts_the_fork_server_before_the_engine_is_imported(tmp_path):
    """issue 30: `waamflow run` of a recipe with a mesh file of EARLY_FORK_SERVER_TRIANGLES or more
    starts the fork server first thing (its imports then run beside the parent's); the thresholds
    and the preload are the engine's own; small meshes, --workers 1 and a Dask scheduler never."""
    import subprocess
    import sys

    from waamflow import cli
    from waamflow.engine import executor, parallel

    assert cli.EARLY_FORK_SERVER_TRIANGLES == executor.WARM_TRIANGLES
    assert cli.FORK_SERVER_PRELOAD == parallel.PRELOAD and cli.MESH_SUFFIXES == parallel.MESH_SUFFIXES
    big = _mesh_recipe(tmp_path, 300_000)
    small_dir = tmp_path / "small"
    small_dir.mkdir()
    small = _mesh_recipe(small_dir, 200_000)
    assert not cli._early_fork_server(big, 1, None)
    assert not cli._early_fork_server(big, 2, "tcp://127.0.0.1:8786")
    assert not cli._early_fork_server(small, 2, None)
    assert not cli._early_fork_server(tmp_path / "missing.json", 2, None)
    probe = (
        "import sys, pathlib\n"
        "from multiprocessing import forkserver\n"
        "from waamflow import cli\n"
        "started = cli._early_fork_server(pathlib.Path(sys.argv[1]), 2, None)\n"
        "print(started, forkserver._forkserver._forkserver_pid is not None, 'waamflow.engine' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", probe, str(big)], capture_output=True, text=True, timeout=120)
    assert out.stdout.split() == ["True", "True", "False"], out.stderr


def test_a_flood_of_warnings_prints_the_first_50_and_a_count():
    """trimesh's soup.stl (100 loose triangles) read as a surface gave 20,701 wall warnings: 20,706
    lines on stderr. The CLI prints the first MAX_PRINTED_WARNINGS, then one line counting the rest
    by node; -v prints them all. summary.json keeps every one (the engine's list, unchanged)."""
    import io

    from waamflow.cli import MAX_PRINTED_WARNINGS, ProgressBar
    from waamflow.engine.events import Event

    def feed(verbose):
        out = io.StringIO()
        bar = ProgressBar(out, verbose)
        for i in range(120):
            bar(Event("warning", node="walls" if i % 4 else "part", layer=i, message=f"w{i}"))
        bar(Event("run_finished", progress=1.0))
        return out.getvalue().splitlines()

    lines = feed(verbose=False)
    assert MAX_PRINTED_WARNINGS == 50 and len(lines) == 51
    assert lines[49] == "warning: walls: layer 49: w49"
    assert (
        lines[50] == "warning: 70 more warnings not shown (walls 53, part 17): all are in summary.json; -v prints them"
    )
    assert len(feed(verbose=True)) == 120
