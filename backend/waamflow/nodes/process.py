"""Process-intelligence nodes (issue 16): coverage, bead-fit, fill-parameters, deposit
compensation, interpass control and treatment paths — thin adapters over waamflow.process."""

from __future__ import annotations

import json
from typing import Any, Literal

import numpy as np
from pydantic import Field

from ..core import serialize
from ..core.model import LayerPaths, LayerSections
from dataclasses import replace as dc_replace

from ..core.errors import InputFileError, PlanningError, RecipeError
from ..core.process import BEAD_SHAPE_FACTOR, DEPOSITION_EFFICIENCY
from ..core.moves import flatten
from ..engine.node import FileRef, LayerNode, Node, NodeParams, register, unit
from ..process.bead_fit import BeadFit, fit_svg, fit_trials, read_trials
from ..process.fill import FillRules, fill
from ..process.interpass import HeatModel, interpass_svg, plan_dwells, summary_report
from ..process.treatment import TreatmentSpec, plan_treatment
from ..zoning.params_xml import parse as parse_params
from ..engine.ports import Port
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


@register
class BeadFitNode(Node):
    """Fit a bead model to the user's bead trials: a CSV of measured beads (columns wfs [m/min],
    ts [mm/s], width [mm], height [mm]) → width and height as power laws of wire feed and travel
    speed (y = a·WFS^b·TS^c, or a·(WFS/TS)^b), least squares with scipy (curve_fit), residuals per
    trial and the validity range. Or load a saved model (`model`). Writes `<node>.bead-model.json`
    (the model file, reusable as `model`), `<node>.fit.svg` (measured vs model) and, for the
    `height`/`width` targets, the travel speed, wire feed, layer height and step-over
    (0.738·width, tangent overlap model) in `<node>.targets.json`. The output model carries the
    targets (a loaded model's are replaced by this node's `height`/`width`): a `slice` connected to
    it takes its layer height, a `strategy` its bead width and step-over.
    Mass balance: the model states the wire diameter, the deposition efficiency η and the bead
    shape factor k (area = k·w·h; fitted from an `area` column of the trials, else `shape_factor`)
    and, per trial, the metal fed η·WFS·(π d²/4)/TS over k·w·h (`fit.mass_balance`); trials whose
    mean is off by more than 20 % are warned about (a unit or measurement error)."""

    type = "bead-fit"
    title = "Bead fit"
    category = "process"
    outputs = (Port("model", "bead-model", "Bead width and height as functions of WFS and TS"),)
    version = "3"  # 2: the model carries the targets; 3: wire diameter, efficiency, shape factor, mass balance

    class Params(NodeParams):
        trials: FileRef = Field(
            "", description="Bead trials CSV (wfs, ts, width, height); empty = use `model`", title="Bead trials"
        )
        model: FileRef = Field(
            "",
            description="A saved bead-model JSON (waamflow/bead-model/1) instead of trials",
            title="Saved bead model",
        )
        form: Literal["power", "power-ratio"] = Field(
            "power", description="y = a·WFS^b·TS^c or y = a·(WFS/TS)^b", title="Model form"
        )
        material: str = Field(
            "",
            max_length=80,
            description="Material (recorded in the model file)",
            title="Material",
            examples=[
                "ER70S-6 (G3Si1) steel",
                "ER316LSi stainless",
                "Ti-6Al-4V",
                "ER4043 (AlSi5)",
                "ER5356 (AlMg5)",
                "ERCuAl-A2 bronze",
                "Inconel 625",
            ],
        )
        process: str = Field(
            "", max_length=80, description="Process, e.g. CMT, GMAW, plasma (recorded)", title="Welding process"
        )
        wire_diameter_mm: float | None = Field(
            None,
            gt=0.1,
            le=10,
            json_schema_extra=unit("mm"),
            description="Wire diameter for the mass balance (empty = 1.2 mm)",
            title="Wire diameter",
        )
        deposition_efficiency: float = Field(
            DEPOSITION_EFFICIENCY,
            gt=0.5,
            le=1.0,
            description="Share η of the wire that ends in the part (GMAW/CMT ≈ 0.95)",
            title="Deposition efficiency η",
        )
        shape_factor: float = Field(
            BEAD_SHAPE_FACTOR,
            gt=0.5,
            le=1.0,
            description="Bead shape factor k, area = k·width·height, when the trials have "
            "no measured `area` column (parabolic 0.667, elliptic 0.785)",
            title="Bead shape factor k",
        )
        height: float = Field(
            1.5,
            gt=0.05,
            le=20,
            json_schema_extra=unit("mm"),
            description="Target bead height",
            title="Target bead height",
        )
        width: float = Field(
            6.0, gt=0.1, le=60, json_schema_extra=unit("mm"), description="Target bead width", title="Target bead width"
        )

    def run(self, ctx, params, inputs):
        if params.trials:
            trials = read_trials(ctx.read_text(params.trials, max_bytes=20_000_000), source=params.trials)
            model = fit_trials(
                trials,
                params.form,
                params.material,
                params.process,
                params.wire_diameter_mm,
                params.deposition_efficiency,
                params.shape_factor,
            )
            mb = model.fit["mass_balance"]
            if not 0.8 <= mb["mean"] <= 1.25:
                ctx.warn(
                    f"{params.trials}: the trials are not mass-balanced: the wire fed per mm "
                    f"(η {model.deposition_efficiency:g} · WFS · π d²/4 / TS, d {model.wire_d:g} mm) is "
                    f"{mb['min']:.2f}–{mb['max']:.2f} × the bead area k·w·h (k {model.shape_factor:.3g}); "
                    "check the units (WFS m/min, TS mm/s, mm) and the wire diameter"
                )
        elif params.model:
            try:
                data = json.loads(ctx.read_text(params.model, max_bytes=5_000_000))
            except json.JSONDecodeError as e:
                raise InputFileError(f"{params.model}: not JSON ({e})") from None
            model = BeadFit.from_json(data, source=params.model)
        else:
            raise RecipeError("bead-fit needs `trials` (CSV) or `model` (JSON)", node=ctx.node_id)
        return {"model": model.with_targets(params.height, params.width)}

    def artifacts(self, ctx, params, outputs):
        m: BeadFit = outputs["model"]
        files = {"bead-model.json": json.dumps(m.to_json(), indent=1), "fit.svg": fit_svg(m)}
        try:
            wfs, ts = m.speeds_for(params.height, params.width)
            files["targets.json"] = json.dumps(
                {
                    "height_mm": params.height,
                    "width_mm": params.width,
                    "wire_feed_speed_m_min": round(wfs, 4),
                    "travel_speed_mm_s": round(ts, 4),
                    "layer_height_mm": params.height,
                    "step_over_mm": round(m.step_over(params.width), 4),
                    "in_model_range": m.in_range(wfs, ts),
                    "bead_area_mm2": round(m.shape_factor * params.width * params.height, 4),
                    "wire_per_mm_mm3": round(m.wire_per_mm(wfs, ts), 4),
                    "feed_ratio": round(m.wire_per_mm(wfs, ts) / (m.shape_factor * params.width * params.height), 4),
                },
                indent=1,
            )
        except ValueError as e:
            ctx.warn(f"targets: {e}")
        return files


