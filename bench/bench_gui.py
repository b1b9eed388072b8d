"""GUI latency under a heavy recipe (#30 item 4): edit → canvas on the 300-layer bracket at layer 150.

Runs frontend/e2e/latency.bench.mjs (headless Chromium against a real `waamflow serve` over the
built frontend) and reads what it writes, out/bench/gui_latency.json.

- `gui_edit_to_canvas_ms_median`: median over ≥ 10 edits (half a section's end-zone length changed
  in the side panel, half a vertex of its mask curve nudged 1 mm with the arrow keys) of the time
  from the edit to the frame that shows the re-planned layer, ms. Every edit makes a state not
  seen before (the length grows at every edit, the vertex moves on right), so no cache or memo of an
  earlier state serves its preview. Goal ≤ 50 ms (reported, not
  asserted). peer = the server's own time for the same previews (the preview response's `ms`,
  median); ratio = GUI / server: what the GUI adds (request, JSON, React, SVG) is the rest. The
  notes split it: edit → preview request sent (the app's state update and render before its
  fetch), the request's wall time in the browser (sent → last byte), and after it the render up to
  the next frame (medians).

The frontend is built first (`npm run build`) unless frontend/dist is newer than every file under
frontend/src; WAAMFLOW_STATIC_DIR serves another build. Needs node and Chromium (CHROMIUM, else
/usr/bin/chromium), as the e2e tests do.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "frontend" / "e2e" / "latency.bench.mjs"
OUT = ROOT / "out" / "bench" / "gui_latency.json"
GOAL_MS = 50.0


def _dist_is_current() -> bool:
    index = ROOT / "frontend" / "dist" / "index.html"
    if not index.is_file():
        return False
    built = index.stat().st_mtime
    return all(p.stat().st_mtime <= built for p in (ROOT / "frontend" / "src").rglob("*") if p.is_file())


def _check_tools() -> str:
    node = shutil.which("node")
    if not node:
        raise RuntimeError("bench_gui: `node` is not on PATH (the GUI bench drives Chromium from node)")
    chromium = os.environ.get("CHROMIUM", "/usr/bin/chromium")
    if not Path(chromium).exists():
        raise RuntimeError(f"bench_gui: no Chromium at {chromium} (set CHROMIUM)")
    return node


def _ms(v: float | None) -> str:
    return "n/a" if v is None else f"{v:.1f} ms"


def run() -> list[dict]:
    node = _check_tools()
    env = dict(os.environ)
    if "WAAMFLOW_STATIC_DIR" not in env and not _dist_is_current():
        subprocess.run(["npm", "run", "build"], cwd=ROOT / "frontend", check=True, capture_output=True)
    OUT.unlink(missing_ok=True)
    proc = subprocess.run([node, str(SPEC)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    if proc.returncode != 0 or not OUT.is_file():
        raise RuntimeError(
            f"bench_gui: {SPEC.name} exited {proc.returncode}:\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
        )
    r = json.loads(OUT.read_text())
    server = r.get("server_ms_median")
    return [
        {
            "name": "gui_edit_to_canvas_ms_median",
            "value": round(r["median"], 1),
            "unit": "ms",
            "peer": round(server, 1) if server is not None else None,
            "ratio": round(r["median"] / server, 3) if server else None,
            "notes": f"graphs/{r['recipe']}.json, layer {r['layer']} (section {r['section']}, {r['path_points']} path points), "
            f"{len(r['samples'])} edits: end length median {r['param_median']:.0f} ms, mask vertex median "
            f"{r['vertex_median']:.0f} ms, max {r['max']:.0f} ms; peer = server preview ms; edit -> request sent "
            f"{_ms(r.get('edit_to_request_ms_median'))}, request wall (browser) {_ms(r.get('http_ms_median'))}, "
            f"the rest is the render to the next frame; goal <= {GOAL_MS:g} ms "
            f"({'met' if r['median'] <= GOAL_MS else 'not met'}); first view of the layer {r['first_layer_ms']} ms; "
            f"load {os.getloadavg()[0]:.1f}",
        }
    ]


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
