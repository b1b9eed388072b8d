"""Process-intelligence nodes (issue 16): coverage, bead-fit, fill-parameters, deposit
compensation, interpass control and treatment paths — thin adapters over waamflow.process.

One module per node family (issue 27): coverage and deposit compensation here, bead-fit and
fill-parameters in `nodes.beadfit`, interpass and treatment in `nodes.heat`; every class stays
importable from this module."""

from __future__ import annotations

from dataclasses import replace as dc_replace
import json
from typing import Any

import numpy as np
from pydantic import Field

from ..core import serialize
from ..core.model import LayerPaths, LayerSections
from ..core.moves import flatten
from ..engine.node import LayerNode, Node, NodeParams, register, unit
from ..engine.ports import Port
from ..process.bead_fit import BeadFit
from ..process.coverage import section_coverage
from ..trajectory.compensate import (
    CompensationSettings,
    compensate,
    deposit_bin_series,
    deposit_cv,
    deposit_ratio_cv,
    deposit_svg,
)
from ..trajectory.run import simulate_program
from .beadfit import BeadFitNode as BeadFitNode
from .beadfit import FillParameters as FillParameters
from .heat import Interpass as Interpass
from .heat import Treatment as Treatment
from .robot import RobotParams, _profile


def layer_local(lp_layer, points: np.ndarray) -> np.ndarray:
    """World (n, 3) toolpath points → layer-local (n, 2) mm."""
    pts = np.asarray(points, dtype=float)
    if lp_layer.frame is None:
        return pts[:, :2]
    inv = np.linalg.inv(lp_layer.frame)
    homo = np.column_stack([pts, np.ones(len(pts))])
    return (homo @ inv.T)[:, :2]


def model_width(model: BeadFit, sp, default: float) -> float:
    """Arc-ON-length-weighted bead width (mm) of a section path from the model at each zone's
    wire feed (m/min) and travel speed (mm/s); `default` where a zone lacks either."""
    L = sp.segment_lengths
    num = den = 0.0
    for j, z in enumerate(sp.zone or ()):
        if not sp.arc[j]:
            continue
        p = sp.zone_params.get(z, {})
        w = (
            float(model.width(p["wire_feed_speed"], p["travel_speed"]))
            if p.get("wire_feed_speed") and p.get("travel_speed")
            else default
        )
        num += w * L[j]
        den += L[j]
    return num / den if den > 0 else default


def coverage_width(params, sp, model: BeadFit | None) -> float:
    """The bead width (mm) the coverage node uses for section path `sp`: its per-section width,
    else the connected bead model's at the zones' feeds and speeds, else `bead_width`. The live
    coverage overlay (/api/preview) calls this too, so the canvas and the node agree."""
    width = float(params.sections.get(sp.key, params.bead_width))
    if model is not None and sp.key not in params.sections:
        width = model_width(model, sp, width)
    return width


def _geom_json(g) -> list[dict]:
    from ..core.model import region_polygons

    return [serialize.polygon_json(p) for p in region_polygons(g)]


