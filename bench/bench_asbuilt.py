"""The as-built loop (issue #29), in the process simulator (`waamflow build-sim`), and the time from a
scan arriving to the next layer's program.

- `asbuilt_<recipe>_{open,closed}_rms`: last-layer top-height error RMS (mm) with the default
  disturbance (`waamflow.asbuilt.sim.Disturbance`: stated, not fitted); `_max` the largest |error|.
  The closed loop's peer is the open loop's figure (ratio = closed / open). Goals: closed
  ≤ 0.3 mm RMS and ≤ 0.8 mm max, open several times worse, every planned layer built.
  mpp-cross is built with 20 layers (0.6 mm: the shipped part is 12 mm tall), curved-duct as shipped.
- `asbuilt_next_layer_ms_<recipe>`: median over the first layers of add_scan (measure the scan)
  + next_program (adapt, write the layer's program with the recipe's post-process), ms. Goals:
  ≤ 200 ms for a cross layer, ≤ 1 s for a bracket layer.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from waamflow.asbuilt import BuildSession, Disturbance, synth_scan
from waamflow.asbuilt.run import build_sim, plan_for_build
from waamflow.engine.executor import FileResolver
from waamflow.engine.recipe import load_recipe

GRAPHS = Path(__file__).resolve().parents[1] / "graphs"


def _loops(name: str, overrides: list) -> list[dict]:
    doc = build_sim(GRAPHS / f"{name}.json", overrides)
    o, c = doc["builds"]["open"], doc["builds"]["closed"]
    note = (
        f"{doc['layers_planned']} layers planned; built open {o['layers_built']}, closed {c['layers_built']} "
        f"({c['layers_added']} added, {c['layers_dropped']} dropped)"
    )
    out = []
    for what in ("rms", "max"):
        ov, cv = o[f"last_layer_{what}_mm"], c[f"last_layer_{what}_mm"]
        out.append({"name": f"asbuilt_{name}_open_{what}", "value": ov, "unit": "mm", "notes": note})
        out.append(
            {
                "name": f"asbuilt_{name}_closed_{what}",
                "value": cv,
                "unit": "mm",
                "peer": ov,
                "ratio": round(cv / ov, 4) if ov else None,
                "notes": note,
            }
        )
    return out


def _latency(name: str, layers: int = 6) -> dict:
    recipe = load_recipe(GRAPHS / f"{name}.json")
    toolpath, post, _ = plan_for_build(recipe, FileResolver(GRAPHS))
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        s = BuildSession.create(Path(tmp) / "b", toolpath, {"recipe": name, "layers": len(toolpath.items)}, post=post)
        s.next_program()
        times = []
        for _ in range(min(layers, len(s.tracks) - 1)):
            tr = s.tracks[s.next_layer]
            scan = synth_scan(tr, tr.planned_height() - 0.1, Disturbance(), rng)
            t0 = time.perf_counter()
            s.add_scan(scan)
            s.next_program()
            times.append((time.perf_counter() - t0) * 1000)
    n = int(np.mean([t.n for t in s.tracks]))
    return {
        "name": f"asbuilt_next_layer_ms_{name}",
        "value": round(statistics.median(times), 1),
        "unit": "ms",
        "notes": f"median of {len(times)} layers, ~{n} path samples per layer (measure + adapt + post)",
    }


def run() -> list[dict]:
    out = _loops("mpp-cross", [("layers.layer_height", 0.6), ("layers.layer_count", 20)])
    out += _loops("curved-duct", [])
    out.append(_latency("mpp-cross"))
    out.append(_latency("bracket"))
    return out


if __name__ == "__main__":
    for e in run():
        print(e)
