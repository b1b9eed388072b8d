"""Process-intelligence nodes (issue 16): coverage, bead-fit, fill-parameters, deposit
compensation, interpass control and treatment paths — thin adapters over waamflow.process."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
from pydantic import Field

from ..core import serialize
from ..core.model import LayerPaths, LayerSections
from dataclasses import replace as dc_replace

from ..core.moves import flatten
from ..engine.node import LayerNode, Node, NodeParams, register, unit
from ..engine.ports import Port
from ..process.coverage import section_coverage
from ..trajectory.compensate import CompensationSettings, compensate, deposit_cv, deposit_svg
from ..trajectory.run import simulate_program
from .robot import RobotParams, _profile


def layer_local(lp_layer, points: np.ndarray) -> np.ndarray:
    """World (n, 3) toolpath points → layer-local (n, 2) mm."""
    pts = np.asarray(points, dtype=float)
    if lp_layer.frame is None:
        return pts[:, :2]
    inv = np.linalg.inv(lp_layer.frame)
    homo = np.column_stack([pts, np.ones(len(pts))])
    return (homo @ inv.T)[:, :2]


def _geom_json(g) -> list[dict]:
    from ..core.model import region_polygons

    return [serialize.polygon_json(p) for p in region_polygons(g)]


@register
class CoverageNode(LayerNode):
    """Bead coverage of every section: the arc-ON path buffered by half the bead width (round
    ends) against the section region gives the void area (left bare), the over-deposit (metal
    outside the section) and the overlap area (the torch passes over it twice or more: counted
    exactly per connected stretch of path, on a grid of bead width / 20). Writes
    `<node>.coverage.json`: per layer and section the areas and shares, plus the void and overlap
    polygons (layer-local, for the 2D canvas), and totals."""

    type = "coverage"
    title = "Coverage"
    category = "process"
    inputs = (Port("toolpath", "toolpath", "Section paths (strategy, zone or sequence output)"),
              Port("sections", "sections", "The sections the paths fill"))
    outputs = (Port("coverage", "coverage", "Per layer: coverage of each section"),)
    over = "toolpath"
    version = "1"

    class Params(NodeParams):
        bead_width: float = Field(6.0, gt=0.05, le=100, json_schema_extra=unit("mm"),
                                  description="Bead width (MPP study: 6 mm); a bead-fit node's width at the "
                                              "chosen speeds is the measured value")
        sections: dict[str, float] = Field(default_factory=dict, description="Section key → bead width (mm) where it differs")
        polygons: bool = Field(True, description="Write the void and overlap polygons (for the 2D canvas)")

    def run_layer(self, ctx, params, index, items):
        lp: LayerPaths = items["toolpath"]
        ls: LayerSections | None = items.get("sections")
        regions = ls.by_key() if ls is not None else {}
        rows = []
        for sp in lp.sections:
            sec = regions.get(sp.key)
            if sec is None:
                ctx.warn(f"no section {sp.key!r} on this layer: coverage skipped", layer=index, section=sp.key)
                continue
            width = float(params.sections.get(sp.key, params.bead_width))
            cov = section_coverage(sec.region, layer_local(lp.layer, sp.points), sp.arc, width)
            row = {"key": sp.key, **cov.summary()}
            if params.polygons:
                row["void"] = _geom_json(cov.void)
                row["overlap"] = _geom_json(cov.overlap.simplify(cov.cell * 0.25))
            rows.append(row)
        return {"coverage": {"index": index, "z": float(lp.layer.z), "sections": rows}}

    def artifacts(self, ctx, params, outputs) -> dict[str, Any]:
        layers = [c for c in outputs["coverage"] if c is not None]
        total = {k: round(sum(r[k] for c in layers for r in c["sections"]), 3)
                 for k in ("region_area_mm2", "void_area_mm2", "overlap_area_mm2", "over_deposit_area_mm2")}
        area = total["region_area_mm2"]
        total["void_share"] = round(total["void_area_mm2"] / area, 5) if area else 0.0
        total["overlap_share"] = round(total["overlap_area_mm2"] / area, 5) if area else 0.0
        return {"coverage.json": serialize.dumps({"units": {"area": "mm²", "length": "mm"}, "total": total,
                                                  "layers": layers})}


@register
class CompensateDeposit(Node):
    """Uniform deposit by design: simulate the program with the robot's controller model, then
    modulate the wire feed per piece of at most `step_mm` of arc-ON path (pieces next to blended
    corners stay long enough not to change the corner) so the deposit per mm stays at its
    programmed value through stops, corners, reversals and the start and end of every bead. The
    feed goes into sub-zones `<zone>@<percent>` with their `wire_feed_speed` (m/min), which every
    post-processor emits as a process change. Writes `<node>.compensation.json` (cv of the deposit
    per mm before and after, feed ratio range, volumes) and `<node>.deposit.svg` (before/after).
    Feed a simulate-robot with `wire_diameter_mm` set to see the compensated deposit."""

    type = "compensate-deposit"
    title = "Compensate deposit"
    category = "process"
    inputs = (Port("toolpath", "toolpath", "Zoned, sequenced toolpath"),)
    outputs = (Port("toolpath", "toolpath", "The toolpath with feed sub-zones"),
               Port("simulation", "simulation", "Simulation of the compensated program"))
    version = "1"

    class Params(RobotParams):
        step_mm: float = Field(1.0, ge=0.2, le=50, json_schema_extra=unit("mm"), description="Longest compensated piece")
        min_ratio: float = Field(0.3, gt=0.0, le=1.0, description="Lowest feed, as a fraction of the programmed feed")
        max_ratio: float = Field(1.6, ge=1.0, le=5.0, description="Highest feed, as a fraction of the programmed feed")
        wire_diameter_mm: float | None = Field(1.2, gt=0.1, le=10, json_schema_extra=unit("mm"),
                                               description="Wire diameter: zones' wire_feed_speed (m/min) sets the feed "
                                                           "(else wire_feed_mm3_s), and the compensated feed is written as WFS")

    def run(self, ctx, params, inputs):
        cfg = CompensationSettings(step_mm=params.step_mm, min_ratio=params.min_ratio, max_ratio=params.max_ratio,
                                   wire_diameter_mm=params.wire_diameter_mm or 1.2)
        prof = _profile(ctx, params)
        opt = params.sim_options()
        plain = simulate_program(flatten(inputs["toolpath"]), prof, opt)
        comp = compensate(inputs["toolpath"], prof, opt, None, cfg)
        cv0 = deposit_cv(plain.trace)
        report = {**comp.report, "deposit_per_mm_cv_before": round(cv0, 5),
                  "cv_reduction": round(1 - comp.report["deposit_per_mm_cv_after"] / cv0, 4) if cv0 > 0 else 0.0}
        deposit = {**comp.after.deposit, "uncompensated_mm3_per_mm": comp.before.deposit["actual_mm3_per_mm"]}
        sim = dc_replace(comp.after, deposit=deposit, estimate={**comp.after.estimate, **{
            k: float(v) for k, v in report.items() if isinstance(v, (int, float))}})
        return {"toolpath": comp.toolpath, "simulation": sim}

    def artifacts(self, ctx, params, outputs):
        sim = outputs["simulation"]
        return {"compensation.json": json.dumps({k: (round(v, 6) if isinstance(v, float) else v)
                                                 for k, v in sim.estimate.items()}, indent=1),
                "deposit.svg": deposit_svg(sim.deposit),
                "toolpath.json": serialize.dumps(serialize.toolpath_json(outputs["toolpath"]))}
