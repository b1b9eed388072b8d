"""LinuxCNC's own interpreter reads every shipped G-code program (issue #23 item 7).

Every recipe in graphs/ whose post-process writes G-code is run with the `linuxcnc` machine
profile (`--set <post>.profile=linuxcnc`) and its program goes through `rs274`, the standalone
RS274NGC interpreter of the Debian package `linuxcnc-uspace` (`.ci/run` installs it). From the
canonical commands it prints (STRAIGHT_FEED / STRAIGHT_TRAVERSE / ARC_FEED / DWELL /
SET_FEED_RATE, SET_AUX_OUTPUT_BIT for M64, SET_AUX_OUTPUT_VALUE for M68, SET_MOTION_OUTPUT_VALUE
for M67, START_SPINDLE_CLOCKWISE for M3 …) the test measures the arc-on (deposition) length, the
arc-off motion, dwells and the time they imply (feed moves at the programmed feed, dwells,
traverses at the header's assumed travel speed) and asserts that they equal the header's
`summary:` within LEN_TOL / TIME_TOL. The header leaves out the approach from the machine's
unknown start position (rs274 starts at 0,0,0) and the final lift, so the measure does too.

Two things the standalone interpreter cannot do are bridged, each asserted: user M-codes
M100-M199 (the rolling M110/M111, job M120) are programs in a LinuxCNC config's USER_M_PATH that
`rs274` does not load (and a REMAP refuses their P/Q words), so they are turned into comments and
counted; comment lines longer than the interpreter's line limit are left out for the measuring
run, while `test_rs274_reads_the_program_verbatim` runs the program with only the user M-codes
bridged and is expected to fail (strict) until the program writes no line over the limit.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

RS274 = shutil.which("rs274")
pytestmark = pytest.mark.skipif(
    RS274 is None,
    reason="LinuxCNC's rs274 is not installed "
    "(Debian: apt-get install --no-install-recommends linuxcnc-uspace; .ci/run does)",
)

ROOT = Path(__file__).resolve().parents[2]
GRAPHS = ROOT / "graphs"
PROFILE = json.loads((ROOT / "backend/waamflow/data/machines/linuxcnc.json").read_text())["post"]
LINE_LIMIT = 252  # rs274 (2.9) rejects a line of 253 characters or more: "Command too long"
LEN_TOL = 1e-4  # relative, + 0.002 mm: coordinates are written to 0.001 mm, the header to 0.001
TIME_TOL = 5e-4  # relative, + 0.06 s: feeds are written to 0.1 mm/min (or whole), the header to 0.1 s

CALL = re.compile(r"^\s*\d+\s+N\S*\s+([A-Z_0-9]+)\((.*)\)\s*$")
USER_M = re.compile(r"^\s*M1\d\d\b", re.I)
SUMMARY = re.compile(
    r"deposition ([\d.]+) mm, travel ([\d.]+) mm, arc-on count (\d+), "
    r"dwell ([\d.]+) s, estimated time ([\d.]+) s"
)


def _gcode_posts() -> list[tuple[str, str]]:
    """(recipe, post node id) for every post-process node that writes G-code."""
    out = []
    for path in sorted(GRAPHS.glob("*.json")):
        doc = json.loads(path.read_text())
        for node in doc.get("nodes", []):
            if node["type"] != "post-process":
                continue
            fmt = node.get("params", {}).get("format", PROFILE["format"] if "format" in PROFILE else "gcode")
            if isinstance(fmt, str) and fmt.startswith("$"):
                fmt = doc.get("inputs", {}).get(fmt[1:])
            if fmt == "gcode":
                out.append((path.stem, node["id"]))
    return out


POSTS = _gcode_posts()
RECIPES = sorted({r for r, _ in POSTS})


def test_every_gcode_recipe_is_covered():
    assert RECIPES == ["bead-trials", "bracket", "mpp-cross", "thin-wall-panel"]
    assert len(POSTS) == 5


@pytest.fixture(scope="module")
def programs(tmp_path_factory) -> dict[tuple[str, str], Path]:
    """Each recipe run once (all its G-code posts with the linuxcnc profile), in parallel."""
    base = tmp_path_factory.mktemp("rs274")
    exe = Path(sys.executable).with_name("waamflow")
    cmd0 = [str(exe)] if exe.exists() else [sys.executable, "-c", "from waamflow.cli import main; main()"]
    env = dict(os.environ, WAAMFLOW_LAYER_WORKERS="1")
    procs = {}
    for recipe in RECIPES:
        sets = [a for r, nid in POSTS if r == recipe for a in ("--set", f"{nid}.profile=linuxcnc")]
        cmd = cmd0 + ["run", str(GRAPHS / f"{recipe}.json"), "--out", str(base / recipe), "--no-cache", *sets]
        procs[recipe] = subprocess.Popen(
            cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
    for recipe, p in procs.items():
        log, _ = p.communicate(timeout=300)
        assert p.returncode == 0, f"{recipe}: {log[-2000:]}"
    return {(r, nid): base / r / f"{nid}.gcode" for r, nid in POSTS}


def _config(tmp: Path) -> list[str]:
    """rs274 flags with a minimal tool table (the torch as T1) and parameter file."""
    (tmp / "tool.tbl").write_text("T1 P1 Z0 D0 ;torch\n")
    (tmp / "rs274.var").write_text("")
    return ["-g", "-t", str(tmp / "tool.tbl"), "-v", str(tmp / "rs274.var")]


def _bridge(text: str, drop_long_comments: bool) -> tuple[str, int, int]:
    """The program with user M-codes as comments (count) and, optionally, long comment lines out."""
    out, n_user, n_long = [], 0, 0
    for line in text.splitlines():
        if USER_M.match(line):
            n_user += 1
            line = "(user " + line.split(";")[0].strip().replace("(", "").replace(")", "") + ")"
        elif drop_long_comments and len(line) > LINE_LIMIT:
            assert line.startswith(";"), f"a command line over rs274's limit: {line[:80]}"
            n_long += 1
            continue
        out.append(line)
    return "\n".join(out) + "\n", n_user, n_long


def _run_rs274(tmp: Path, text: str) -> tuple[int, str, str]:
    src, canon = tmp / "prog.ngc", tmp / "prog.canon"
    src.write_text(text)
    p = subprocess.run(
        [RS274, *_config(tmp), str(src), str(canon)],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=60,
    )
    return (
        p.returncode,
        canon.read_text() if canon.exists() else "",
        (p.stdout + p.stderr).replace("executing", "").strip(),
    )


def _code_call(code: str) -> str:
    """The canonical call rs274 prints for an arc on/off line of the post header (e.g. M64_P0)."""
    words = code.replace("_", " ").upper().split()
    m = int(float(words[0][1:]))
    p = next((int(float(w[1:])) for w in words[1:] if w.startswith("P")), 0)
    return {
        62: f"SET_MOTION_OUTPUT_BIT({p})",
        63: f"CLEAR_MOTION_OUTPUT_BIT({p})",
        64: f"SET_AUX_OUTPUT_BIT({p})",
        65: f"CLEAR_AUX_OUTPUT_BIT({p})",
        3: "START_SPINDLE_CLOCKWISE(0)",
        4: "START_SPINDLE_COUNTERCLOCKWISE(0)",
        5: "STOP_SPINDLE_TURNING(0)",
    }[m]


def _arc_length(start, args: list[float]) -> float:
    """ARC_FEED(first_end, second_end, first_axis, second_axis, rotation, axis_end, …) in G17."""
    x1, y1, cx, cy, rot, z1 = args[:6]
    a0 = math.atan2(start[1] - cy, start[0] - cx)
    a1 = math.atan2(y1 - cy, x1 - cx)
    r = math.hypot(start[0] - cx, start[1] - cy)
    sweep = (a1 - a0) % (2 * math.pi) if rot > 0 else (a0 - a1) % (2 * math.pi)
    sweep += 2 * math.pi * (abs(rot) - 1) if sweep > 1e-12 else 2 * math.pi * abs(rot)
    return math.hypot(r * sweep, z1 - start[2])


def measure(canon: str, arc_on: str, arc_off: str, travel_speed: float) -> dict:
    """Arc-on length, arc-off motion, dwell and time from rs274's canonical commands."""
    pos, feed, on = (0.0, 0.0, 0.0), 0.0, False
    moves = []  # (kind, length, feed, arc on)
    r = {"arc_on_count": 0, "dwell": 0.0, "outputs": [], "traverse_arc_on": 0, "plane": "CANON_PLANE_XY"}
    for line in canon.splitlines():
        m = CALL.match(line)
        if not m:
            continue
        name, args = m.groups()
        call = f"{name}({args})"
        if call == arc_on:
            on, r["arc_on_count"] = True, r["arc_on_count"] + 1
        elif call == arc_off:
            on = False
        elif name == "SET_FEED_RATE":
            feed = float(args)
        elif name == "DWELL":
            r["dwell"] += float(args)
        elif name in ("SET_AUX_OUTPUT_VALUE", "SET_MOTION_OUTPUT_VALUE"):
            ch, v = args.split(",")
            r["outputs"].append((name, int(ch), float(v)))
        elif name == "SELECT_PLANE":
            r["plane"] = args
        elif name in ("STRAIGHT_FEED", "STRAIGHT_TRAVERSE", "ARC_FEED"):
            v = [float(a) for a in args.split(",")]
            if name == "ARC_FEED":
                assert r["plane"] == "CANON_PLANE_XY"
                end = (v[0], v[1], v[5])
                d = _arc_length(pos, v)
            else:
                end = tuple(v[:3])
                d = math.dist(pos, end)
            moves.append(("traverse" if name == "STRAIGHT_TRAVERSE" else "feed", d, feed, on, end, pos))
            pos = end
    assert moves[0][0] == "traverse", "the program starts with an approach from the start position"
    last = moves[-1]
    lift = (last[0] == "traverse" and last[4][:2] == last[5][:2]) and last[4][2] - last[5][2]
    r["approach"], r["final_lift"] = moves[0][1], lift
    r["deposition"] = sum(d for k, d, f, o, *_ in moves if k == "feed" and o)
    counted = moves[1:-1] if lift else moves[1:]
    r["travel"] = sum(d for k, d, f, o, *_ in counted if not o)
    r["traverse_arc_on"] = sum(1 for k, d, f, o, *_ in moves if k == "traverse" and o)
    assert all(f > 0 for k, d, f, o, *_ in moves if k == "feed" and d > 0), "a feed move without a feed rate"
    r["time"] = (
        sum(d / f * 60.0 if k == "feed" else d / travel_speed for k, d, f, o, *_ in counted if d > 0) + r["dwell"]
    )
    return r


