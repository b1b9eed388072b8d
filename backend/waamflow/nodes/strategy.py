"""The `strategy` node: fill every section of every layer with its pattern (waamflow.paths).

Params follow the contract: a `default` spec plus per-section overrides keyed "<mask>/<section>".
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Literal, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, create_model, field_validator, model_validator

from ..core import serialize
from ..core.errors import PlanningError, layer_ranges
from ..core.model import LayerPaths, LayerSections, SectionPath
from ..engine.node import LayerNode, NodeParams, register, unit
from ..engine.ports import Port
from ..paths import StrategySpec
from ..paths.compare import Job, compare, comparison_json, comparison_svg, parse_variant, path_metrics
from ..paths.whole import HOLE_MAX_WIDTHS, OUTSIDE_TOL, outside_length, plan_whole

# A section smaller than this share of its bead's square (w²) is slicing noise (a sliver of a
# near-degenerate face, above the slicer's absolute 0.001 mm² floor once a part is scaled up): it is
# left out with a warning. A 2 x 2 mm pin under a 5 mm bead (0.16 w²) is a feature and is welded.
NOISE_WIDTHS2 = 0.01
LEFT_OUT = "left out"  # a noise section's `fills` entry (cover report), warned once for the part


class SectionStrategy(StrategySpec):
    """A section's fill spec plus its programmed travel speed."""

    speed: float = Field(
        10.0,
        gt=0.0,
        le=500.0,
        description="Programmed travel speed (zones may override)",
        json_schema_extra=unit("mm/s"),
        title="Travel speed",
    )


def _partial(model: type[BaseModel]) -> type[BaseModel]:
    """The same fields, all optional (None = take the default's): per-section overrides."""
    fields: dict[str, Any] = {}  # name → (annotation, FieldInfo): create_model's field definitions
    for name, f in model.model_fields.items():
        extra = f.json_schema_extra if isinstance(f.json_schema_extra, dict) else None
        fields[name] = (
            Optional[f.annotation],
            Field(None, title=f.title, description=f.description, json_schema_extra=extra),
        )
    return create_model("SectionStrategyOverride", __config__=ConfigDict(extra="forbid"), **fields)


SectionOverride = _partial(SectionStrategy)


def spec_for(default: SectionStrategy, override) -> SectionStrategy:
    if override is None:
        return default
    return SectionStrategy.model_validate({**default.model_dump(), **override.model_dump(exclude_none=True)})


def paths_summary(toolpath) -> dict:
    """Per section and in total: programmed length, arc-ON length, arc switches, length outside the
    section and its share, time at programmed speed (`paths.json`)."""
    rows = []
    for lp in toolpath:
        if lp is None:
            continue
        for sp in lp.sections:
            rows.append(
                {
                    "layer": lp.index,
                    "key": sp.key,
                    "pattern": sp.strategy,
                    **path_metrics(sp.segment_lengths, sp.arc, sp.inside, sp.speed),
                }
            )
    total = {
        k: round(sum(r[k] for r in rows), 3)
        for k in ("programmed_length_mm", "arc_on_length_mm", "arc_switches", "outside_length_mm", "time_s")
    }
    total["outside_share"] = (
        round(total["outside_length_mm"] / total["programmed_length_mm"], 4)
        if total["programmed_length_mm"] > 0
        else 0.0
    )
    return {"units": "mm", "total": total, "sections": rows}


@dataclass(frozen=True, eq=False)
class PlannedLayerPaths(LayerPaths):
    """A layer's section paths as the strategy planned them, with per section (in order) how its
    path was chosen and what it leaves uncovered: {"section", "how", "pattern", "pieces",
    "uncovered_mm2", "area_mm2"} (`combine` reports them; nodes downstream see a LayerPaths)."""

    fills: tuple[dict, ...] = ()


def _warn_noise(ctx, toolpath) -> None:
    """One warning for the sections left out as slicing noise (`NOISE_WIDTHS2`), on every layer:
    how many, on which layers, their areas, and the first (PrusaSlicer's ht90 actuator read in cm
    had 97 such slivers, one warning each)."""
    found = [
        (lp.index, f) for lp in toolpath if lp is not None for f in getattr(lp, "fills", ()) if f["how"] == LEFT_OUT
    ]
    if not found:
        return
    layers = sorted({i for i, _f in found})
    areas = [f["area_mm2"] for _i, f in found]
    first_layer, first = found[0]
    n = len(found)
    ctx.warn(
        f"{n} section{'s' if n != 1 else ''} on {len(layers)} layer{'s' if len(layers) != 1 else ''} "
        f"({layer_ranges(layers)}) {'are' if n != 1 else 'is'} slicing noise, {min(areas):.2g}"
        f"{f'-{max(areas):.2g}' if n > 1 else ''} mm² (under {NOISE_WIDTHS2:g} of their bead's square): "
        f"left out (first: layer {first_layer}, section {first['section']}); slivers of the mesh, the "
        "preflight judges what the layers lack",
        layer=first_layer,
        section=first["section"],
    )