@register
class FillParameters(Node):
    """Fill the zone-parameter XML from a bead model and targets: every empty value of every
    layer > section > zone gets one (wire feed and travel speed for the target bead height — the
    layer height unless given — and width — the model's target width unless given; current and
    voltage from a synergic line; dwell), values the user gave (the zone node's XML, or
    `parameters`) are kept and reported beside the model's.
    The ignition zone `start` and termination zone `end` get their own ramp rules (slower travel,
    less wire; ignition dwell). Mass balance by design: every zone's wire feed makes the metal that
    ends in the part, η·WFS·(π d²/4)/TS, equal to what its layer needs per mm of path — layer
    height × the passes' step (measured on each section path, or `step`) for overlapping passes,
    k·w·h for a single bead. Writes `<node>.params.xml` (filled; each zone states its feed ratio)
    and `<node>.fill.json` (counts, kept user values, zones outside the model's trial range, ramp
    lengths, mass balance per section and zone); the output toolpath carries the filled values
    (speeds set per zone). Zones whose (user-given) values feed more than 2 % off are warned about."""

    type = "fill-parameters"
    title = "Fill parameters"
    category = "process"
    inputs = (Port("toolpath", "toolpath", "Zoned toolpath"), Port("model", "bead-model", "Bead model"))
    outputs = (
        Port("toolpath", "toolpath", "Toolpath with every zone's parameters"),
        Port("report", "report", "The filled XML text and the fill report"),
    )
    version = "2"  # 2: mass-balanced wire feed, balanced ramp defaults, CMT synergic line

    class Params(NodeParams):
        parameters: FileRef = Field(
            "",
            description="Optional XML with user values (kept); the toolpath's own zone parameters are kept as well",
            title="User parameter XML",
        )
        height: float | None = Field(
            None,
            gt=0.05,
            le=20,
            json_schema_extra=unit("mm"),
            description="Target bead height (empty = each layer's height)",
            title="Target bead height",
        )
        width: float | None = Field(
            None,
            gt=0.1,
            le=60,
            json_schema_extra=unit("mm"),
            description="Target bead width (empty = the bead model's target width, else 6)",
            title="Target bead width",
        )
        travel_speed: float | None = Field(
            None,
            gt=0.1,
            le=500,
            json_schema_extra=unit("mm/s"),
            description="Fixed travel speed of body zones (else the bead model's for "
            "the target height and width); WFS from the mass balance",
            title="Body zone travel speed",
        )
        step: float | None = Field(
            None,
            gt=0.1,
            le=60,
            json_schema_extra=unit("mm"),
            description="Centre distance of neighbouring passes: the layer takes step × height "
            "per mm of path (empty = measured on each section path; a single "
            "bead takes k·width·height)",
            title="Pass step",
        )
        start_ts_factor: float = Field(
            0.75,
            gt=0.05,
            le=3,
            description="Ignition zone: travel speed × this",
            title="Start zone travel speed factor",
        )
        start_wfs_factor: float = Field(
            0.75,
            gt=0.05,
            le=3,
            description="Ignition zone: wire feed × this (equal to the travel factor = mass-balanced)",
            title="Start zone wire feed factor",
        )
        start_dwell_s: float = Field(
            0.5, ge=0, le=60, json_schema_extra=unit("s"), description="Ignition zone dwell", title="Start zone dwell"
        )
        end_ts_factor: float = Field(
            0.5,
            gt=0.05,
            le=3,
            description="Termination zone: travel speed × this",
            title="End zone travel speed factor",
        )
        end_wfs_factor: float = Field(
            0.5,
            gt=0.05,
            le=3,
            description="Termination zone: wire feed × this (above the travel factor = extra metal for the crater)",
            title="End zone wire feed factor",
        )
        current_line: tuple[float, float] = Field(
            (55.0, 15.0),
            description="Synergic current: A at 0 and A per m/min (CMT steel 1.2 mm: 100 A at 3 m/min)",
            title="Synergic current line",
        )
        voltage_line: tuple[float, float] = Field(
            (11.0, 0.6), description="Synergic voltage: V at 0 and V per m/min", title="Synergic voltage line"
        )
        job: float | None = Field(
            None, ge=0, le=9999, description="Power-source job number for every zone", title="Job number"
        )

    def run(self, ctx, params, inputs):
        user = {}
        if params.parameters:
            user = dict(parse_params(ctx.read_bytes(params.parameters, max_bytes=32 * 1024 * 1024)).values)
        width = params.width if params.width is not None else (inputs["model"].target_width_mm or 6.0)
        rules = FillRules(
            height_mm=params.height,
            width_mm=width,
            travel_speed=params.travel_speed,
            start_ts_factor=params.start_ts_factor,
            start_wfs_factor=params.start_wfs_factor,
            start_dwell_s=params.start_dwell_s,
            end_ts_factor=params.end_ts_factor,
            end_wfs_factor=params.end_wfs_factor,
            current_line=tuple(params.current_line),
            voltage_line=tuple(params.voltage_line),
            job=params.job,
            step_mm=params.step,
        )
        try:
            tp, xml, report = fill(inputs["toolpath"], inputs["model"], rules, user)
        except ValueError as e:
            raise PlanningError(f"fill-parameters: {e}") from None
        for lp in tp:
            if lp is not None and any(not sp.zone for sp in lp.sections):
                ctx.warn("a section has no zones (connect a zone node first): nothing filled there", layer=lp.index)
                break
        if report["out_of_model_range_count"]:
            r = report["out_of_model_range"][0]
            ctx.warn(
                f"{report['out_of_model_range_count']} zone(s) need speeds outside the bead trials' range "
                f"(e.g. WFS {r['wire_feed_speed']} m/min, TS {r['travel_speed']} mm/s)",
                layer=r["layer"],
                section=r["section"],
            )
        mb = report["mass_balance"]
        if mb["unbalanced_count"]:
            r = mb["unbalanced_zones"][0]
            ctx.warn(
                f"{mb['unbalanced_count']} zone(s) feed more than 2 % off the metal their layer needs "
                f"(e.g. zone {r['zone']!r}: wire/need {r['feed_ratio']:.2f}); given values are kept",
                layer=r["layer"],
                section=r["section"],
            )
        return {"toolpath": tp, "report": {"xml": xml, "fill": report}}

    def artifacts(self, ctx, params, outputs):
        rep = outputs["report"]
        return {"params.xml": rep["xml"], "fill.json": json.dumps(rep["fill"], indent=1)}


