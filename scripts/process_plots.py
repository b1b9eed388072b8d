"""Regenerate the README's process plots (docs/process/*.png) from the recipes themselves.

    PYTHONPATH=backend .venv/bin/python scripts/process_plots.py [--out docs/process] [--svg-only]

Runs graphs/bead-trials.json (8 layers of the MPP cross: bead trials → fitted model → filled
parameters → coverage → interpass dwells → wire-feed compensation → G-code, and a rolling
program) and graphs/rectangle-study.json (rectangular and triangular patterns at 40 mm/s with
compensation on), writes the node plots as SVG and converts them to PNG with headless Chromium
(the browser the e2e tests use). Prints the numbers the README quotes. Exit 3 when Chromium is
missing (the SVGs are written anyway).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from shapely.geometry import Polygon

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe
from waamflow.process.bead_fit import fit_svg
from waamflow.process.interpass import interpass_svg
from waamflow.process.svgplot import layer_plan_svg
from waamflow.trajectory.compensate import deposit_svg

ROOT = Path(__file__).resolve().parents[1]
GRAPHS = ROOT / "graphs"


def run(recipe: str, **inputs):
    r = apply_overrides(load_recipe(GRAPHS / recipe), list(inputs.items()))
    return execute(build_graph(r), resolver=FileResolver(GRAPHS), workers=1)


def _poly(d: dict) -> Polygon:
    return Polygon(d["exterior"], d["holes"])


def worked_example(layers: int) -> tuple[dict[str, str], dict]:
    res = run("bead-trials.json", layers=layers)
    o = res.outputs
    svgs = {"fit": fit_svg(o["trials"]["model"]), "interpass": interpass_svg(o["interpass"]["report"])}
    # layer 0 from above: sections, the compensated path, coverage, rolling strokes
    sections = o["guide"]["sections"][0].sections
    paths = [(np.asarray(sp.points), np.asarray(sp.arc)) for sp in o["compensate"]["toolpath"][0].sections]
    cov = o["coverage"]["coverage"][0]["sections"]
    voids = [_poly(p) for r in cov for p in r["void"]]
    overlaps = [_poly(p) for r in cov for p in r["overlap"]]
    strokes = [np.asarray(sp.points)[:-1] for sp in o["rolling"]["toolpath"][0].sections]
    area = sum(r["region_area_mm2"] for r in cov)
    void = sum(r["void_area_mm2"] for r in cov)
    over = sum(r["overlap_area_mm2"] for r in cov)
    svgs["layer-plan"] = layer_plan_svg(
        [s.region for s in sections],
        paths,
        voids,
        overlaps,
        strokes,
        title="Layer 0: filled, compensated path; coverage; rolling strokes",
        note=f"void {void:.0f} mm² ({100 * void / area:.1f} %), overlap {over:.0f} mm² ({100 * over / area:.1f} %) "
        f"of {area:.0f} mm²; {len(strokes)} rolling strokes",
    )
    # deposit per mm along layer 0 (constant feed vs compensated)
    sim = o["compensate"]["simulation"]
    layer0 = float(sum(sp.segment_lengths[sp.arc].sum() for sp in o["compensate"]["toolpath"][0].sections))
    est = sim.estimate
    svgs["deposit"] = deposit_svg(
        sim.deposit,
        "Worked example, layer 0: deposit per mm, constant feed vs compensated "
        f"(ratio cv {est['deposit_ratio_cv_before']:.3f} → {est['deposit_ratio_cv_after']:.3f})",
        s_range=(0.0, layer0),
    )
    ip = o["interpass"]["report"]
    numbers = {
        "model": {k: o["trials"]["model"].fit[k] for k in ("width", "height")},
        "coverage_layer0": {"area_mm2": round(area, 1), "void_mm2": round(void, 1), "overlap_mm2": round(over, 1)},
        "fill": {k: o["fill"]["report"]["fill"][k] for k in ("zones", "filled_values", "kept_count")},
        "interpass": {k: ip[k] for k in ("total_dwell_s", "total_added_dwell_s", "max_peak_c")}
        | {"dwells_s": [r["dwell_s"] for r in ip["layers"]]},
        "compensation": {
            k: round(float(est[k]), 4)
            for k in (
                "deposit_per_mm_cv_before",
                "deposit_per_mm_cv_after",
                "deposit_ratio_cv_before",
                "deposit_ratio_cv_after",
            )
        },
        "rolling": {k: o["rolling"]["report"][k] for k in ("strokes", "rolled_length_mm", "time_s")},
        "program": {k: o["post"]["program"].stats[k] for k in ("dwell_total_s", "estimated_time_s", "arc_on_count")},
    }
    return svgs, numbers


def study() -> tuple[dict[str, str], dict]:
    svgs, numbers = {}, {}
    for pattern in ("rectangular", "triangular"):
        res = run("rectangle-study.json", pattern=pattern, speed=40, compensate="on")
        sim = json.loads(res.artifacts["simulate.simulation.json"])
        before, after = sim["deposit_per_mm_cv_before"], sim["deposit_per_mm_cv"]
        svgs[f"study-{pattern}"] = deposit_svg(
            res.outputs["simulate"]["simulation"].deposit,
            f"Robot study, {pattern} pattern at 40 mm/s: deposit per mm, cv {before:.3f} → {after:.3f}",
        )
        numbers[pattern] = {"cv_before": before, "cv_after": after}
    return svgs, numbers


def to_png(svg_path: Path, png_path: Path, browser: str) -> None:
    head = svg_path.read_text(encoding="utf-8")[:400]
    w = int(head.split('width="')[1].split('"')[0])
    h = int(head.split('height="')[1].split('"')[0])
    with tempfile.TemporaryDirectory(prefix="process-plots-") as prof:
        subprocess.run(
            [
                browser,
                "--headless=new",
                "--no-sandbox",
                "--disable-gpu",
                "--hide-scrollbars",
                "--force-device-scale-factor=2",
                f"--user-data-dir={prof}",
                f"--window-size={w},{h}",
                f"--screenshot={png_path}",
                svg_path.resolve().as_uri(),
            ],
            check=True,
            capture_output=True,
            timeout=120,
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "process"))
    ap.add_argument("--layers", type=int, default=8)
    ap.add_argument("--svg-only", action="store_true")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    svgs, numbers = worked_example(a.layers)
    s2, n2 = study()
    svgs.update(s2)
    numbers["study_40mm_s"] = n2
    for name, text in svgs.items():
        (out / f"{name}.svg").write_text(text, encoding="utf-8")
    print(json.dumps(numbers, indent=1))
    if a.svg_only:
        return 0
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if browser is None:
        print("no Chromium found: SVGs written, PNGs not", file=sys.stderr)
        return 3
    for name in svgs:
        to_png(out / f"{name}.svg", out / f"{name}.png", browser)
        (out / f"{name}.svg").unlink()
    print(f"{len(svgs)} PNGs → {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
