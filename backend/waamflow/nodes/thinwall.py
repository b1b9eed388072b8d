"""Thin-wall nodes (Venturini et al. 2018): `features` (recognition by valence) and `wall-path`
(feature strategies, one bead per wall). Thin adapters over waamflow.features; `wall-path` also
lays the centre line of single-bead ring regions (fan-sliced hollow walls, waamflow.curved)."""

from __future__ import annotations

from typing import Literal

import numpy as np
import shapely
from pydantic import Field, model_validator

from ..core import serialize
from ..core.notes import Notes
from ..core.errors import PlanningError
from ..core.model import Layer, LayerPaths, Layered, SectionPath, region_polygons
from ..core.tolerances import TOL
from ..curved.centerline import ring_centerline, seam_index, start_at
from ..curved.fan import to_local
from ..engine.node import Node, NodeParams, register, unit
from ..engine.ports import Port
from ..features import RecognitionSpec, WallSpec, features_for_layer, helix, plan_layer_walls, recognise_layers
from ..features.recognition import curves_digest
from ..features.tubular import aligned_loop, scattered_loop
from ..features.walls import WallPass, order_passes

# The bead of the study's trials (80 A, 18 V, 300 mm/min, WFS 4.6 m/min): ~5 mm, the width at
# which its radii 2.0/10.0 mm were sound (see features.walls.crossing_window).
STUDY_BEAD_WIDTH = 5.0


def _centerlines(job: tuple[list, float]) -> list[tuple[np.ndarray, float]]:
    """The centre lines of a list of ring polygons (a worker's share of `_ring_centerlines`)."""
    polys, spacing = job
    return [ring_centerline(p, spacing) for p in polys]


