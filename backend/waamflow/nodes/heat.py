"""Between-layer nodes: `interpass` (each layer's dwell from a lumped heat model) and `treatment`
(rolling or peening passes over each layer's deposited beads).

Split from `nodes.process` (issue 27: one module per node family); the classes stay importable
from there.
"""

from __future__ import annotations

import json
from typing import Literal

from pydantic import Field

from ..core import serialize
from ..core.errors import RecipeError
from ..engine.node import Node, NodeParams, register, unit
from ..engine.ports import Port
from ..process.interpass import (
    HeatModel,
    Spanning,
    climbing_note,
    interpass_svg,
    plan_dwells,
    spanning_sections,
    summary_report,
)
from ..process.treatment import TreatmentSpec, plan_treatment
from .beadfit import BeadFitNode as BeadFitNode
from .beadfit import FillParameters as FillParameters


@register
class Interpass(Node):
    """Interpass control: each layer's dwell from a lumped heat model (part + substrate at one
    temperature, heat η·U·I·t_arc per layer, cooling by convection + radiation over the side walls
    and top and by conduction into the table) so the part is under the interpass temperature when
    the next layer starts, and at least the minimum layer time. Existing dwells are never
    shortened. Writes `<node>.interpass.json` (per layer: arc time, mass, time constant, peak and
    next-start temperature, dwell, what limited it; totals) and `<node>.interpass.svg`; the output
    toolpath carries the dwells (the post-processor writes them as interlayer dwells). A section
    welded through several layers' heights in one go (a helix) cannot be cooled between its laps:
    warned with its layer, section and laps."""

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
        for span in spanning_sections(inputs["toolpath"]):
            peak = next((r["peak_c"] for r in report["layers"] if r["layer"] == span.layer), None)
            what = (
                f"no dwell can cool between its laps, its heat is layer {span.layer}'s"
                + (f" (peak {peak:.0f} °C in this model)" if peak is not None else "")
                + f", not held to {params.interpass_c:g} °C"
            )
            ctx.warn(climbing_note(span, what), layer=span.layer, section=span.section)
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
    after each layer's deposition (`interleave`). A section welded through several layers' heights
    in one go (a helix) gets no treatment (its lower laps lie under the next): warned, listed in
    the report's `skipped_climbing`. Writes `<node>.treatment.json` and
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
        for row in report["layers"]:
            for c in row["skipped_climbing"]:
                span = Spanning(row["layer"], c["section"], c["z_from"], c["z_to"], c["laps"])
                what = f"no {params.tool} for it, the tool would run along laps the next ones already cover"
                ctx.warn(climbing_note(span, what), layer=span.layer, section=span.section)
        ctx.report({k: v for k, v in report.items()})
        return {"toolpath": tp, "report": report}

    def artifacts(self, ctx, params, outputs):
        return {
            "treatment.json": json.dumps(outputs["report"], indent=1),
            "toolpath.json": serialize.dumps(serialize.toolpath_json(outputs["toolpath"])),
        }
