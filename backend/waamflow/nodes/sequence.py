"""The MPP sequence node (Michel et al. 2019: the layer path): a layer's section paths joined into
one program with arc-OFF travel between them, each layer starting where the previous ended.

A thin adapter over waamflow.sequencing; the chain of layers runs on the whole part (not a
LayerNode), with speculative runs of layers in the run's workers (`run_ahead`, `map_in_workers`).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from ..core import serialize
from ..core.errors import layer_ranges
from ..core.model import Layered
from ..engine.node import Node, NodeParams, register, unit
from ..engine.ports import Port
from ..process.interpass import climbing_note, spanning_sections
from ..sequencing import sequence_part
from ..sequencing.layer_path import chunk_seconds, part_travel, sequence_ahead
from ..sequencing.seams import DEFAULT_CLEARANCE, SeamSpec, ignition_points, nearest_distances
from ..sequencing.tour import submitted_seconds

Point2 = tuple[float, float]


# ------------------------------------------------------------------------------------------------
# sequence
# ------------------------------------------------------------------------------------------------
@register
class SequenceNode(Node):
    """MPP layer path: join a layer's section paths into one program with arc-OFF travel between them.

    Order: `mask` (the mask's section order), `nearest` (shortest travel from the previous layer's
    end, keeping the MPP order rule: `precedence` keys, then oscillated sections, then the parallel
    ones they feed; exact up to 6 sections, else nearest neighbour + 2-opt/Or-opt) or an explicit
    list of section keys (a mask/explicit order that breaks the rule is warned). `seam`: where each
    section ignites — `auto` (the entry farthest from the layer below's ignitions; loops move on by
    `seam_shift`), `alternate` (odd layers reversed), `stagger`, `scattered`, `aligned` (as
    planned) or an [x, y] point; a path may be reversed, a serpentine of passes re-threaded from its
    other end, a loop rotated; never at a junction with another section (within `bead_width`) unless
    `seam_at_junctions`; machining stock (segments outside the section) first. Arc-ON runs shorter
    than `min_arc_run_mm` are bridged across an inside gap or dropped, warned and counted in the
    report. Travel: retract by `retract_height` along the build direction, travel, plunge.
    `alternate` also reverses the section order on odd layers. `dwell` adds an interlayer dwell
    (a section that climbs several layers' heights, a helix, gets none between its laps: warned).
    Writes `toolpath.json` and `travel.json` (travel length per layer).
    """

    # Not a LayerNode on purpose: layer i starts where layer i-1 ended (approach, the nearest order
    # and the seams, chosen away from the ignitions below), so a per-layer signature would miss a
    # change below. As a whole-part node its output signatures change with any input layer.
    type = "sequence"
    version = "2"
    title = "Sequence (layer path)"
    category = "mpp"
    inputs = (Port("toolpath", "toolpath", "Zoned section paths"),)
    outputs = (Port("toolpath", "toolpath", "Layer programs in deposition order"),)

    class Params(NodeParams):
        order: Literal["mask", "nearest"] | list[str] = Field(
            "mask",
            description="`mask`, `nearest` (shortest travel within the MPP order rule) or a list of section keys",
            title="Section order",
        )
        precedence: list[str] = Field(
            default_factory=list,
            description="Section keys deposited first on every "
            "layer, in this order, before the oscillated and then the other sections "
            "(the order rule `nearest` keeps)",
            title="Sections first",
        )
        retract_height: float = Field(
            10.0,
            ge=0,
            le=500,
            description="Clearance of arc-OFF travel above the higher end point",
            json_schema_extra=unit("mm"),
            title="Retract height",
        )
        alternate: bool = Field(
            False,
            description="Reverse open sections and the section order on odd layers (seam `alternate`)",
            title="Alternate odd layers",
        )
        seam: Literal["auto", "alternate", "stagger", "scattered", "aligned"] | Point2 = Field(
            "auto",
            description="Where sections ignite: auto (farthest from the ignitions of the layer below), "
            "alternate, stagger, scattered, aligned (as planned) or an [x, y] point (layer-local, mm)",
            title="Seam placement",
        )
        seam_shift: float = Field(
            0.0,
            ge=0,
            le=1000,
            description="Distance a closed loop's seam moves per layer (stagger/auto); 0 = 2 bead widths",
            json_schema_extra=unit("mm"),
            title="Seam shift per layer",
        )
        seam_at_junctions: bool = Field(
            False, description="Allow ignition at a junction with another section", title="Seams at junctions"
        )
        bead_width: float = Field(
            0.0,
            ge=0,
            le=100,
            description="Bead width: junction clearance and the "
            "defaults of seam_shift and min_arc_run_mm; 0 = unknown (6 mm clearance, "
            "12 mm minimum run)",
            json_schema_extra=unit("mm"),
            title="Bead width",
        )
        min_arc_run_mm: float | None = Field(
            None,
            ge=0,
            le=1000,
            description="Shortest arc-ON run; shorter "
            "ones are bridged or dropped (0 = off; empty = 2 bead widths, "
            "12 mm without a bead width)",
            json_schema_extra=unit("mm"),
            title="Shortest arc-on run",
        )
        dwell: float = Field(
            0.0,
            ge=0,
            le=3600,
            description="Interlayer dwell after each layer",
            json_schema_extra=unit("s"),
            title="Interlayer dwell",
        )

    def run(self, ctx, params, inputs):
        tp = inputs["toolpath"]
        if not isinstance(params.order, str) and all(lp is not None for lp in tp):
            seen = {sp.key for lp in tp for sp in lp.sections}
            for key in params.order:
                if key not in seen:
                    ctx.warn(f"order lists {key!r}, which matches no section", section=key)

        def in_workers(fn, items):  # in the workers if up and paid by what is sent (ctx.ahead may leave a few)
            return ctx.map_in_workers(fn, items, seconds=chunk_seconds(items))

        def on_layer(k: int, n: int) -> None:  # a sketch of 3,000 walls a layer takes seconds a layer
            ctx.check_cancelled()
            ctx.progress(k / n, f"layer {k} of {n} sequenced")

        if params.order == "nearest":  # a large layer's second seed goes to a worker (tour.nearest_order)
            ctx.start_workers(sum(submitted_seconds(len(lp.sections)) for lp in tp if lp is not None))
        layers, notes = sequence_with_notes(list(tp), params, in_workers, on_layer, ctx.submit, ctx.ahead())
        _report(ctx, params, layers, notes)
        for span in spanning_sections(Layered(tuple(layers))) if params.dwell > 0 else ():  # a helix's laps: one layer
            what = f"the {params.dwell:g} s interlayer dwell comes after all its laps, none between them"
            ctx.warn(climbing_note(span, what), layer=span.layer, section=span.section)
        return {"toolpath": Layered(tuple(layers))}

    ahead_input = "toolpath"  # zoned layers sequenced in the chain tasks that made them

    def run_ahead(self, params, items):
        """A run of consecutive zoned layers sequenced from nothing where a chain task made them
        (`layer_path.sequence_ahead`); `run` takes a layer's result only when it was made from the
        very layer it is given, with the torch position and ignitions the serial chain reaches."""
        return sequence_ahead(items, **_kernel_kw(params))

    def artifacts(self, ctx, params, outputs):
        travel = [
            {"index": lp.index, "travel_mm": round(t, 3), "order": [sp.key for sp in lp.sections]}
            for lp, t in zip(outputs["toolpath"], part_travel(outputs["toolpath"]))
            if lp is not None
        ]
        total = round(sum(t["travel_mm"] for t in travel), 3)
        return {
            "toolpath.json": serialize.dumps(serialize.toolpath_json(outputs["toolpath"])),
            "travel.json": serialize.dumps({"units": "mm", "total_travel_mm": total, "layers": travel}),
        }


def _min_run(params) -> float:
    """The shortest arc-ON run, mm: `min_arc_run_mm`, else two bead widths (12 mm when unknown)."""
    bw = params.bead_width
    return params.min_arc_run_mm if params.min_arc_run_mm is not None else (2.0 * bw if bw > 0 else 12.0)


def _kernel_kw(params) -> dict:
    """The sequencing kernel's keywords for the node's params (`sequence_layer`)."""
    bw = params.bead_width
    clearance = bw if bw > 0 else DEFAULT_CLEARANCE
    shift = params.seam_shift if params.seam_shift > 0 else 2.0 * clearance
    min_run = _min_run(params)
    policy = "alternate" if params.alternate and params.seam == "auto" else params.seam
    return {
        "order": params.order,
        "retract_height": params.retract_height,
        "alternate": params.alternate,
        "dwell_after_s": params.dwell,
        "min_run": min_run,
        "precedence": tuple(params.precedence),
        "seam": SeamSpec(
            policy if isinstance(policy, str) else tuple(policy), clearance, shift, params.seam_at_junctions
        ),
    }


def sequence_with_notes(
    layers: list, params, map_chunks=None, on_layer=None, submit=None, ahead=None
) -> tuple[list, list[dict]]:
    """Run `sequence_part` with the node's params (`map_chunks`, `on_layer`, `submit`, `ahead`:
    see there); returns the layers and the kernel's notes."""
    notes: list[dict] = []
    seq, _ = sequence_part(
        layers, map_chunks=map_chunks, on_layer=on_layer, ahead=ahead, notes=notes, submit=submit, **_kernel_kw(params)
    )
    return seq, notes


