"""The real-size bracket (graphs/bracket.json, 300 layers) planned whole, STL → G-code.

- `bracket_plan_s`: cold plan (no cache) with the default workers, artifacts included, s;
  peer = the same plan serial (workers=1); ratio = parallel / serial. Notes: sections, program lines.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run() -> list[dict]:
    old_epoch = os.environ.get("SOURCE_DATE_EPOCH")
    os.environ["SOURCE_DATE_EPOCH"] = old_epoch or "1767225600"  # the same trace date in both programs
    try:
        return _run()
    finally:
        if old_epoch is None:
            os.environ.pop("SOURCE_DATE_EPOCH", None)


def _run() -> list[dict]:
    from waamflow.engine.cache import MemoryCache
    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import load_recipe

    path = ROOT / "graphs" / "bracket.json"
    graph = build_graph(load_recipe(path))
    resolver = FileResolver(path.parent)
    t0 = time.perf_counter()
    par = execute(graph, resolver=resolver, cache=MemoryCache())
    t_par = time.perf_counter() - t0
    t0 = time.perf_counter()
    ser = execute(graph, resolver=resolver, cache=MemoryCache(), workers=1)
    t_ser = time.perf_counter() - t0
    program = next(v for k, v in par.artifacts.items() if k.endswith(".gcode"))
    text = program.decode() if isinstance(program, bytes) else str(program)
    n_sections = sum(len(lp.sections) for lp in par.outputs["sequence"]["toolpath"])
    same = par.artifacts == ser.artifacts
    assert same, "bracket: parallel artifacts differ from the serial run"
    return [
        {
            "name": "bracket_plan_s",
            "value": round(t_par, 3),
            "unit": "s",
            "peer": round(t_ser, 3),
            "ratio": round(t_par / t_ser, 4),
            "notes": f"graphs/bracket.json whole: {par.layer_count} layers, {n_sections} sections, "
            f"{text.count(chr(10))} program lines; {par.executor['workers']} workers "
            f"({par.executor['tasks']} tasks) vs serial; artifacts {'identical' if same else 'DIFFER'}; "
            f"load {os.getloadavg()[0]:.1f}",
        }
    ]


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))