def _header(text: str) -> dict:
    head = "\n".join(text.splitlines()[:20])
    s = SUMMARY.search(head)
    post = re.search(r"waamflow-post: arc_on=(\S+) arc_off=(\S+)", head)
    speed = re.search(r"assumes ([\d.]+) mm/s", head)
    assert s and post and speed, head
    return {
        "deposition": float(s[1]),
        "travel": float(s[2]),
        "arc_on_count": int(s[3]),
        "dwell": float(s[4]),
        "time": float(s[5]),
        "arc_on": post[1],
        "arc_off": post[2],
        "travel_speed": float(speed[1]),
    }


def _analog_lines(text: str) -> list[tuple[str, int, float]]:
    """M67/M68 E<n> Q<v> lines as the canonical calls rs274 should print for them."""
    out = []
    for m in re.finditer(r"^M6([78]) E(\d+) Q(-?[\d.]+)", text, re.M):
        out.append(("SET_MOTION_OUTPUT_VALUE" if m[1] == "7" else "SET_AUX_OUTPUT_VALUE", int(m[2]), float(m[3])))
    return out


RESULTS: dict[str, dict] = {}


@pytest.mark.parametrize("recipe,post", POSTS, ids=[f"{r}:{n}" for r, n in POSTS])
def test_rs274_lengths_and_time_equal_the_header(programs, tmp_path, recipe, post):
    text = programs[(recipe, post)].read_text()
    head = _header(text)
    bridged, n_user, n_long = _bridge(text, drop_long_comments=True)
    assert n_long == 0
    rc, canon, msg = _run_rs274(tmp_path, bridged)
    assert rc == 0 and msg == "", f"rs274 reports an error: {msg}"
    assert "PROGRAM_END()" in canon
    assert canon.count('COMMENT("user M1') == n_user
    got = measure(canon, _code_call(head["arc_on"]), _code_call(head["arc_off"]), head["travel_speed"])
    RESULTS[f"{recipe}:{post}"] = {"rs274": got, "header": head, "user_m": n_user, "long_comments": n_long}
    print(
        f"\n{recipe}:{post}: rs274 deposition {got['deposition']:.3f} mm (header {head['deposition']:.3f}), "
        f"arc-off motion {got['travel']:.3f} mm ({head['travel']:.3f}), arc-on {got['arc_on_count']} "
        f"({head['arc_on_count']}), dwell {got['dwell']:.3f} s ({head['dwell']:.3f}), time {got['time']:.2f} s "
        f"({head['time']:.1f}); approach {got['approach']:.3f} mm, final lift {got['final_lift']} mm; "
        f"user M-codes bridged {n_user}, long comment lines {n_long}"
    )
    assert got["arc_on_count"] == head["arc_on_count"]
    assert got["traverse_arc_on"] == 0, "a G0 while the arc is on"
    assert got["final_lift"] == pytest.approx(PROFILE["final_lift"], abs=1e-9)
    assert got["deposition"] == pytest.approx(head["deposition"], rel=LEN_TOL, abs=2e-3)
    assert got["travel"] == pytest.approx(head["travel"], rel=LEN_TOL, abs=2e-3)
    assert got["dwell"] == pytest.approx(head["dwell"], abs=1e-3)
    assert got["time"] == pytest.approx(head["time"], rel=TIME_TOL, abs=0.06)
    # every M67/M68 weld value reaches the interpreter's analog outputs, in order
    assert got["outputs"] == _analog_lines(text)
    if head["arc_on_count"]:
        assert {ch for _, ch, _ in got["outputs"]} >= {0}, "no wire feed (E0) commanded"