@register
class CoverageNode(LayerNode):
    """Bead coverage of every section: the arc-ON path buffered by half the bead width (round
    ends) against the section region gives the void area (left bare), the over-deposit (metal
    outside the section) and the overlap area (the torch passes over it twice or more: counted
    exactly per connected stretch of path, on a grid of bead width / 20). With a bead model
    connected, each section's width is the model's at its zones' wire feed and travel speed. Writes
    `<node>.coverage.json`: per layer and section the areas and shares, plus the void and overlap
    polygons (layer-local, for the 2D canvas), and totals."""

    type = "coverage"
    title = "Coverage"
    category = "process"
    inputs = (
        Port("toolpath", "toolpath", "Section paths (strategy, zone or sequence output)"),
        Port("sections", "sections", "The sections the paths fill"),
        Port(
            "model",
            "bead-model",
            "Optional bead model: each section's width from its zones' wire feed and travel speed",
            optional=True,
        ),
    )
    outputs = (Port("coverage", "coverage", "Per layer: coverage of each section"),)
    over = "toolpath"
    version = "3"  # 2: overlap outlines smoothed

    class Params(NodeParams):
        bead_width: float = Field(
            6.0,
            gt=0.05,
            le=100,
            json_schema_extra=unit("mm"),
            description="Bead width (MPP study: 6 mm); a bead-fit node's width at the "
            "chosen speeds is the measured value",
            title="Bead width",
        )
        sections: dict[str, float] = Field(
            default_factory=dict,
            description="Section key → bead width (mm) where it differs",
            title="Bead width by section",
        )
        polygons: bool = Field(
            True,
            description="Write the void and overlap polygons (for the 2D canvas)",
            title="Write void and overlap polygons",
        )

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
            width = coverage_width(params, sp, items.get("model"))
            cov = section_coverage(sec.region, layer_local(lp.layer, sp.points), sp.arc, width)
            row = {"key": sp.key, **cov.summary()}
            if params.polygons:
                row["void"] = _geom_json(cov.void)
                row["overlap"] = _geom_json(cov.overlap_outline())
            rows.append(row)
        return {"coverage": {"index": index, "z": float(lp.layer.z), "sections": rows}}

    def artifacts(self, ctx, params, outputs) -> dict[str, Any]:
        layers = [c for c in outputs["coverage"] if c is not None]
        total = {
            k: round(sum(r[k] for c in layers for r in c["sections"]), 3)
            for k in ("region_area_mm2", "void_area_mm2", "overlap_area_mm2", "over_deposit_area_mm2")
        }
        area = total["region_area_mm2"]
        total["void_share"] = round(total["void_area_mm2"] / area, 5) if area else 0.0
        total["overlap_share"] = round(total["overlap_area_mm2"] / area, 5) if area else 0.0
        return {
            "coverage.json": serialize.dumps(
                {"units": {"area": "mm²", "length": "mm"}, "total": total, "layers": layers}
            )
        }


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
    outputs = (
        Port("toolpath", "toolpath", "The toolpath with feed sub-zones"),
        Port("simulation", "simulation", "Simulation of the compensated program"),
    )
    version = "1"

    class Params(RobotParams):
        step_mm: float = Field(
            1.0,
            ge=0.2,
            le=50,
            json_schema_extra=unit("mm"),
            description="Longest compensated piece",
            title="Longest compensated piece",
        )
        min_ratio: float = Field(
            0.3,
            gt=0.0,
            le=1.0,
            description="Lowest feed, as a fraction of the programmed feed",
            title="Lowest feed ratio",
        )
        max_ratio: float = Field(
            1.6,
            ge=1.0,
            le=5.0,
            description="Highest feed, as a fraction of the programmed feed",
            title="Highest feed ratio",
        )
        wire_diameter_mm: float | None = Field(
            1.2,
            gt=0.1,
            le=10,
            json_schema_extra=unit("mm"),
            description="Wire diameter: zones' wire_feed_speed (m/min) sets the feed "
            "(else wire_feed_mm3_s), and the compensated feed is written as WFS",
            title="Wire diameter",
        )

    def run(self, ctx, params, inputs):
        cfg = CompensationSettings(
            step_mm=params.step_mm,
            min_ratio=params.min_ratio,
            max_ratio=params.max_ratio,
            wire_diameter_mm=params.wire_diameter_mm or 1.2,
        )
        prof = _profile(ctx, params)
        opt = params.sim_options()
        plain = simulate_program(flatten(inputs["toolpath"]), prof, opt)
        comp = compensate(inputs["toolpath"], prof, opt, None, cfg)
        cv0 = deposit_cv(plain.trace)
        report = {
            **comp.report,
            "deposit_per_mm_cv_before": round(cv0, 5),
            "deposit_ratio_cv_before": round(deposit_ratio_cv(plain), 5),
            "cv_reduction": round(1 - comp.report["deposit_per_mm_cv_after"] / cv0, 4) if cv0 > 0 else 0.0,
        }
        deposit = {
            **comp.after.deposit,
            "uncompensated_mm3_per_mm": comp.before.deposit["actual_mm3_per_mm"],
            "programmed_mm3_per_mm": comp.before.deposit["programmed_mm3_per_mm"],
            "bins": deposit_bin_series(plain, comp.after),
        }
        sim = dc_replace(
            comp.after,
            deposit=deposit,
            estimate={**comp.after.estimate, **{k: float(v) for k, v in report.items() if isinstance(v, (int, float))}},
        )
        return {"toolpath": comp.toolpath, "simulation": sim}

    def artifacts(self, ctx, params, outputs):
        sim = outputs["simulation"]
        return {
            "compensation.json": json.dumps(
                {k: (round(v, 6) if isinstance(v, float) else v) for k, v in sim.estimate.items()}, indent=1
            ),
            "deposit.svg": deposit_svg(sim.deposit),
            "toolpath.json": serialize.dumps(serialize.toolpath_json(outputs["toolpath"])),
        }