def _short_runs(runs: list[dict], kind: str, min_run: float) -> str:
    """The warning for a section's arc-ON runs shorter than the minimum, bridged or dropped."""
    first = runs[0]
    at = f"{[round(float(c), 3) for c in first['at'][:2]]}"
    limit = f"the minimum arc run ({min_run:g} mm, `min_arc_run_mm`)"
    if kind == "bridged":
        what, fix = "bridged to a neighbour across an inside gap, arc kept on", ""
    else:
        what = "dropped (no inside gap to bridge): flown arc-OFF, no metal there"
        fix = (
            ": the path there is too short for a stable arc (features narrower than its pattern and bead "
            "can follow); lower `min_arc_run_mm` to weld them, or give the section another pattern or bead width"
        )
    if len(runs) == 1:
        return f"arc-ON run of {first['length']:.2f} mm at {at} on layer {first['layer']} is shorter than {limit}: {what}{fix}"
    lengths = [r["length"] for r in runs]
    layers = sorted({r["layer"] for r in runs})
    where = f"layer {layers[0]}" if len(layers) == 1 else f"{len(layers)} layers ({layer_ranges(layers)})"
    return (
        f"{len(runs)} arc-ON runs of {min(lengths):.2f}-{max(lengths):.2f} mm on {where} are shorter than "
        f"{limit}: {what} (first at layer {first['layer']} {at}){fix}"
    )