def _ring_centerlines(ctx, layers, spacing: float) -> dict[tuple[int, int], tuple[np.ndarray, float]]:
    """(layer slot, polygon index) → (centre line, width) of every ring of the region layers: each
    ring's own (no seam, no neighbour), so they are computed up front, in the run's workers when
    the cost model says the layers pay (`ctx.map`); the laps are then placed layer by layer."""
    keys, polys = [], []
    for slot, layer in enumerate(layers):
        if layer is None or layer.curves:
            continue
        for k, poly in enumerate(region_polygons(layer.region)):
            if poly.interiors:
                keys.append((slot, k))
                polys.append(poly)
    n = max(1, min(len(polys), 8))
    bounds = [len(polys) * i // n for i in range(n + 1)]
    jobs = [(polys[a:b], spacing) for a, b in zip(bounds, bounds[1:]) if b > a]
    if not jobs:
        return {}
    mapper = getattr(ctx, "map", None)  # a Context maps; a bare stand-in computes here
    got = mapper(_centerlines, jobs, layers=len({s for s, _k in keys})) if mapper else list(map(_centerlines, jobs))
    return dict(zip(keys, (c for part in got for c in part)))


@register
class FeaturesNode(Node):
    """Thin-wall feature recognition by valence (Venturini et al. 2018).

    Reads the midsurface curves of the layers (the first layer with curves — an extrusion repeats
    it — or every distinct layer). End points and curve–curve intersections within `merge_tol` are
    one point; the entities, ends and branches there give the kind: free_end, corner/continuous
    (by `corner_angle_deg`), t_crossing, direct_crossing, odd_t_crossing, odd_direct_crossing,
    four_direct_crossing. Entities are counted as drawn: an X whose crossing arm is two collinear
    curves is an odd direct crossing (also when the sketch joined them, or when they stop up to
    `join_gap` short of the other wall). Three-branch crossings carry the study's T sub-type,
    `subtype`: straight (a side within `corner_angle_deg` of 180°), open (a side wider: the stem
    inside a bent wall's corner) or closed (every side narrower). Closed loops touching nothing
    are tubulars, `isolated` when the band of half the torch `encumbrance` about them touches no
    other curve. Writes `<node>.features.json`.
    """

    type = "features"
    title = "Feature recognition"
    category = "thin walls"
    inputs = (Port("layers", "layers", "Layers with midsurface curves (from a sketch)"),)
    outputs = (Port("features", "features", "Recognised features"),)

    class Params(NodeParams):
        merge_tol: float = Field(
            TOL.merge,
            gt=0,
            le=1.0,
            json_schema_extra=unit("mm"),
            description="Points closer than this are one point (study: 1e-6 mm)",
            title="Merge tolerance",
        )
        corner_angle_deg: float = Field(
            30.0,
            gt=0,
            lt=180,
            json_schema_extra=unit("deg"),
            description="Walls turning by at least this angle meet at a corner, less: continuous junction",
            title="Corner angle",
        )
        encumbrance: float = Field(
            30.0,
            gt=0,
            le=1000,
            json_schema_extra=unit("mm"),
            description="Torch maximum encumbrance (diameter) for the isolated-tubular test",
            title="Torch encumbrance",
        )
        every_layer: bool = Field(
            False, description="Recognise every distinct layer, not only the first", title="Every layer"
        )
        join_gap: float = Field(
            0.05,
            ge=0,
            le=5.0,
            json_schema_extra=unit("mm"),
            description="Open curve ends this close whose curves continue each other (collinear "
            "within join_angle_deg) are joined before classifying; 0 = only "
            "coincident ends meet",
            title="Join gap",
        )
        join_angle_deg: float = Field(
            1.0,
            ge=0,
            le=30,
            json_schema_extra=unit("deg"),
            description="Angle tolerance for joining collinear curves",
            title="Join angle tolerance",
        )

    def run(self, ctx, params, inputs):
        spec = RecognitionSpec(
            params.merge_tol,
            params.corner_angle_deg,
            params.encumbrance,
            join_gap=params.join_gap,
            join_angle_deg=params.join_angle_deg,
        )
        fs = recognise_layers(inputs["layers"], spec, every_layer=params.every_layer)
        if not fs.layers:
            ctx.warn("no layer has midsurface curves: nothing to recognise (connect a sketch)")
        return {"features": fs}

    def artifacts(self, ctx, params, outputs):
        return {"features.json": serialize.dumps(outputs["features"].to_json())}


def _section(layer: Layer, p: WallPass, speed: float) -> SectionPath:
    pts = layer.to_world(p.xy)
    n = len(pts) - 1
    axis = None if layer.frame is None else np.tile(-layer.normal, (len(pts), 1))
    return SectionPath(
        p.key, p.strategy, pts, np.ones(n, bool), np.asarray(p.inside, bool), np.full(n, float(speed)), tool_axis=axis
    )


@register
class WallPathNode(Node):
    """One bead per wall: the thin-wall feature strategies (Venturini et al. 2018).

    Curves are split into entities at crossings; corner/continuous junctions are deposited in one
    go. At crossings a cutting circle (`cut_radius`) removes the walls and, per fillet corner, a
    segment joins the branch's cut point to the influence-circle point (`influence_radius`) on the
    corner bisector (study best: 10.0 / 2.0 mm); flat corners of a T are bridged across. The
    study's wall widths: `tww` (total wall width as deposited = the bead width), `eww` (effective,
    after machining) and `deposition_efficiency` (EWW/TWW) — any two give the third, the bead
    width is TWW (else `bead_width`, else the study's 5 mm). With it, radii the study's trials
    found defective are warned by junction and radius (cut > 0.8·w/2, influence < √2·w/sin(α/2);
    theoretical bounds w/2 and w/sin(α/2)). `fillet_radius` R_f: corners turn on the filleted
    wall's midsurface, radius R_f + EWW/2; crossings warn where walls and fillet leads leave a
    fillet corner partly empty. Free ends
    are extended by `free_end_extension` so ignition/extinction fall outside the useful wall.
    Isolated tubulars: `tubular` = helical (one continuous helix, pitch = layer height, placed in
    the first layer, over the consecutive layers of one ring; a tube whose ring changes every layer,
    a sliced surface's, gets aligned laps and a warning once), aligned or scattered start–stop with
    self-overlap `overlap`; non-isolated
    ones are built layer by layer (scattered). Layers without curves but with ring regions (a
    fan-sliced hollow wall) get the ring's centre line as one lap with `overlap`, its seam chosen
    by `tubular`: aligned (and helical, which rings, each layer its own centre line, are not laid
    as: a warning says so once) starts layer 0 in the middle of the lap's longest straight stretch
    and every later layer at the point nearest the seam below (starts that stack, which the
    preflight warns); scattered moves that start on by the golden-ratio fraction of the lap per
    layer.
    Passes in greedy nearest-neighbour order, each layer starting where the previous ended; `seam`
    stock (default) ignites a pass with machining stock at one end only (free-end extension, fillet
    lead) in that stock and warns, with the layer, of walls that have none.
    Writes `<node>.toolpath.json`.
    """

    type = "wall-path"
    version = "2"
    title = "Wall path (thin walls)"
    category = "thin walls"
    inputs = (
        Port("layers", "layers", "Layers (midsurface curves or ring regions)"),
        Port("features", "features", "Recognised features (default: recognised here)", optional=True),
    )
    outputs = (Port("toolpath", "toolpath", "One bead per wall, per layer"),)

    class Params(NodeParams):
        speed: float = Field(
            5.0,
            gt=0,
            le=200,
            json_schema_extra=unit("mm/s"),
            description="Travel speed (study trials: 300 mm/min = 5 mm/s)",
            title="Travel speed",
        )
        cut_radius: float = Field(
            2.0,
            gt=0,
            le=100,
            json_schema_extra=unit("mm"),
            description="Cutting circle radius at crossings (study best 2.0)",
            title="Cutting radius",
        )
        influence_radius: float = Field(
            10.0,
            gt=0,
            le=500,
            json_schema_extra=unit("mm"),
            description="Influence circle radius at crossings (study best 10.0)",
            title="Influence radius",
        )
        free_end_extension: float = Field(
            5.0,
            ge=0,
            le=200,
            json_schema_extra=unit("mm"),
            description="Path extension beyond a free wall end (arc start/stop zone)",
            title="Free end extension",
        )
        tubular: Literal["helical", "aligned", "scattered"] = Field(
            "helical", description="Strategy for isolated tubulars", title="Isolated tubulars"
        )
        overlap: float = Field(
            5.0,
            ge=0,
            le=200,
            json_schema_extra=unit("mm"),
            description="O_l: self-overlap at the stop of a start–stop lap (≈ crater length)",
            title="Start–stop overlap",
        )
        bead_width: float | None = Field(
            None,
            ge=0,
            le=100,
            json_schema_extra=unit("mm"),
            description="Bead width = total wall width TWW; empty: tww, else "
            "eww / deposition_efficiency, else 5 mm (the study's bead). "
            "Sets the crossing-radius bounds and the fillet check (0 = no check)",
            title="Bead width",
        )
        eww: float = Field(
            0.0,
            ge=0,
            le=100,
            json_schema_extra=unit("mm"),
            description="Effective wall width EWW, left after machining (0 = not given: the bead width)",
            title="Effective wall width",
        )
        tww: float = Field(
            0.0,
            ge=0,
            le=100,
            json_schema_extra=unit("mm"),
            description="Total wall width TWW as deposited, ≥ EWW: the bead width (0 = not given)",
            title="Total wall width",
        )
        deposition_efficiency: float = Field(
            0.0,
            ge=0,
            le=1,
            json_schema_extra=unit("1"),
            description="DE = useful / deposited area = EWW / TWW for a single-bead "
            "wall; with EWW gives TWW (0 = not given)",
            title="Deposition efficiency",
        )
        fillet_radius: float = Field(
            0.0,
            ge=0,
            le=100,
            json_schema_extra=unit("mm"),
            description="Internal fillet radius R_f of the part: corners turn on R_f + EWW/2; "
            "crossings warn where the fillet leads leave it empty (0 = sharp)",
            title="Fillet radius",
        )
        spacing: float = Field(
            1.0,
            gt=0.01,
            le=50,
            json_schema_extra=unit("mm"),
            description="Point spacing of ring centre lines (region layers)",
            title="Point spacing",
        )
        seam: Literal["stock", "nearest"] = Field(
            "stock",
            description="Wall ignition: stock (a pass with machining stock at one end only starts "
            "there; passes without stock are warned) or nearest (the end nearer the torch)",
            title="Wall seam",
        )

        @model_validator(mode="after")
        def _radii(self):
            if self.influence_radius <= self.cut_radius:
                raise ValueError("influence_radius must exceed cut_radius")
            return self

        @model_validator(mode="after")
        def _widths(self):
            """EWW, TWW and DE = EWW/TWW: any two give the third; the bead width is TWW."""
            eww, tww, de = self.eww, self.tww, self.deposition_efficiency
            if eww and tww and eww > tww + 1e-9:
                raise ValueError(
                    f"eww {eww:g} mm exceeds tww {tww:g} mm: the wall as deposited must hold the machined one"
                )
            if eww and tww and de and abs(eww / tww - de) > 5e-3:
                raise ValueError(
                    f"deposition_efficiency {de:g} disagrees with eww / tww = {eww:g} / {tww:g} = "
                    f"{eww / tww:.3f}: give two of the three"
                )
            if eww and de and not tww:
                tww = self.tww = eww / de
            elif tww and de and not eww:
                eww = self.eww = tww * de
            elif eww and tww and not de:
                self.deposition_efficiency = eww / tww
            if tww:
                if self.bead_width is not None and abs(self.bead_width - tww) > 1e-9:
                    raise ValueError(
                        f"bead_width {self.bead_width:g} mm disagrees with tww {tww:g} mm (the bead "
                        "width is the total wall width): give one"
                    )
                self.bead_width = tww
            elif self.bead_width is None:
                self.bead_width = STUDY_BEAD_WIDTH
            if eww and self.bead_width and eww > self.bead_width + 1e-9:
                raise ValueError(
                    f"eww {eww:g} mm exceeds the bead width {self.bead_width:g} mm: give tww or deposition_efficiency"
                )
            return self

    def run(self, ctx, params, inputs):
        layers: Layered[Layer] = inputs["layers"]
        fs = inputs.get("features")
        if fs is None:
            fs = recognise_layers(layers, RecognitionSpec())
        spec = WallSpec(
            params.cut_radius,
            params.influence_radius,
            params.free_end_extension,
            params.tubular,
            params.overlap,
            fs.spec.corner_angle_deg,
            fs.spec.merge_tol,
            params.bead_width or 0.0,
            eww=params.eww,
            fillet_radius=params.fillet_radius,
            join_gap=fs.spec.join_gap,
            join_angle_deg=fs.spec.join_angle_deg,
        )
        centers = _ring_centerlines(ctx, layers, params.spacing)
        out: list[LayerPaths | None] = []
        helices: dict = {}  # (ring digest, first slot) → {key, ring, slot, last slot, zs}: one per run of layers
        warned: set[str] = set()  # a note said once for the whole run
        notes = Notes()  # the kernel's notes, layer by layer: said once per kind, after the layers
        planned: dict = {}  # an extrusion's layers share their wall passes (plan_layer_walls `memo`)
        pos = None
        seams: list[np.ndarray] = []  # world seams of the last ring layer: the next aligns to them
        for slot, layer in enumerate(layers):
            ctx.check_cancelled()
            if layer is None:
                out.append(None)
                continue
            if layer.curves:
                passes = self._walls(ctx, layer, fs, spec, pos, helices, slot, notes, params.seam, planned)
            else:
                passes = self._rings(ctx, layer, params, spec, pos, seams, centers, slot)
                if passes and spec.tubular == "helical" and RINGS_NOT_HELICAL not in warned:
                    warned.add(RINGS_NOT_HELICAL)  # what the parameter asks is not what is laid: say so, once
                    ctx.warn(RINGS_NOT_HELICAL, layer=layer.index)
            if passes:
                pos = passes[-1].xy[-1]
            out.append(LayerPaths(layer, tuple(_section(layer, p, params.speed) for p in passes)))
        for h in helices.values():  # each isolated tube: one helix per run of consecutive layers, in its first
            lp = out[h["slot"]]
            if len(h["zs"]) == 1:  # its ring changes every layer (a sliced surface's): laps, as on rings
                xy = aligned_loop(h["ring"], spec.overlap)
                lap = _section(lp.layer, WallPass(h["key"], "aligned", xy, np.ones(len(xy) - 1, bool)), params.speed)
                out[h["slot"]] = LayerPaths(lp.layer, (lap,) + lp.sections, lp.dwell_after_s)
                if RINGS_NOT_HELICAL not in warned:
                    warned.add(RINGS_NOT_HELICAL)
                    ctx.warn(RINGS_NOT_HELICAL, layer=lp.layer.index)
                continue
            pts = helix(h["ring"], h["zs"])
            n = len(pts) - 1
            sp = SectionPath(h["key"], "helical", pts, np.ones(n, bool), np.ones(n, bool), np.full(n, params.speed))
            out[h["slot"]] = LayerPaths(lp.layer, (sp,) + lp.sections, lp.dwell_after_s)
        for index, text in notes.said():
            ctx.warn(text, layer=index)
        if not any(lp is not None and lp.sections for lp in out):
            raise PlanningError(_no_wall(layers))
        return {"toolpath": Layered(tuple(out))}

    @staticmethod
    def _walls(
        ctx,
        layer: Layer,
        fs,
        spec: WallSpec,
        start,
        helices: dict,
        slot: int,
        notes: Notes,
        seam: str = "stock",
        planned: dict | None = None,
    ) -> list[WallPass]:
        lw = plan_layer_walls(
            layer.curves,
            features_for_layer(fs, layer),
            spec,
            layer_index=layer.index,
            start=start,
            seam=seam,
            memo=planned,
        )
        for note in lw.warnings:
            notes.add(note, layer.index)
        if not lw.helical:
            return list(lw.passes)
        passes = list(lw.passes)
        for key, ring in lw.helical:
            if layer.frame is not None:  # a helix needs parallel planar layers: lap by lap instead
                xy = aligned_loop(ring, spec.overlap)
                passes.append(WallPass(key, "aligned", xy, np.ones(len(xy) - 1, bool)))
                continue
            dg = curves_digest([ring])
            run = next((h for (d, _), h in helices.items() if d == dg and h["last"] == slot - 1), None)
            if run is None:
                run = helices.setdefault((dg, slot), {"key": key, "ring": ring, "slot": slot, "last": slot, "zs": []})
            run["last"] = slot
            run["zs"].append(layer.z)
        return order_passes(passes, start, seam)

    @staticmethod
    def _rings(
        ctx,
        layer: Layer,
        params,
        spec: WallSpec,
        start,
        seams: list[np.ndarray],
        centers: dict[tuple[int, int], tuple[np.ndarray, float]],
        slot: int,
    ) -> list[WallPass]:
        """Ring laps of a region layer; `seams` (world points of the previous ring layer's seams)
        is replaced by this layer's; `centers`: the rings' centre lines (`_ring_centerlines`)."""
        passes, placed = [], []
        below = to_local(layer, np.array(seams)) if seams else np.zeros((0, 2))
        for k, poly in enumerate(region_polygons(layer.region)):
            if not poly.interiors:
                ctx.warn(f"region {k} has no hole (not a single-bead ring): skipped", layer=layer.index)
                continue
            mid, width = centers[(slot, k)]
            near = None
            if spec.tubular != "scattered" and len(below):
                # the seam below this lap (within a few bead widths): a new wall starts afresh
                gap = shapely.distance(shapely.LineString(mid), shapely.points(below))
                if gap.min() <= max(3.0 * width, 5.0 * params.spacing):
                    near = below[int(np.argmin(gap))]
            lap = start_at(mid, seam_index(mid, near))
            if spec.tubular == "scattered":
                xy = scattered_loop(lap, layer.index, spec.overlap)
            else:
                xy = aligned_loop(lap, spec.overlap)
            placed.append(layer.to_world(xy[:1])[0])
            passes.append(WallPass(f"ring{k}", "perimeter", xy, np.ones(len(xy) - 1, bool)))
        seams[:] = placed
        return order_passes(passes, start)

    def artifacts(self, ctx, params, outputs):
        return {"toolpath.json": serialize.dumps(serialize.toolpath_json(outputs["toolpath"]))}


RINGS_NOT_HELICAL = (
    "`tubular: helical` is laid as aligned start-stop laps on ring layers (a sliced mesh's or a fan's rings, "
    "each layer its own centre line): each lap ignites beside the lap below's start; set `tubular: aligned` "
    "to say so, or `scattered` to spread the starts (the preflight warns starts stacked within a bead width)"
)


def _no_wall(layers) -> str:
    """Why a wall-path planned nothing, and what to use instead: its layers' kinds counted (the
    message had named neither a layer nor a remedy)."""
    given = [l for l in layers if l is not None]
    solid = [l for l in given if not l.curves and not l.region.is_empty]
    curved = [l for l in given if l.curves]
    empty = len(given) - len(solid) - len(curved)
    if curved:  # walls there, all dropped (LibreCAD's v10.dxf: a 1.75 mm symbol)
        x0, y0, x1, y1 = shapely.total_bounds(list(curved[0].curves))
        size = float(max(x1 - x0, y1 - y0))
        return (
            f"no wall to deposit: {len(curved)} of {len(given)} layers carry curves (the sketch is {size:.2f} mm "
            "across), but every wall was dropped: inside the crossings' cutting circles or too short (the walls "
            "node's warnings say which); check the sketch's units and scale, or lower cut_radius"
        )
    if solid:
        first = solid[0]
        return (
            f"no wall to deposit: {len(solid)} of {len(given)} layers are filled regions without a hole (first: "
            f"layer {first.index}, {first.region.area:.0f} mm²), not single-bead walls: wall-path follows a "
            "sketch's or an open surface's curves and the rings of thin tubes. Fill solid sections with "
            "mask → strategy, or model the wall as its midsurface (a sketch) or a thin-walled tube"
        )
    return (
        f"no wall to deposit: the {len(given)} layers carry no curves and no ring regions ({empty} empty): "
        "check the slice's z range and the part (a sketch's curves, an open surface, or thin tubes)"
    )
