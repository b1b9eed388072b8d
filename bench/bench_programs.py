"""Simulated vs header time of every shipped program that is simulated as written (issue #23).

For each recipe in graphs/ whose simulate-robot node reads a post-process's program (its `program`
input is connected), the recipe is run once without the cache and two cycle times are set side by
side: `simulation.json`'s `total_time_s` (the controller model running the program as written:
its blending, dwells and controller family) and the program header's `estimated_time_s` (the
post-processor's own estimate: programmed feeds, dwells, travel at the stated travel speed).

- `program_time_<recipe>`: simulated seconds; peer = the header's; ratio = simulated / header.
  A ratio above 1 is time the header does not know about (acceleration, corners, blending).
"""

from __future__ import annotations

import json
from pathlib import Path

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import load_recipe

GRAPHS = Path(__file__).resolve().parents[1] / "graphs"


def simulated_programs(recipe_path: Path) -> list[tuple[str, str]]:
    """(simulate-robot id, post-process id) pairs where the simulation reads the program."""
    doc = json.loads(recipe_path.read_text())
    types = {n["id"]: n["type"] for n in doc["nodes"]}
    pairs = []
    for e in doc["edges"]:
        src, dst = e["from"].split(".")[0], e["to"]
        if dst.endswith(".program") and types.get(dst.split(".")[0]) == "simulate-robot" \
                and types.get(src) == "post-process":
            pairs.append((dst.split(".")[0], src))
    return pairs


def run() -> list[dict]:
    out = []
    for path in sorted(GRAPHS.glob("*.json")):
        pairs = simulated_programs(path)
        if not pairs:
            continue
        result = execute(build_graph(load_recipe(path)), resolver=FileResolver(path.parent), preflight=False)
        for sim, post in pairs:
            simulated = json.loads(result.artifacts[f"{sim}.simulation.json"])["total_time_s"]
            header = result.program_stats()[post]["estimated_time_s"]
            out.append({"name": f"program_time_{path.stem}", "value": round(simulated, 2), "unit": "s",
                        "peer": round(header, 2), "ratio": round(simulated / header, 4),
                        "notes": f"{post} ({result.program_stats()[post]['format']}) simulated by {sim} as "
                                 f"written vs the program header's estimate"})
    return out