def cover_report(toolpath) -> dict:
    """What the strategy chose per section and what its paths leave uncovered (node report):
    counts of sections planned as given / split at corners / filled with contour, the uncovered
    area in total and its largest share of one section, and one row per (section, choice) with
    the layers it applies to."""
    rows: dict[tuple, dict] = {}
    counts = {"as planned": 0, "split": 0, "contour": 0}
    total, worst = 0.0, 0.0
    for lp in toolpath:
        for f in getattr(lp, "fills", ()) if lp is not None else ():
            counts[f["how"]] = counts.get(f["how"], 0) + 1
            total += f["uncovered_mm2"]
            share = f["uncovered_mm2"] / f["area_mm2"] if f["area_mm2"] > 0 else 0.0
            worst = max(worst, share)
            if f["how"] == "as planned":
                continue
            row = rows.setdefault(
                (f["section"], f["how"], f["pattern"], f["pieces"]),
                {
                    "section": f["section"],
                    "how": f["how"],
                    "pattern": f["pattern"],
                    "pieces": f["pieces"],
                    "layers": [],
                    "max_uncovered_share": 0.0,
                },
            )
            row["layers"].append(lp.index)
            row["max_uncovered_share"] = round(max(row["max_uncovered_share"], share), 5)
    changed = [{**r, "layers": layer_ranges(r["layers"])} for r in rows.values()][:200]
    return {
        "cover": {
            "sections_as_planned": counts["as planned"],
            "sections_split": counts["split"],
            "sections_contour": counts["contour"],
            "sections_left_out": counts.get(LEFT_OUT, 0),  # slicing noise (NOISE_WIDTHS2)
            "uncovered_mm2": round(total, 3),
            "max_uncovered_share": round(worst, 5),
            "changed": changed,
        }
    }


_COMPARISONS: dict[str, dict] = {}


def _compare_sections(sections, params) -> dict:
    jobs, layers = [], 0
    for ls in sections:
        if ls is None:
            continue
        layers += 1
        for s in ls.sections:
            spec = spec_for(params.default, params.sections.get(s.key))
            jobs.append(Job(s.region, s.guide, spec, spec.speed))
    return comparison_json(compare(jobs, params.compare), len(jobs), layers)