def test_measure_counts_what_it_should(tmp_path):
    """The measure on a hand-made program: 30 mm arc on at 600 mm/min (3 s), a 90° arc of r 10
    (15.708 mm, 1.571 s), 2 s dwell; 40 mm traverse at 100 mm/s (0.4 s); approach and lift left out."""
    prog = (
        "\n".join(
            [
                "G21 G90 G17",
                "G0 X0 Y0 Z5",
                "M64 P0",
                "G4 P2",
                "G1 X30 F600",
                "G3 X40 Y10 I0 J10",
                "M65 P0",
                "G0 X40 Y50",
                "M68 E0 Q3.20",
                "G0 Z15",
                "M2",
            ]
        )
        + "\n"
    )
    rc, canon, msg = _run_rs274(tmp_path, prog)
    assert rc == 0 and msg == ""
    got = measure(canon, _code_call("M64_P0"), _code_call("M65_P0"), 100.0)
    assert got["deposition"] == pytest.approx(30 + 5 * math.pi, abs=1e-3)
    assert got["travel"] == pytest.approx(40.0, abs=1e-9)
    assert got["time"] == pytest.approx(3 + 5 * math.pi / 10 + 2 + 0.4, abs=1e-3)
    assert got["final_lift"] == pytest.approx(10.0) and got["approach"] == pytest.approx(5.0)
    assert got["outputs"] == [("SET_AUX_OUTPUT_VALUE", 0, 3.2)] and got["arc_on_count"] == 1


def test_rs274_reports_errors(tmp_path):
    rc, _, msg = _run_rs274(tmp_path, "G21\n; " + "x" * LINE_LIMIT + "\nG1 X1 F100\nM2\n")
    assert rc != 0 and "too long" in msg
    rc, _, msg = _run_rs274(tmp_path, "G21\nM110 P1 Q2\nM2\n")
    assert rc != 0 and "M110" in msg


@pytest.mark.parametrize("recipe,post", POSTS, ids=[f"{r}:{n}" for r, n in POSTS])
def test_rs274_reads_the_program_verbatim(programs, tmp_path, recipe, post):
    bridged, _, _ = _bridge(programs[(recipe, post)].read_text(), drop_long_comments=False)
    # every line as written, the header included (the weld tag was one 282-character line, which
    # LinuxCNC refused as 'Command too long'; it is one line per weld value now)
    assert max(len(line) for line in bridged.splitlines()) <= LINE_LIMIT
    rc, _, msg = _run_rs274(tmp_path, bridged)
    assert rc == 0 and msg == "", f"rs274 reports an error: {msg}"