@register
class Interpass(Node):
    """Interpass control: each layer's dwell from a lumped heat model (part + substrate at one
    temperature, heat η·U·I·t_arc per layer, cooling by convection + radiation over the side walls
    and top and by conduction into the table) so the part is under the interpass temperature when
    the next layer starts, and at least the minimum layer time. Existing dwells are never
    shortened. Writes `<node>.interpass.json` (per layer: arc time, mass, time constant, peak and
    next-start temperature, dwell, what limited it; totals) and `<node>.interpass.svg`; the output
    toolpath carries the dwells (the post-processor writes them as interlayer dwells)."""

    type = "interpass"
    title = "Interpass control"
    category = "process"
    inputs = (Port("toolpath", "toolpath", "Sequenced toolpath"),)
    outputs = (
        Port("toolpath", "toolpath", "Toolpath with interlayer dwells"),
        Port("report", "report", "Per-layer temperatures and dwells"),
    )
    version = "1"

    class Params(NodeParams):
        interpass_c: float = Field(
            200.0,
            gt=-50,
            le=1500,
            json_schema_extra=unit("°C"),
            description="Highest part temperature when a layer starts",
            title="Interpass temperature",
        )
        min_layer_time_s: float = Field(
            0.0,
            ge=0,
            le=36000,
            json_schema_extra=unit("s"),
            description="Minimum layer time (arc + travel + dwell)",
            title="Minimum layer time",
        )
        ambient_c: float = Field(
            20.0,
            ge=-50,
            le=100,
            json_schema_extra=unit("°C"),
            description="Ambient temperature",
            title="Ambient temperature",
        )
        density_kg_m3: float = Field(
            7850.0, gt=100, le=25000, json_schema_extra=unit("kg/m³"), description="Density", title="Density"
        )
        specific_heat_j_kgk: float = Field(
            600.0,
            gt=50,
            le=5000,
            json_schema_extra=unit("J/(kg·K)"),
            description="Specific heat (steel ≈ 600, Ti-6Al-4V ≈ 650, Al ≈ 950)",
            title="Specific heat",
        )
        arc_efficiency: float = Field(
            0.8, gt=0, le=1, description="Arc efficiency η (GMAW/CMT ≈ 0.8)", title="Arc efficiency η"
        )
        arc_power_w: float = Field(
            4000.0,
            gt=0,
            le=100000,
            json_schema_extra=unit("W"),
            description="Arc power where a zone has no current and voltage",
            title="Default arc power",
        )
        h_w_m2k: float = Field(
            35.0,
            gt=0,
            le=1000,
            json_schema_extra=unit("W/(m²·K)"),
            description="Surface heat transfer: convection + linearised radiation",
            title="Surface heat transfer",
        )
        base_conductance_w_k: float = Field(
            2.0,
            ge=0,
            le=10000,
            json_schema_extra=unit("W/K"),
            description="Conduction into the table/fixture",
            title="Base conductance",
        )
        substrate_mass_kg: float = Field(
            1.0,
            ge=0,
            le=10000,
            json_schema_extra=unit("kg"),
            description="Substrate mass heated with the part",
            title="Substrate mass",
        )
        bead_width: float = Field(
            6.0,
            gt=0.1,
            le=60,
            json_schema_extra=unit("mm"),
            description="Bead width (deposited mass)",
            title="Bead width",
        )
        travel_speed: float = Field(
            100.0,
            gt=1,
            le=2000,
            json_schema_extra=unit("mm/s"),
            description="Speed of arc-OFF moves without a programmed speed",
            title="Travel speed",
        )

    def run(self, ctx, params, inputs):
        m = HeatModel(
            interpass_c=params.interpass_c,
            ambient_c=params.ambient_c,
            min_layer_time_s=params.min_layer_time_s,
            density_kg_m3=params.density_kg_m3,
            specific_heat_j_kgk=params.specific_heat_j_kgk,
            arc_efficiency=params.arc_efficiency,
            arc_power_w=params.arc_power_w,
            h_w_m2k=params.h_w_m2k,
            base_conductance_w_k=params.base_conductance_w_k,
            substrate_mass_kg=params.substrate_mass_kg,
            bead_width_mm=params.bead_width,
            travel_speed=params.travel_speed,
        )
        try:
            tp, report = plan_dwells(inputs["toolpath"], m)
        except ValueError as e:
            raise RecipeError(str(e), node=ctx.node_id) from None
        ctx.progress(1.0, f"interpass dwell {report['total_added_dwell_s']:.1f} s added")
        ctx.report(summary_report(report))
        return {"toolpath": tp, "report": report}

    def artifacts(self, ctx, params, outputs):
        rep = outputs["report"]
        return {"interpass.json": json.dumps(rep, indent=1), "interpass.svg": interpass_svg(rep)}