@register
class StrategyNode(LayerNode):
    """Fill each section with a deposition path along its guide: MPP oscillate/parallel or one of the
    robot study's objective-rectangle patterns (raster, semicircular, triangular, rectangular,
    spiral, swiping), fitted to the section's shape. Passes are offsets of the guide, so they follow
    a curved guide; pass count and boundary margin follow the study's rule from the bead spacing.

    Each segment carries arc ON/OFF (raster returns and, with arc_outside "off", every stretch
    outside the section are OFF), inside/outside the section, and the programmed speed. Sections
    keep their order. Artifacts: `toolpath.json`, `paths.json` (per section: programmed length,
    arc switches, length outside, time at programmed speed); with `compare` set, `comparison.json` and
    `comparison.svg` compare patterns on the same sections (length, arc switches, share outside,
    time at programmed speed).

    The whole section gets a path: each section's path is checked against the section (arc-ON path
    buffered by half the bead width; a weave's pool bridges its strokes). A section of a layer with
    no mask (a connected region, key `region<k>`) that its path leaves more than `max_uncovered`
    (2 %) without a bead, or welds off the part (its outside is off the part: arc-ON centre line
    more than a bead width beyond the run-ups, or the bead wholly off it over more than a bead
    width), is split at its reflex corners into pieces, each filled along its own long
    axis and joined by arc-OFF links, or else filled with contour rings (`whole_regions: auto`); its
    toolpath `strategy` names the pattern used. Any section still left more than `max_uncovered`
    uncovered (a drawn mask section, or `whole_regions: off`) is warned about with its area, layer
    and section. The node report `cover` counts the sections planned as given, split and filled
    with contour, and lists the changed ones by layer.

    With a bead model connected (`model`, from bead-fit), the default bead width is the model's
    target width and the spacing its step-over, 0.738·width (Ding et al. 2015 tangent overlap
    model, as the contour pattern uses): the connected model wins over `default`'s bead_width and
    spacing (a warning names both when the default sets them to other values); per-section
    overrides stay the user's.
    """

    type = "strategy"
    combine_keeps_items = True  # combine only warns
    version = "8"  # 2: run-ups along the guide; 3: passes follow curved guides; 4-5: narrow sections, spiral start; 6: bead model; 7: whole regions covered, uncovered area warned; 8: whole regions never welded off the part
    title = "Strategy"
    category = "mpp"
    inputs = (
        Port("sections", "sections", "Sections per layer (with guides)"),
        Port(
            "model",
            "bead-model",
            "Optional bead model (bead-fit): its target width and step-over set the default bead_width and spacing",
            optional=True,
        ),
    )
    outputs = (Port("toolpath", "toolpath", "One section path per section, in section order"),)
    over = "sections"

    class Params(NodeParams):
        default: SectionStrategy = Field(
            default_factory=SectionStrategy, description="Spec for every section", title="Default strategy"
        )
        whole_regions: Literal["auto", "off"] = Field(
            "auto",
            description="Sections of layers with no mask (each connected region is one section): "
            "'auto' re-plans a region its path leaves more than max_uncovered without a bead, "
            "or welds off the part "
            "(split at its reflex corners, each piece along its own long axis; else contour "
            "rings); 'off' keeps the path as planned (still warned about)",
            title="Whole regions",
        )
        max_uncovered: float = Field(
            2.0,
            ge=0.0,
            le=100.0,
            json_schema_extra=unit("%"),
            description="Share of a section's area its path may leave without a bead "
            "(arc-ON path buffered by half the bead width; a weave's pool "
            "bridges its strokes) before the section is re-planned (auto) "
            "or warned about",
            title="Largest uncovered share",
        )
        sections: dict[str, SectionOverride] = Field(  # type: ignore[valid-type]
            default_factory=dict,
            description='Section key ("bs1/A") → fields that differ from the default',
            title="Strategy by section",
        )
        compare: list[str] = Field(
            default_factory=list,
            max_length=16,
            description='Patterns to compare on the same sections ("triangular:60" sets '
            "the apex angle); empty = no comparison artifacts",
            title="Patterns to compare",
        )

        @model_validator(mode="after")
        def _overrides_valid(self):
            for key, ov in self.sections.items():
                try:
                    spec_for(self.default, ov)
                except ValueError as e:
                    raise ValueError(f"sections[{key!r}]: {e}") from None
            return self

        @field_validator("compare")
        @classmethod
        def _variants(cls, v: list[str]) -> list[str]:
            for text in v:
                parse_variant(text)
            return v

    @staticmethod
    def effective(params, model):
        """`params` with the default's bead_width and spacing from a connected bead model's target
        width and step-over (unchanged without a model or target)."""
        width = getattr(model, "target_width_mm", None) if model is not None else None
        if width is None:
            return params
        default = SectionStrategy.model_validate(
            {**params.default.model_dump(), "bead_width": float(width), "spacing": float(model.step_over(width))}
        )
        return params.model_copy(update={"default": default})

    def layer_params(self, params, index, items):
        params = self.effective(params, items.get("model"))
        ls: LayerSections = items["sections"]
        return {
            "default": params.default.model_dump(mode="json"),
            "sections": {
                s.key: params.sections[s.key].model_dump(mode="json", exclude_none=True)
                for s in ls.sections
                if s.key in params.sections
            },
            "whole_regions": params.whole_regions,
            "max_uncovered": params.max_uncovered,
        }

    def run_layer(self, ctx, params, index, items):
        params = self.effective(params, items.get("model"))
        ls: LayerSections = items["sections"]
        out, fills = [], []
        limit = params.max_uncovered / 100.0
        for s in ls.sections:
            spec = spec_for(params.default, params.sections.get(s.key))
            if 0.0 < s.region.area < NOISE_WIDTHS2 * spec.bead_width**2:  # (none at all: plan_whole says so)
                a = round(float(s.region.area), 6)  # slicing noise: one warning for the part (`combine`)
                fills.append(
                    {"section": s.key, "how": LEFT_OUT, "pattern": None, "pieces": 0, "uncovered_mm2": a, "area_mm2": a}
                )
                continue
            # a key without "/" is a connected region (no mask): a section nobody drew
            adapt = params.whole_regions == "auto" and "/" not in s.key
            try:
                whole = plan_whole(s.region, s.guide, spec, adapt=adapt, max_uncovered=limit)
            except PlanningError as e:
                raise e.located(layer=index, section=s.key)
            except ValueError as e:
                raise PlanningError(f"{spec.pattern}: {e}", layer=index, section=s.key) from e
            path = whole.path
            w = spec.bead_width
            if whole.uncovered_share <= limit and whole.hole_widths > HOLE_MAX_WIDTHS and ctx is not None:
                ctx.warn(
                    f"one place of {whole.hole_widths * w * w:.0f} mm² of section {s.key} on layer {index} gets no "
                    f"bead ({whole.hole_widths:.1f} bead widths of bead, {100 * whole.uncovered_share:.1f} % of the "
                    f"section; {whole.pattern}{', split at its corners' if whole.how == 'split' else ''}): the "
                    "preflight fails a layer with such a place (hole); add a mask section there or choose contour",
                    layer=index,
                    section=s.key,
                )
            if whole.uncovered_share > limit and ctx is not None:
                ctx.warn(
                    f"{whole.uncovered:.1f} mm² ({100 * whole.uncovered_share:.1f} %) of section {s.key} on "
                    f"layer {index} gets no bead ({whole.pattern}"
                    f"{', split at its corners' if whole.how == 'split' else ''}): add a mask section there "
                    "or choose a filling pattern (contour, parallel)",
                    layer=index,
                    section=s.key,
                )
            # a section planned as given (a drawn mask's) is measured against the layer's part here:
            # arc_outside 'on' welds on beyond it, which may be the part's outside (a notch, a hole)
            off = whole.outside if adapt else outside_length(ls.layer.region, path, spec)
            if off > OUTSIDE_TOL and ctx is not None:
                how = (
                    f"{', split at its corners' if whole.how == 'split' else ''}, the best of as planned, split "
                    "and contour): set arc_outside 'off', choose contour, or draw a mask"
                    if adapt
                    else ", planned as given, as a drawn section or `whole_regions: off` is): set arc_outside "
                    "'off', choose contour, or change the mask"
                )
                ctx.warn(
                    f"{off:.1f} mm of arc-ON path of section {s.key} on layer {index} runs off the "
                    f"part beyond its run-ups ({whole.pattern}{how}",
                    layer=index,
                    section=s.key,
                )
            fills.append(
                {
                    "section": s.key,
                    "how": whole.how,
                    "pattern": whole.pattern,
                    "pieces": whole.pieces,
                    "uncovered_mm2": round(whole.uncovered, 3),
                    "area_mm2": round(whole.area, 3),
                }
            )
            out.append(
                SectionPath(
                    key=s.key,
                    strategy=whole.pattern,
                    points=ls.layer.to_world(path.points),
                    arc=path.arc.copy(),
                    inside=path.inside.copy(),
                    speed=np.full(len(path.points) - 1, spec.speed),
                )
            )
        return {"toolpath": PlannedLayerPaths(ls.layer, tuple(out), fills=tuple(fills))}

    def combine(self, ctx, params, outputs, inputs):
        model = inputs.get("model")
        given = params
        params = self.effective(params, model)
        if model is not None and params is given:
            ctx.warn("the connected bead model has no target width: the default bead_width and spacing are used")
        elif params is not given:
            d0, d1 = given.default, params.default
            clash = [
                f
                for f in ("bead_width", "spacing")
                if f in d0.model_fields_set and abs(getattr(d0, f) - getattr(d1, f)) > 1e-9
            ]
            if clash:
                ctx.warn(
                    f"bead width {d1.bead_width:g} mm and spacing {d1.spacing:.4g} mm from the bead model "
                    f"(connected model wins over the default's bead_width {d0.bead_width:g} mm, spacing "
                    f"{d0.spacing:g} mm)"
                )
        # The comparison re-plans every section once per compared pattern: it is memoised on the
        # sections' signatures + params, since combine runs on every execution (cached layers too).
        self._comparison = None
        if params.compare:
            sections = inputs["sections"]
            key = None
            if sections.sigs and all(sections.sigs):
                key = json.dumps([list(sections.sigs), params.model_dump(mode="json")], sort_keys=True)
            self._comparison = _COMPARISONS.get(key) if key else None
            if self._comparison is None:
                self._comparison = _compare_sections(sections, params)
                if key:
                    _COMPARISONS[key] = self._comparison
                    while len(_COMPARISONS) > 8:
                        _COMPARISONS.pop(next(iter(_COMPARISONS)))
        _warn_noise(ctx, outputs["toolpath"])
        ctx.report(cover_report(outputs["toolpath"]))
        return super().combine(ctx, params, outputs, inputs)

    def artifacts(self, ctx, params, outputs) -> dict[str, Any]:
        tp = outputs["toolpath"]
        files: dict[str, Any] = {
            "toolpath.json": serialize.dumps(serialize.toolpath_json(tp)),
            "paths.json": serialize.dumps(paths_summary(tp)),
        }
        comp = getattr(self, "_comparison", None)
        if params.compare and comp is not None:
            files["comparison.json"] = serialize.dumps(comp)
            files["comparison.svg"] = comparison_svg(comp["patterns"], selected=params.default.pattern)
        return files