def _report(ctx, params, layers, notes: list[dict]) -> None:
    """Warn each event (layer, section) and report the counts and the seam distances."""
    kinds = {"bridged": 0, "dropped": 0, "junction": 0, "order-rule": 0}
    junctions: dict[str, list[dict]] = {}
    short: dict[tuple[str, str], list[dict]] = {}
    for n in notes:
        kinds[n["kind"]] += 1
        if n["kind"] in ("bridged", "dropped"):
            short.setdefault((n["section"], n["kind"]), []).append(n)
        elif n["kind"] == "junction":
            junctions.setdefault(n["section"], []).append(n)
    min_run = _min_run(params) if short else 0.0
    for (key, kind), runs in short.items():  # one warning a section and kind: a part of pins drops thousands
        ctx.warn(_short_runs(runs, kind, min_run), layer=runs[0]["layer"], section=key)
    for key, at in junctions.items():  # one warning a section, its layers named
        layers_at = sorted({n["layer"] for n in at})
        where = (
            f"layer {layers_at[0]}" if len(layers_at) == 1 else f"{len(layers_at)} layers ({layer_ranges(layers_at)})"
        )
        fix = (
            "both ends of the wall meet other walls: set `seam_at_junctions` to accept it"
            if at[0].get("strategy") == "wall"
            else "set `seam_at_junctions` to accept it, or change the guide"
        )
        ctx.warn(
            f"ignites at a junction with another section at {at[0]['at'][:2]} on {where}: every entry does ({fix})",
            layer=at[0]["layer"],
            section=key,
        )
    breaks = [n for n in notes if n["kind"] == "order-rule"]
    if breaks:
        first = breaks[0]
        ctx.warn(
            f"order deposits {first['before']!r} before {first['section']!r} against the MPP order rule "
            f"(oscillated sections, then the parallel ones they feed) on {len({n['layer'] for n in breaks})} "
            "layer(s): use order `nearest` or list them in `precedence`",
            layer=first["layer"],
            section=first["section"],
        )
    gaps = []
    below = None
    for lp in layers:
        if lp is None:
            below = None
            continue
        ign = ignition_points(lp.sections)
        if below is not None and len(below):
            gaps += nearest_distances(ign, below).tolist()
        below = ign
    ctx.report(
        {
            "short_runs_bridged": kinds["bridged"],
            "short_runs_dropped": kinds["dropped"],
            "junction_ignitions": kinds["junction"],
            "order_rule_breaks": kinds["order-rule"],
            "ignitions": int(sum(len(ignition_points(lp.sections)) for lp in layers if lp is not None)),
            "min_ignition_gap_to_layer_below_mm": round(min(gaps), 3) if gaps else None,
        }
    )


__all__ = ["SequenceNode", "sequence_with_notes"]
