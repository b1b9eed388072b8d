"""One gate for every parameter that names a file (#26 faults 2, 3, 4).

Walks the node catalog: every parameter marked `x-file` (a file the node reads) or `x-shipped` (a
name of shipped data: robot profiles and descriptions, cells, machine profiles) gets the traversal /
device / FIFO / socket / symlink set over REST and must answer 422 naming the node and the
parameter — before a run exists, without opening anything outside the allowed folders, and without
opening the FIFO or socket at all. The engine's own reads (the CLI's, no sandbox) refuse devices,
FIFOs and sockets in well under a second and check a file's size before reading it."""

import json
import os
import socket
import sys
import threading
import time

import pytest
from fastapi.testclient import TestClient

from waamflow.api.app import create_app
from waamflow.cli import main as cli
from waamflow.core.errors import InputFileError
from waamflow.engine.executor import FileResolver
from waamflow.settings import Settings
from waamflow.trajectory.profile import load_profile

SECRET_KEY = "aws_access_key_id_for_the_lab"
OPENED: list[str] | None = None  # while a list: every path this process opens (audit hook)


def _audit(event, args):
    if OPENED is not None and event == "open" and args and isinstance(args[0], (str, bytes, os.PathLike)):
        OPENED.append(os.fsdecode(args[0]))


sys.addaudithook(_audit)  # cannot be removed; inert while OPENED is None


@pytest.fixture()
def folders(tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.json").write_text(json.dumps({SECRET_KEY: "AKIA-not-for-you", "path_acc": 1}))
    g = tmp_path / "graphs"
    g.mkdir()
    (g / "inside.stl").write_text("solid x\nendsolid x\n")
    os.mkfifo(g / "fifo.stl")
    os.mkfifo(g / "fifo.json")
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(g / "sock.stl"))
    os.symlink(outside / "secret.json", g / "out-link.json")
    os.symlink("/dev/zero", g / "zero-link.stl")
    (g / "folder.stl").mkdir()
    yield tmp_path, outside, g
    sock.close()


# what a file parameter is given; each must be refused (why: a word of the expected message)
FILE_ATTACKS = [
    ("/etc/passwd", "absolute"),
    ("/dev/zero", "absolute"),
    ("../outside/secret.json", "'..'"),
    ("sub/../../outside/secret.json", "'..'"),
    ("out-link.json", "outside"),
    ("zero-link.stl", "outside"),
    ("fifo.stl", "FIFO"),
    ("fifo.json", "FIFO"),
    ("sock.stl", "socket"),
    ("folder.stl", "folder"),
    ("file:///etc/passwd", "URL"),
]
SHIPPED_ATTACKS = [
    "/etc/passwd",
    "/dev/zero",
    "../../../../../etc/passwd",
    "../outside/secret",
    "./fifo.stl",
    "a/b",
    "..",
    "/proc/self/environ",
]


def _catalog_file_params(c) -> list[tuple[str, str, str, dict]]:
    """(node type, param, "file" | "shipped", the node's required params) from GET /api/nodes."""
    out = []
    for node in c.get("/api/nodes").json():
        props = node["params_schema"].get("properties", {})
        required = {k: "inside.stl" for k in node["params_schema"].get("required", []) if props[k].get("x-file")}
        for name, schema in props.items():
            if schema.get("x-file"):
                out.append((node["type"], name, "file", required))
            if schema.get("x-shipped"):
                out.append((node["type"], name, "shipped", required))
    return out


