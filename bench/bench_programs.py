"""Simulated vs header time of every shipped program that is simulated as written (issue #23).

For each recipe in graphs/ whose simulate-robot node reads a post-process's program (its `program`
input is connected), the recipe is run once without the cache and two cycle times are set side by
side: `simulation.json`'s `total_time_s` (the controller model running the program as written:
its blending, dwells and controller family) and the program header's `estimated_time_s` (the
post-processor's own estimate: programmed feeds, dwells, travel at the stated travel speed).

- `program_time_<recipe>`: simulated seconds; peer = the header's; ratio = simulated / header.
  A ratio above 1 is time the header does not know about (acceleration, corners, blending).
  The notes name the controller family and robot profile simulated (KRL → KUKA KR C2, or KR C4
  for ArcTech Basic 3.x; RAPID → ABB IRC5; G-code → the G-code motion planner with junction
  deviation, unless the recipe names the robot that runs it).
- `program_time_<recipe>_gcode_planner`: for a G-code program the recipe runs on its own robot
  (bead-trials sets cdis on simulate-robot), the same program once more on the G-code planner
  family (simulate-robot without its robot/blend params): what a gantry with the shipped
  planner profile (500 mm/s², junction deviation 0.05 mm, 16-block look-ahead) would take.
"""

from __future__ import annotations

import json
from pathlib import Path

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import load_recipe, parse_recipe

GRAPHS = Path(__file__).resolve().parents[1] / "graphs"


def simulated_programs(recipe_path: Path) -> list[tuple[str, str]]:
    """(simulate-robot id, post-process id) pairs where the simulation reads the program."""
    doc = json.loads(recipe_path.read_text())
    types = {n["id"]: n["type"] for n in doc["nodes"]}
    pairs = []
    for e in doc["edges"]:
        src, dst = e["from"].split(".")[0], e["to"]
        if (
            dst.endswith(".program")
            and types.get(dst.split(".")[0]) == "simulate-robot"
            and types.get(src) == "post-process"
        ):
            pairs.append((dst.split(".")[0], src))
    return pairs


ROBOT_PARAMS = ("robot_profile", "profile_file", "cdis", "blend")


def _row(name: str, result, sim: str, post: str, extra: str = "") -> dict:
    sj = json.loads(result.artifacts[f"{sim}.simulation.json"])
    simulated = sj["total_time_s"]
    stats = result.program_stats()[post]
    header = stats["estimated_time_s"]
    return {
        "name": name,
        "value": round(simulated, 2),
        "unit": "s",
        "peer": round(header, 2),
        "ratio": round(simulated / header, 4),
        "notes": f"{post} ({stats['format']}) simulated by {sim} as written{extra} "
        f"(controller {sj['settings']['controller']}, profile {sj['robot_profile']}) "
        f"vs the program header's estimate",
    }


def run() -> list[dict]:
    out = []
    for path in sorted(GRAPHS.glob("*.json")):
        pairs = simulated_programs(path)
        if not pairs:
            continue
        recipe = load_recipe(path)
        result = execute(build_graph(recipe), resolver=FileResolver(path.parent), preflight=False)
        for sim, post in pairs:
            out.append(_row(f"program_time_{path.stem}", result, sim, post))
            sj = json.loads(result.artifacts[f"{sim}.simulation.json"])
            if result.program_stats()[post]["format"] == "gcode" and sj["settings"]["controller"] != "gcode_planner":
                doc = json.loads(path.read_text())
                for n in doc["nodes"]:
                    if n["id"] == sim:
                        n["params"] = {k: v for k, v in n.get("params", {}).items() if k not in ROBOT_PARAMS}
                again = execute(build_graph(parse_recipe(doc)), resolver=FileResolver(path.parent), preflight=False)
                out.append(
                    _row(
                        f"program_time_{path.stem}_gcode_planner",
                        again,
                        sim,
                        post,
                        " on the G-code planner family (the recipe's robot params removed)",
                    )
                )
    return out