@register
class Treatment(Node):
    """Interpass treatment paths: a rolling (or peening) pass over each layer's deposited beads —
    the tool follows the bead centre line at the bead top, cut into strokes where the heading
    turns more than `max_turn_deg` (a loaded wheel cannot pivot), each with approach and retract
    `clearance` above it, at the rolling `speed`; tool width and force are carried in the report.
    Emitted as its own toolpath (connect a post-process for the treatment program) or interleaved
    after each layer's deposition (`interleave`). Writes `<node>.treatment.json` and
    `<node>.toolpath.json`."""

    type = "treatment"
    title = "Rolling / peening"
    category = "process"
    inputs = (Port("toolpath", "toolpath", "Deposition toolpath"),)
    outputs = (
        Port("toolpath", "toolpath", "Treatment passes (alone or after each layer)"),
        Port("report", "report", "Strokes, lengths and times per layer"),
    )
    version = "1"

    class Params(NodeParams):
        tool: Literal["rolling", "peening"] = Field("rolling", description="Treatment tool", title="Treatment tool")
        tool_width: float = Field(
            8.0, gt=0.5, le=100, json_schema_extra=unit("mm"), description="Roller/peen width", title="Tool width"
        )
        force: float = Field(
            25000.0, ge=0, le=500000, json_schema_extra=unit("N"), description="Rolling load", title="Rolling force"
        )
        speed: float = Field(
            10.0,
            gt=0.1,
            le=1000,
            json_schema_extra=unit("mm/s"),
            description="Speed along the bead",
            title="Treatment speed",
        )
        clearance: float = Field(
            10.0, ge=0, le=500, json_schema_extra=unit("mm"), description="Approach/retract height", title="Clearance"
        )
        max_turn_deg: float = Field(
            30.0,
            gt=0,
            le=180,
            json_schema_extra=unit("deg"),
            description="A sharper turn ends the stroke",
            title="Sharpest turn in a stroke",
        )
        tolerance: float = Field(
            0.05,
            gt=0,
            le=1,
            json_schema_extra=unit("mm"),
            description="Centre-line simplification",
            title="Centre-line tolerance",
        )
        min_stroke: float = Field(
            2.0,
            ge=0,
            le=1000,
            json_schema_extra=unit("mm"),
            description="Shorter strokes are skipped",
            title="Shortest stroke",
        )
        interleave: bool = Field(
            False,
            description="Deposition then treatment, layer by layer, in one toolpath",
            title="Interleave with deposition",
        )

    def run(self, ctx, params, inputs):
        spec = TreatmentSpec(
            tool=params.tool,
            tool_width_mm=params.tool_width,
            force_n=params.force,
            speed=params.speed,
            clearance_mm=params.clearance,
            max_turn_deg=params.max_turn_deg,
            tolerance_mm=params.tolerance,
            min_stroke_mm=params.min_stroke,
        )
        tp, report = plan_treatment(inputs["toolpath"], spec, params.interleave)
        ctx.report({k: v for k, v in report.items()})
        return {"toolpath": tp, "report": report}

    def artifacts(self, ctx, params, outputs):
        return {
            "treatment.json": json.dumps(outputs["report"], indent=1),
            "toolpath.json": serialize.dumps(serialize.toolpath_json(outputs["toolpath"])),
        }