def test_every_file_parameter_refuses_the_attack_set(folders):
    global OPENED
    tmp, outside, g = folders
    s = Settings(data_dir=tmp / "data", graphs_dir=g, start_viewer=False, static_dir=None, workers=1)
    with TestClient(create_app(s)) as c:
        params = _catalog_file_params(c)
        kinds = {(t, p): k for t, p, k, _ in params}
        # the walk finds every kind of file the issue names (mesh, sketch, zone XML, trials, traces,
        # cells, robot descriptions, robot profiles, machine profiles)
        for want in [
            ("mesh", "path"),
            ("sketch", "path"),
            ("zone", "parameters"),
            ("bead-fit", "trials"),
            ("calibrate-robot", "trace"),
            ("simulate-robot", "cell"),
            ("simulate-robot", "profile_file"),
            ("simulate-robot", "robot_description"),
            ("simulate-robot", "robot_profile"),
            ("estimate-time", "robot_profile"),
            ("post-process", "profile"),
            ("post-process", "cell"),
        ]:
            assert want in kinds, want
        assert kinds[("simulate-robot", "robot_description")] == "shipped"
        OPENED = []
        answered = 0
        for ntype, pname, kind, required in params:
            attacks = FILE_ATTACKS if kind == "file" else [(a, "shipped") for a in SHIPPED_ATTACKS]
            if (ntype, pname) == ("simulate-robot", "cell"):  # a shipped name, or a user's cell .json file
                attacks += [(a, w) for a, w in FILE_ATTACKS if a.endswith(".json")]
            for value, why in attacks:
                rec = {
                    "format": "waamflow/1",
                    "name": "gate",
                    "edges": [],
                    "nodes": [{"id": "n", "type": ntype, "params": {**required, pname: value}}],
                }
                t0 = time.time()
                r = c.post("/api/runs", json={"recipe": rec})
                assert time.time() - t0 < 5
                assert r.status_code == 422, (ntype, pname, value, r.status_code, r.text)
                d = r.json()["detail"]
                assert d["node"] == "n" and d["field"] == pname, (ntype, pname, value, d)
                assert why in d["message"] and "should match pattern" not in d["message"], (ntype, pname, value, d)
                assert SECRET_KEY not in r.text and "root:" not in r.text
                answered += 1
        # a file outside answers the same whether it exists or not (nothing is looked at out there)
        os.symlink(outside / "missing.json", g / "dangling.json")
        for there, missing in [
            ("../outside/secret.json", "../outside/missing.json"),
            (str(outside / "secret.json"), str(outside / "missing.json")),
            ("out-link.json", "dangling.json"),
        ]:
            answers = []
            for value in (there, missing):
                rec = {
                    "format": "waamflow/1",
                    "name": "gate",
                    "edges": [],
                    "nodes": [{"id": "n", "type": "mesh", "params": {"path": value}}],
                }
                r = c.post("/api/runs", json={"recipe": rec})
                answers.append((r.status_code, r.json()["detail"]["message"].replace(value, "<value>")))
            assert answers[0] == answers[1] and answers[0][0] == 422, answers
        opened, OPENED = OPENED, None
        assert answered >= 150, answered
        forbidden = (str(outside), str(g / "fifo"), str(g / "sock"), str(g / "zero-link"), "/dev/", "/etc/", "/proc/")
        assert not [p for p in opened if p.startswith(forbidden)], opened
        assert c.get("/api/runs").json() == []  # no run was created


def _within(seconds: float, fn):
    """fn() in a thread; its result or exception, failing when it has not returned in time."""
    box: dict = {}

    def go():
        try:
            box["value"] = fn()
        except BaseException as e:  # noqa: BLE001 - handed back to the test
            box["error"] = e

    t = threading.Thread(target=go, daemon=True)
    t.start()
    t.join(seconds)
    assert not t.is_alive(), f"still blocked after {seconds} s"
    return box


def test_engine_reads_refuse_fifo_device_socket_and_check_size_first(folders):
    """The CLI's resolver has no folder limits, but what it opens must still be a regular file."""
    _, _, g = folders
    res = FileResolver(g)
    for name, word in [
        ("fifo.stl", "FIFO"),
        ("/dev/zero", "device"),
        ("zero-link.stl", "device"),
        ("sock.stl", "socket"),
        ("folder.stl", "folder"),
    ]:
        box = _within(3, lambda: res.read_bytes(name))
        assert isinstance(box.get("error"), InputFileError) and word in str(box["error"]), (name, box)
        box = _within(3, lambda: res.signature(name))  # the cache key never reads it either
        assert "value" in box, (name, box)
        assert "value" in _within(3, lambda: res.sha256(name)), name
    big = g / "big.stl"
    with open(big, "wb") as f:
        f.truncate(600 * 2**20)  # sparse: 600 MB long, nothing to read
    box = _within(3, lambda: res.read_bytes("big.stl"))
    assert isinstance(box.get("error"), InputFileError) and "MB" in str(box["error"]) and "limit" in str(box["error"])
    box = _within(3, lambda: res.read_bytes("inside.stl", max_bytes=5))
    assert isinstance(box.get("error"), InputFileError) and "limit" in str(box["error"])
    assert res.read_bytes("inside.stl") == b"solid x\nendsolid x\n"


def test_cli_robot_description_dev_zero_is_refused_at_once(tmp_path, capsys):
    rec = {
        "format": "waamflow/1",
        "name": "z",
        "edges": [],
        "nodes": [{"id": "sim", "type": "simulate-robot", "params": {"robot_description": "/dev/zero"}}],
    }
    p = tmp_path / "z.json"
    p.write_text(json.dumps(rec))
    t0 = time.time()
    assert cli(["run", str(p), "--out", str(tmp_path / "out")]) == 2
    assert time.time() - t0 < 10
    err = capsys.readouterr().err
    assert err.startswith("error:") and "sim" in err and "robot_description" in err, err


def test_profile_errors_never_echo_keys():
    with pytest.raises(InputFileError) as e:
        load_profile("mine.json", text=json.dumps({SECRET_KEY: "x", "other_secret_name": 1, "path_acc": 1}))
    msg = str(e.value)
    assert SECRET_KEY not in msg and "other_secret_name" not in msg and "2 keys" in msg, msg
