"""STL → G-code side by side with PrusaSlicer on three shapes (issues 15 and 30).

Shapes: `vase` (below), `twisted_vase` (the same tube with a ±10 mm 3-lobed ripple on both walls,
turning 120° over the height: the ring changes every layer), `bracket` (graphs/bracket.json as
shipped: 300 layers through masks, parallel passes, zones, sequence, post-process and the
preflight; PrusaSlicer: one 6 mm perimeter and 100 % rectilinear infill of 6 mm lines, i.e. the
same area filled with beads). `stl_to_gcode_ratio_vs_prusaslicer_<shape>` per shape and
`stl_to_gcode_ratio_vs_prusaslicer` = the worst of them (the figure that counts: a user's part is
not the bench's).

- per shape: wall time of `waamflow run` (a fresh CLI process, no cache,
  default workers: mesh → slice → wall-path → post-process, G-code written to disk) / wall time of
  the `prusa-slicer` CLI (a fresh process: load STL → slice → perimeters → G-code) on the same
  binary STL in the same run. The vase: an open tube r 80/74 mm, 200 mm high, 1,008,000
  triangles (2,000 facets round, 125 stacks), 133 layers of 1.5 mm. PrusaSlicer is configured for
  one perimeter of 6 mm extrusion width, no infill, no top/bottom layers, no skirt or brim
  (`PRUSA_CONFIG`); waamflow lays one bead per layer on the ring's centre line. Targets: ≤ 0.5,
  ≤ 1.0 at the very least. Value = ratio of the medians of `REPEATS` alternating runs
  (`WAAMFLOW_BENCH_REPEATS`, default 3); the notes carry both wall and CPU seconds (user + sys of the
  process tree, the layer workers included), per-node seconds of waamflow's run, both programs' layer counts
  and the machine load, since other processes on a shared machine move the wall times.

PrusaSlicer comes from Debian (`prusa-slicer`, 2.5.0 on bookworm). When it is not on PATH the
bench installs it with `apt-get install -y prusa-slicer` (root only); if that is not possible the
entry has value null and says why, and the rest of the bench runs on.
Run alone: `.venv/bin/python bench/run.py bench_vase`.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

R_OUT, R_IN, HEIGHT, LAYER = 80.0, 74.0, 200.0, 1.5
N_THETA, N_Z = 2000, 125  # 4 · 2000 · 126 = 1,008,000 triangles
REPEATS = max(1, int(os.environ.get("WAAMFLOW_BENCH_REPEATS", "3")))  # one pair is at the mercy of one moment's load

PRUSA_CONFIG = """\
# one 6 mm perimeter per 1.5 mm layer, nothing else (the WAAM comparison of issue 15)
layer_height = 1.5
first_layer_height = 1.5
nozzle_diameter = 6
max_layer_height = 1.5
min_layer_height = 0.1
perimeters = 1
top_solid_layers = 0
bottom_solid_layers = 0
fill_density = 0%
extrusion_width = 6
perimeter_extrusion_width = 6
external_perimeter_extrusion_width = 6
first_layer_extrusion_width = 6
thin_walls = 0
skirts = 0
brim_width = 0
support_material = 0
bed_shape = 0x0,300x0,300x300,0x300
max_print_height = 300
gcode_flavor = reprap
gcode_comments = 0
"""


def _recipe() -> dict:
    return {
        "format": "waamflow/1",
        "name": "bench-vase",
        "description": "Thin-walled vase r 80/74 mm, 200 mm: one bead per 1.5 mm layer on the ring's centre line",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "vase.stl"}},
            {"id": "layers", "type": "slice", "params": {"layer_height": LAYER}},
            {
                "id": "walls",
                "type": "wall-path",
                # one lap a layer, as PrusaSlicer's perimeters (aligned: what `helical` lays on rings)
                "params": {"speed": 10.0, "spacing": 1.0, "overlap": 5.0, "bead_width": 6.0, "tubular": "aligned"},
            },
            # the weld commanded: 5 m/min puts a 6 × 1.5 mm bead at 10 mm/s (wire/part 1.0 in the preflight)
            {
                "id": "post",
                "type": "post-process",
                "params": {"format": "gcode", "weld_values": {"wire_feed_speed": 5.0}},
            },
        ],
        "edges": [
            {"from": "part.mesh", "to": "layers.mesh"},
            {"from": "layers.layers", "to": "walls.layers"},
            {"from": "walls.toolpath", "to": "post.toolpath"},
        ],
    }


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _tree_cpu(root: int) -> dict[int, float]:
    """CPU seconds (user + sys) so far of every process below `root`, by pid (Linux /proc)."""
    tick = os.sysconf("SC_CLK_TCK")
    kids: dict[int, list[tuple[int, float]]] = {}
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as fh:
                st = fh.read()
        except OSError:
            continue
        f = st[st.rindex(")") + 2 :].split()
        kids.setdefault(int(f[1]), []).append((int(d), (int(f[11]) + int(f[12])) / tick))
    out, todo = {}, [root]
    while todo:
        for pid, cpu in kids.get(todo.pop(), []):
            out[pid] = cpu
            todo.append(pid)
    return out


def _timed(cmd: list[str], env: dict | None = None, cwd: Path | None = None) -> tuple[float, float, str]:
    """(wall s, CPU s of the process tree, stderr tail); raises on a non-zero exit.

    CPU: the larger of what the children reaped report (getrusage) and the sum over every process
    of the tree, polled every 50 ms from /proc: waamflow's layer workers are forked by a fork
    server that no one reaps when the run ends, so getrusage never sees their CPU (a parallel run
    read 7.6 s where its processes had used 14.1 s)."""
    c0, t0 = _children_cpu(), time.perf_counter()
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        p = subprocess.Popen(cmd, env=env, cwd=cwd, stdout=out, stderr=err, text=True)
        seen: dict[int, float] = {}
        poll = os.path.isdir("/proc")
        while p.poll() is None:
            if poll:
                for pid, cpu in _tree_cpu(os.getpid()).items():
                    seen[pid] = max(seen.get(pid, 0.0), cpu)
            if time.perf_counter() - t0 > 1800:
                p.kill()
            time.sleep(0.05)
        wall = time.perf_counter() - t0
        err.seek(0)
        stderr = err.read()
        out.seek(0)
        stdout = out.read()
    seen.pop(os.getpid(), None)
    cpu = max(_children_cpu() - c0, sum(seen.values()))
    if p.returncode != 0:
        raise RuntimeError(f"{cmd[0]} exited {p.returncode}: {(stderr or stdout)[-800:]}")
    return wall, cpu, stderr[-400:]


def _prusa_slicer() -> tuple[str | None, str]:
    """Path of the prusa-slicer CLI (installing the Debian package if missing), or None and why."""
    exe = shutil.which("prusa-slicer")
    if exe:
        return exe, ""
    if os.geteuid() != 0 or not shutil.which("apt-get"):
        return None, "prusa-slicer is not on PATH and apt-get cannot install it here (not root or no apt)"
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for cmd in (
        ["apt-get", "install", "-y", "--no-install-recommends", "prusa-slicer"],
        ["apt-get", "update"],
        ["apt-get", "install", "-y", "--no-install-recommends", "prusa-slicer"],
    ):
        subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=1200)
        exe = shutil.which("prusa-slicer")
        if exe:
            return exe, "installed by the bench (apt-get install prusa-slicer)"
    return None, "apt-get install prusa-slicer failed (is the Debian package reachable?)"


def _prusa_version(exe: str) -> str:
    p = subprocess.run([exe, "--help"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    line = next((ln for ln in p.stdout.splitlines() if ln.startswith("PrusaSlicer")), "PrusaSlicer ?")
    return line.split(" based on")[0]


BRACKET_PRUSA = (
    PRUSA_CONFIG.replace(
        "fill_density = 0%",
        "fill_density = 100%\nfill_pattern = rectilinear\ninfill_extrusion_width = 6\nsolid_infill_extrusion_width = 6",
    )
    .replace("max_print_height = 300", "max_print_height = 460")
    .replace("bed_shape = 0x0,300x0,300x300,0x300", "bed_shape = 0x0,400x0,400x400,0x400")
)


def _shape(name: str, tmp: Path) -> tuple[Path, Path, str, str]:
    """(STL, waamflow recipe, PrusaSlicer config, description) of bench shape `name` in `tmp`."""
    from bench_slice import ribbed_tube, write_binary_stl

    if name in ("vase", "twisted_vase"):
        twisted = name == "twisted_vase"
        corners = ribbed_tube(
            N_THETA,
            N_Z,
            radius=R_OUT,
            wall=R_OUT - R_IN,
            height=HEIGHT,
            rib_depth=10.0 if twisted else 0.0,
            ribs=3,
            twist_deg=120.0 if twisted else 0.0,
            inner_follows=twisted,
        )
        n_tri = len(corners)
        size = write_binary_stl(str(tmp / f"{name}.stl"), corners)
        del corners
        rec = _recipe()
        rec["nodes"][0]["params"]["path"] = f"{name}.stl"
        (tmp / f"{name}.json").write_text(json.dumps(rec))
        (tmp / f"{name}.ini").write_text(PRUSA_CONFIG)
        desc = (
            f"{'twisted 3-lobed ±10 mm ' if twisted else ''}vase r {R_OUT:g}/{R_IN:g} mm × {HEIGHT:g} mm, "
            f"{n_tri:,} triangles ({size / 1e6:.0f} MB binary STL), {LAYER} mm layers"
        )
        return tmp / f"{name}.stl", tmp / f"{name}.json", tmp / f"{name}.ini", desc
    if name == "bracket":
        rec = json.loads((ROOT / "graphs" / "bracket.json").read_text())
        stl = tmp / "bracket.stl"
        shutil.copy(ROOT / "graphs" / "parts" / "bracket.stl", stl)
        for n in rec["nodes"]:
            if n["type"] == "mesh":
                n["params"]["path"] = "bracket.stl"
        (tmp / "bracket.json").write_text(json.dumps(rec))
        (tmp / "bracket.ini").write_text(BRACKET_PRUSA)
        return (
            stl,
            tmp / "bracket.json",
            tmp / "bracket.ini",
            "bracket 300 × 90 × 450 mm (graphs/bracket.json), 1.5 mm layers",
        )
    raise ValueError(name)


SHAPES = ("vase", "twisted_vase", "bracket")


def _one(name: str, exe: str | None, why: str, tmp: Path) -> dict:
    stl, recipe, ini, desc = _shape(name, tmp)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "backend"), os.environ.get("PYTHONPATH", "")])}
    out = tmp / f"out-{name}"
    waam_cmd = [str(Path(sys.executable).parent / "waamflow"), "run", str(recipe), "--no-cache", "--out", str(out)]
    if not Path(waam_cmd[0]).exists():
        waam_cmd[:1] = [sys.executable, "-m", "waamflow.cli"]
    ours, theirs = [], []
    for _ in range(REPEATS):  # alternating, so a change of machine load hits both
        ours.append(_timed(waam_cmd, env=env))
        if exe:
            theirs.append(
                _timed(
                    [
                        exe,
                        "--loglevel",
                        "1",
                        "--export-gcode",
                        "--load",
                        str(ini),
                        "--center",
                        "200,200" if name == "bracket" else "150,150",
                        "--output",
                        str(tmp / f"prusa-{name}.gcode"),
                        str(stl),
                    ],
                    cwd=tmp,
                )
            )
    summary = json.loads((out / "summary.json").read_text())
    gcode = (out / "post.gcode").read_text()
    our_layers = sum(1 for ln in gcode.splitlines() if ln.startswith("; layer "))
    nodes = ", ".join(f"{k} {v['seconds']:.2f}" for k, v in summary["nodes"].items())
    t_ours = statistics.median(w for w, _, _ in ours)
    c_ours = statistics.median(c for _, c, _ in ours)
    base = (
        f"{desc}; waamflow CLI cold (--no-cache, {summary['executor']['workers']} workers, "
        f"{summary['executor'].get('tasks', 0)} layer tasks) "
        f"{t_ours:.2f} s wall / {c_ours:.2f} s CPU (runs {'/'.join(f'{w:.2f}' for w, _, _ in ours)} s), "
        f"{our_layers} layers, nodes: {nodes}"
    )
    name_out = f"stl_to_gcode_ratio_vs_prusaslicer_{name}"
    if not exe:
        return {
            "name": name_out,
            "value": None,
            "unit": "x",
            "peer": None,
            "ratio": None,
            "notes": f"NOT MEASURED: {why}; {base}",
        }
    prusa_layers = (tmp / f"prusa-{name}.gcode").read_text().count(";LAYER_CHANGE")
    t_theirs = statistics.median(w for w, _, _ in theirs)
    c_theirs = statistics.median(c for _, c, _ in theirs)
    ratio = t_ours / t_theirs
    return {
        "name": name_out,
        "value": round(ratio, 3),
        "unit": "x",
        "peer": round(t_theirs, 3),
        "ratio": round(ratio, 4),
        "cpu_ratio": round(c_ours / c_theirs, 3),
        "notes": f"{base}; {_prusa_version(exe)} CLI ({'perimeter + 100 % infill' if name == 'bracket' else 'perimeter only'}, "
        f"6 mm extrusion width{', ' + why if why else ''}) {t_theirs:.2f} s wall / {c_theirs:.2f} s CPU "
        f"(runs {'/'.join(f'{w:.2f}' for w, _, _ in theirs)} s), "
        f"{prusa_layers} layers; CPU ratio {c_ours / c_theirs:.2f}; median of {REPEATS}; "
        f"load {os.getloadavg()[0]:.1f}; target <= 0.5 (at least <= 1.0)",
    }


def run() -> list[dict]:
    exe, why = _prusa_slicer()
    out = []
    for name in SHAPES:
        with tempfile.TemporaryDirectory() as d:
            out.append(_one(name, exe, why, Path(d)))
    measured = [e for e in out if e["value"] is not None]
    if measured:
        worst = max(measured, key=lambda e: e["value"])
        out.append(
            {
                **worst,
                "name": "stl_to_gcode_ratio_vs_prusaslicer",
                "notes": f"worst of {', '.join(SHAPES)}: {worst['name'].rsplit('_vs_prusaslicer_', 1)[1]}; "
                + worst["notes"],
            }
        )
    else:
        out.append({**out[0], "name": "stl_to_gcode_ratio_vs_prusaslicer"})
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
