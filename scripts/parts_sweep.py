"""Run other people's meshes through the generic recipes and print each run's preflight verdict.

    .venv/bin/python scripts/parts_sweep.py DIR [--out out/sweep] [--patterns contour,parallel,...]
        [--units m] [--placement on_plate]

Every STL/OBJ/PLY/3MF/STEP/IGES in DIR (and every DXF, its curves extruded 20 mm) goes through mesh → slice (2 mm) → mask → strategy (each pattern, 5 mm
beads, 4 mm spacing) → sequence → post (G-code), and through mesh → slice → features → wall-path →
sequence → post; the programs are kept even when the preflight fails (`--accept-preflight`), so
each failure can be read in its preflight.json. A line per run: exit code, seconds, verdict and
the checks that warned or failed. This is how the faults named in the tests' docstrings after
compas_slicer's, trimesh's and the other test models were found (README, "Other people's parts");
the meshes are not in the repository: fetch them first (e.g. compas-dev/compas_slicer's
data/test_geometries)."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MESHES = (".stl", ".obj", ".ply", ".off", ".3mf", ".step", ".stp", ".iges", ".igs")
SKETCHES = (".dxf",)  # read by the sketch node: its curves extruded SKETCH_HEIGHT mm
SKETCH_HEIGHT = 20.0


def recipe(
    mesh: str, pattern: str | None, units: str = "file", placement: str = "as_is", same_stem: bool = False
) -> dict:
    """The generic recipe for one mesh: a strategy `pattern`, or wall-path when None; `units`:
    the input node's file units ("file": as the file says, else mm); `placement`: the input node's
    (on_plate for parts modelled away from z = 0, e.g. robot links in their joint frames);
    `same_stem`: another file shares the mesh's stem (PrusaSlicer's pyramid.obj and pyramid.stl):
    the run is named by the whole file name, so neither run's output overwrites the other's."""
    common = {"path": mesh, "units": units, "placement": placement}
    part = {"id": "part", "type": "mesh", "params": common}
    if Path(mesh).suffix.lower() in SKETCHES:
        part = {"id": "part", "type": "sketch", "params": {**common, "height": SKETCH_HEIGHT}}
    nodes = [
        part,
        {"id": "layers", "type": "slice", "params": {"layer_height": 2.0}},
    ]
    edges = [{"from": "part.mesh", "to": "layers.mesh"}]
    if pattern:
        nodes += [
            {"id": "mask", "type": "mask", "params": {}},
            {
                "id": "strategy",
                "type": "strategy",
                "params": {"default": {"pattern": pattern, "bead_width": 5, "spacing": 4}},
            },
        ]
        edges += [
            {"from": "layers.layers", "to": "mask.layers"},
            {"from": "mask.sections", "to": "strategy.sections"},
            {"from": "strategy.toolpath", "to": "sequence.toolpath"},
        ]
    else:
        nodes += [
            {"id": "features", "type": "features", "params": {}},
            {"id": "walls", "type": "wall-path", "params": {}},
        ]
        edges += [
            {"from": "layers.layers", "to": "features.layers"},
            {"from": "layers.layers", "to": "walls.layers"},
            {"from": "features.features", "to": "walls.features"},
            {"from": "walls.toolpath", "to": "sequence.toolpath"},
        ]
    nodes += [
        {"id": "sequence", "type": "sequence", "params": {"order": "nearest", "retract_height": 5}},
        {"id": "post", "type": "post-process", "params": {"format": "gcode", "weld_values": {"wire_feed_speed": 4}}},
    ]
    edges.append({"from": "sequence.toolpath", "to": "post.toolpath"})
    stem = Path(mesh).stem if not same_stem else Path(mesh).name.replace(".", "_")
    name = f"{stem}__{pattern or 'walls'}"
    return {"format": "waamflow/1", "name": name, "nodes": nodes, "edges": edges}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", type=Path, help="folder of meshes")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "sweep")
    ap.add_argument("--patterns", default="contour,parallel,oscillate,raster,spiral")
    ap.add_argument("--units", default="file", help="the files' length unit (e.g. m for robot link meshes)")
    ap.add_argument("--placement", default="as_is", help="as_is, on_plate or centred (the input node's)")
    args = ap.parse_args()
    exe = ROOT / ".venv" / "bin" / "waamflow"
    args.out.mkdir(parents=True, exist_ok=True)
    meshes = sorted(p for p in args.dir.iterdir() if p.suffix.lower() in MESHES + SKETCHES and p.stat().st_size > 0)
    stems = [m.stem for m in meshes]
    for mesh in meshes:
        for pattern in [*args.patterns.split(","), None]:
            rec = recipe(mesh.name, pattern or None, args.units, args.placement, stems.count(mesh.stem) > 1)
            path = args.dir / f"{rec['name']}.json"
            path.write_text(json.dumps(rec, indent=1))
            out = args.out / rec["name"]
            t0 = time.perf_counter()
            run = [str(exe), "run", str(path), "--out", str(out), "--no-cache", "--accept-preflight"]
            done = subprocess.run(run, capture_output=True, text=True)
            seconds = time.perf_counter() - t0
            try:
                pf = json.loads((out / "preflight.json").read_text())
                checks = sorted({f"{p['check']}:{p['severity']}" for p in pf["problems"]})
                what = f"{pf['verdict']} {' '.join(checks)}"
            except (OSError, ValueError, KeyError):
                last = (done.stdout + done.stderr).strip().splitlines()
                what = "no preflight: " + (last[-1][:160] if last else "")
            print(f"{rec['name']}  exit {done.returncode}  {seconds:.1f} s  {what}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
