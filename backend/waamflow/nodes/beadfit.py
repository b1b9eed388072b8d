"""Bead-model nodes: `bead-fit` (a bead model fitted to measured bead trials, or a saved one loaded)
and `fill-parameters` (the zone-parameter XML's empty values filled from that model and targets).

Split from `nodes.process` (issue 27: one module per node family); the classes stay importable
from there.
"""

from __future__ import annotations

import json
from typing import Literal

from pydantic import Field

from ..core.errors import InputFileError, PlanningError, RecipeError
from ..core.process import BEAD_SHAPE_FACTOR, DEPOSITION_EFFICIENCY
from ..engine.node import FileRef, Node, NodeParams, register, unit
from ..engine.ports import Port
from ..process.bead_fit import BeadFit, fit_svg, fit_trials, read_trials
from ..process.fill import FillRules, fill
from ..zoning.params_xml import parse as parse_params


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
