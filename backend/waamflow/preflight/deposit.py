"""What the deposit does besides covering the part, checked on the program as read back: the
wire it feeds against the part's volume (`_wire_balance`: wire ending in the part = Σ over arc-ON
segments of length / speed · WFS · π d²/4 · η, from the values the program commands), the lengths
of its arc runs (`_arc_runs`) and where its ignitions lie (`_ignitions`: stacked on the layer
below inside the part, or in machining stock outside it). `check.check_program` calls them.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np
import shapely
from shapely.geometry import MultiLineString
from shapely.ops import unary_union

from ..core.process import wire_area_mm2
from .read import ProgramRead, Run
from .report import Report, rounded
from .settings import PreflightSettings

if TYPE_CHECKING:  # check imports this module
    from .check import Coverage, Part


def _segments(run: Run) -> tuple[np.ndarray, np.ndarray]:
    d = np.diff(run.points, axis=0)
    return d, np.linalg.norm(d, axis=1)


def wire_volume(run: Run, s: PreflightSettings) -> tuple[float, int]:
    """(metal ending in the part from this run, mm³; arc-ON segments with no commanded wire feed or
    speed — their metal is unknown and left out)."""
    _d, length = _segments(run)
    ok = np.isfinite(run.wfs) & np.isfinite(run.speed) & (run.speed > 0) & (length > 0)
    rate = run.wfs * 1000.0 / 60.0 * wire_area_mm2(s.wire_diameter_mm) * s.deposition_efficiency  # mm³/s
    vol = float(np.sum(np.where(ok, length / np.where(ok, run.speed, 1.0) * np.where(ok, rate, 0.0), 0.0)))
    return vol, int(np.count_nonzero(~ok & (length > 0)))


def _wire_balance(
    part: Part | None,
    prog: ProgramRead,
    layers: list[tuple[int, list[Run]]],
    cov: Coverage | None,
    weld_expected: bool,
    out: dict,
    rep: Report,
    s: PreflightSettings,
    dwells: Sequence[tuple[float, int, Run, int]] = (),
) -> None:
    """Wire fed vs metal needed: per layer and in all (the moves', and the dwells' with the arc on:
    dwell.dwell_metal), the arc-ON moves without weld data, the wire/part volume ratio (out) and
    their problems."""
    wire_total, missing = 0.0, 0
    in_dwells = np.zeros(len(layers))
    for vol, li, _run, _n in dwells:
        in_dwells[li] += vol
    out["dwell_mm3"] = rounded(float(in_dwells.sum()), 1)
    for li, (idx, runs) in enumerate(layers):
        w = float(in_dwells[li])
        for r in runs:
            v, m = wire_volume(r, s)
            w += v
            missing += m
        wire_total += w
        L = rep.layer(idx)
        L["wire_mm3"] = rounded(w, 1)
        if L.get("part_mm3"):
            L["volume_ratio"] = rounded(w / L["part_mm3"], 3)
    seg_total = sum(len(r.speed) for r in prog.runs)
    weld_missing = sum(int(np.count_nonzero(~r.weld)) for r in prog.runs)
    out["weld_data_missing"] = weld_missing if weld_expected else None
    ratio = None
    if part is not None and cov and cov["part_volume_mm3"] > 0 and missing == 0:
        ratio = wire_total / cov["part_volume_mm3"]
    out["wire_mm3"] = rounded(wire_total, 1) if missing == 0 else None
    out["wire_part_volume_ratio"] = rounded(ratio, 3)
    if weld_expected and weld_missing and s.weld_data != "off":
        first = next(r for r in prog.runs if (~r.weld).any())
        rep.problem(
            "weld_data",
            s.weld_data,
            f"{weld_missing} of {seg_total} arc-ON moves have no weld parameter commanded (first: layer "
            f"{first.layer}, section {first.section}): the power source would weld with whatever job it "
            "holds; command wire feed/current in the machine profile (comments do not count)",
            layer=first.layer,
            section=first.section,
            value=weld_missing,
            limit=0,
            point=first.points[0],
        )
    no_wfs = [r for r in prog.runs if not np.isfinite(r.wfs).all()]  # (moves without a speed: _speedless)
    if weld_expected and no_wfs and not weld_missing and part is not None and cov and cov["part_volume_mm3"] > 0:
        # welded with weld data, but no wire feed the reader can see: the metal balance is unknown
        first = no_wfs[0]
        missing = sum(int(np.count_nonzero(~np.isfinite(r.wfs))) for r in no_wfs)
        rep.problem(
            "volume_ratio",
            "warn",
            f"{missing} arc-ON moves weld without a wire feed in the program (first: layer {first.layer}, "
            f"section {first.section}): the wire the part gets cannot be checked against its volume; "
            "command the wire feed, or check the power source's synergic line gives the zones' feeds",
            layer=first.layer,
            section=first.section,
            value=missing,
            limit=0,
            point=first.points[0],
        )
    if ratio is not None:
        lo, hi = s.volume_ratio_ok
        flo, fhi = s.volume_ratio_fail
        if not lo <= ratio <= hi:
            sev = "fail" if not flo <= ratio <= fhi else "warn"
            word = "more" if ratio > hi else "less"
            worst = max(
                (L for L in rep.layers.values() if L.get("volume_ratio")),
                key=lambda L: abs(math.log(L["volume_ratio"])),
                default=None,
            )
            rep.problem(
                "volume_ratio",
                sev,
                f"the wire fed puts {ratio:.2f}× the part's volume into it ({word} metal than the part "
                f"needs; wire {s.wire_diameter_mm} mm, deposition efficiency {s.deposition_efficiency}): "
                "balance wire feed and travel speed in the zone parameters (fill-parameters does)",
                layer=worst["index"] if worst else None,
                value=ratio,
                limit=hi if ratio > hi else lo,
            )


#: A layer is judged on its own metal balance when its slab needs at least this many bead widths of
#: bead (its part volume over bead width² × its height): a dome's last small layers are left out.
LAYER_BALANCE_MIN_WIDTHS = 10.0


def layer_balance(rep: Report, width: float, s: PreflightSettings) -> None:
    """The `layer_volume_ratio` problem: layers whose wire puts far less or more metal into their
    slab than the program's typical layer does (each layer's `volume_ratio` over their median: how
    fat the program's beads run against the part as a whole is `volume_ratio`'s), one problem per
    severity naming the worst. The part's balance hides a layer: the bracket's layer 150 of 300
    welded at three times its speed (a third of its metal) left the part at 0.99x. Layers with a
    skipped slab (`gap_below_mm`: skipped_layers names them) and layers needing under
    LAYER_BALANCE_MIN_WIDTHS bead widths of bead (slabs of a bead width squared × their height
    each) are not judged. Over 43 runs of solids (compas_slicer's through every pattern with
    `scripts/parts_sweep.py`, the shipped recipes) the layers needing ten widths or more lay
    0.74-1.59x their slab; compas_slicer's wavy vase as walls lays 1.4-1.6x its layers' upright
    walls and up to 2.1x at its narrowing top (1.4x its median layer)."""
    if s.layer_volume_ratio == "off" or width <= 0:
        return
    lo, hi = s.layer_volume_ratio_ok
    flo, fhi = s.layer_volume_ratio_fail
    judged = [
        L
        for L in rep.layers.values()
        if L.get("volume_ratio")
        and not L.get("gap_below_mm")
        and (L.get("height_mm") or 0.0) > 0
        and L.get("part_mm3", 0.0) >= LAYER_BALANCE_MIN_WIDTHS * width * width * L["height_mm"]
    ]
    if not judged:
        return
    typical = float(np.median([L["volume_ratio"] for L in judged]))
    rel = {id(L): L["volume_ratio"] / typical for L in judged}
    for sev in ("fail", "warn"):
        if sev == "fail":
            these = [L for L in judged if not flo <= rel[id(L)] <= fhi]
        else:
            these = [L for L in judged if flo <= rel[id(L)] <= fhi and not lo <= rel[id(L)] <= hi]
        if not these:
            continue
        worst = max(these, key=lambda L: abs(math.log(max(rel[id(L)], 1e-9))))
        r = rel[id(worst)]
        more = f"; {len(these) - 1} more layers lie outside {lo}-{hi}x of it" if len(these) > 1 else ""
        band = (flo, fhi) if sev == "fail" else (lo, hi)
        rep.problem(
            "layer_volume_ratio",
            s.layer_volume_ratio if sev == "fail" else "warn",
            f"layer {worst['index']} lays {r:.2f}x the metal of the program's typical layer for its slab of the "
            f"part ({worst['wire_mm3']:.0f} mm³ of wire for {worst['part_mm3']:.0f} mm³, {worst['volume_ratio']:.2f}x; "
            f"the typical layer {typical:.2f}x): a layer {'thinner' if r < 1 else 'thicker'} than the layers around it "
            f"by that much{more}: check the layer's travel speed and wire feed (a speed or feed meant for another "
            "layer, a zone's value typed wrong); the part's balance hides one layer",
            layer=worst["index"],
            value=r,
            limit=band[0] if r < band[0] else band[1],
        )


def _flagged(prog: ProgramRead, moves: Callable[[Run], np.ndarray]) -> list[tuple[Run, np.ndarray]]:
    """(run, indices of its arc-ON moves that `moves` flags) of each run with any, in program order."""
    out = [(r, np.flatnonzero(moves(r))) for r in prog.runs]
    return [(r, k) for r, k in out if len(k)]


def _speedless(prog: ProgramRead, rep: Report, s: PreflightSettings) -> None:
    """Arc-ON moves with no travel speed to weld at: a rapid with the arc on (G0: the controller's
    rapid rate, read as no speed) or a zero feed (F0: refused by LinuxCNC, a stall with the arc
    burning elsewhere). Their metal is unknown, so the wire balance has no ratio either."""
    if s.weld_speed == "off":
        return
    bad = _flagged(prog, lambda r: ~(np.isfinite(r.speed) & (r.speed > 0)))
    if not bad:
        return
    count = sum(len(k) for _r, k in bad)
    total = sum(len(r.speed) for r in prog.runs)
    first, k = bad[0]
    zero = bool(np.isfinite(first.speed[k[0]]))
    what = "a zero feed (F0)" if zero else "no speed: a rapid or joint move (G0, PTP, MoveJ) or no feed stated yet"
    rep.problem(
        "weld_speed",
        s.weld_speed,
        f"{count} of {total} arc-ON moves have no travel speed to weld at (first: layer {first.layer}, section "
        f"{first.section}, {what}): the torch would weld at the controller's rapid rate or stand with the "
        "arc burning; command a welding feed (zone `travel_speed`) on every arc-ON move",
        layer=first.layer,
        section=first.section,
        value=count,
        limit=0,
        point=first.points[int(k[0]) + 1],
    )


def feed_per_mm(prog: ProgramRead) -> tuple[list[tuple[Run, np.ndarray, np.ndarray]], float]:
    """(run, its moves' wire feed / travel speed in (m/min)/(mm/s), their lengths) of each run, and
    the length-weighted median of the positive ratios: the program's bead (its metal per mm is
    `core.process.deposit_rate_mm3_s` of it); nan when no move has one."""
    with np.errstate(divide="ignore", invalid="ignore"):  # no or zero speed: weld_speed's (_speedless)
        per = [(r, r.wfs / r.speed, _segments(r)[1]) for r in prog.runs]
    a_all = np.concatenate([a for _r, a, _l in per]) if per else np.zeros(0)
    l_all = np.concatenate([ln for _r, _a, ln in per]) if per else np.zeros(0)
    ok = np.isfinite(a_all) & (a_all > 0) & (l_all > 0)
    if not ok.any():
        return per, math.nan
    a_ok, l_ok = a_all[ok], l_all[ok]
    o = np.argsort(a_ok)
    c = np.cumsum(l_ok[o])
    return per, float(a_ok[o][min(int(np.searchsorted(c, c[-1] / 2)), len(o) - 1)])


def _local_deposit(
    per: list[tuple[Run, np.ndarray, np.ndarray]], med: float, width: float, rep: Report, s: PreflightSettings
) -> None:
    """Stretches longer than a bead width that lay far less or more metal per millimetre (wire
    feed / speed) than the program's length-weighted median (`feed_per_mm`: per run, med): a KRL
    weld begun at the travel's $VEL.CP (100 mm/s where the layer welds at 6-8: mpp-cross passed
    "ok"), a wire feed typed ten times too high. The part's balance hides a stretch. Zones vary the
    ratio (the shipped examples 0.30-1.73 of the median, compensate-deposit 0.3-1.6 of a zone's by
    default): `local_deposit_ok` (0.25-4) warns outside, `local_deposit_fail` (0.1-8) fails
    outside. One problem a layer."""
    if s.local_deposit == "off" or not math.isfinite(med):
        return
    lo, hi = s.local_deposit_ok
    flo, fhi = s.local_deposit_fail
    seen: set = set()
    for r, a, seg in per:
        x = a / med
        off = np.isfinite(x) & ((x < lo) | (x > hi)) & (seg > 0)
        if not off.any() or r.layer in seen:
            continue
        # the longest stretch of consecutive segments off the band, on one side of it
        side = np.where(off, np.where(x > hi, 1, -1), 0)
        cut = np.flatnonzero(np.diff(side)) + 1
        best: tuple[float, int, int] | None = None
        for k, j in zip(np.r_[0, cut], np.r_[cut, len(side)]):
            if side[k] and (best is None or float(seg[k:j].sum()) > best[0]):
                best = (float(seg[k:j].sum()), int(k), int(j))
        if best is None or best[0] <= width:
            continue
        length, k, j = best
        worst = float(np.min(x[k:j])) if x[k] < lo else float(np.max(x[k:j]))
        failing = not flo <= worst <= fhi
        sev = s.local_deposit if failing else "warn"
        limit = (flo if worst < lo else fhi) if failing else (lo if worst < lo else hi)
        speed, wfs = float(r.speed[k]), float(r.wfs[k])
        seen.add(r.layer)
        rep.problem(
            "local_deposit",
            sev,
            f"{length:.1f} mm of layer {r.layer} (section {r.section}) lay {worst:.2f}× the program's typical metal "
            f"per mm ({speed:.1f} mm/s at {wfs:.2f} m/min: {a[k] * 1000 / 60:.2f} mm of wire a mm of bead, typically "
            f"{med * 1000 / 60:.2f}): a bead {'thinner' if worst < 1 else 'thicker'} by that much; check the speed and "
            "the wire feed there (a weld begun before its welding speed is set keeps the travel's)",
            layer=r.layer,
            section=r.section,
            value=worst,
            limit=limit,
            point=r.points[k],
        )


def _starved(prog: ProgramRead, rep: Report, s: PreflightSettings) -> None:
    """Arc-ON moves commanded less wire feed than `s.wire_feed_min_m_min` (0 in a zone's parameters):
    the arc burns there with no wire, which the part's metal balance can hide when the zone is short."""
    if s.wire_feed_min == "off":
        return
    low = _flagged(prog, lambda r: np.isfinite(r.wfs) & (r.wfs < s.wire_feed_min_m_min))
    if not low:
        return
    count = sum(len(k) for _r, k in low)
    first, k = low[0]
    least = min(float(r.wfs[k].min()) for r, k in low)
    rep.problem(
        "wire_feed",
        s.wire_feed_min,
        f"{count} arc-ON motions are commanded as little as {least:.2f} m/min of wire feed, below "
        f"{s.wire_feed_min_m_min:g} m/min (first: layer {first.layer}, section {first.section}): the arc burns "
        "there without wire, depositing nothing; set the zone's wire_feed_speed",
        layer=first.layer,
        section=first.section,
        value=count,
        limit=s.wire_feed_min_m_min,
        point=first.points[int(k[0])],
    )


def _arc_runs(
    prog: ProgramRead, layers: list[tuple[int, list[Run]]], width: float, out: dict, rep: Report, s: PreflightSettings
) -> None:
    """The shortest arc-ON run (out, per layer) and the runs shorter than `min_arc_run_mm`."""
    min_run = s.min_arc_run_mm if s.min_arc_run_mm is not None else 2.0 * width
    lengths = [(r.length, r) for r in prog.runs]
    out["min_arc_run_mm"] = rounded(min(v for v, _ in lengths), 3)
    short = [(v, r) for v, r in lengths if v < min_run]
    for idx, runs in layers:
        rep.layer(idx)["min_arc_run_mm"] = rounded(min(r.length for r in runs), 3)
    if short:
        v, r = min(short, key=lambda t: t[0])
        rep.problem(
            "arc_run",
            "warn",
            f"{len(short)} arc-ON runs are shorter than {min_run:.1f} mm (shortest "
            f"{v:.2f} mm, layer {r.layer}, section {r.section}): arc flicker; bridge or drop them "
            "(sequence `min_arc_run_mm`)",
            layer=r.layer,
            section=r.section,
            value=v,
            limit=min_run,
            point=r.points[0],
        )


def _ignitions(
    part: Part | None,
    layers: list[tuple[int, list[Run]]],
    cov: Coverage | None,
    planar: bool,
    width: float,
    out: dict,
    rep: Report,
    s: PreflightSettings,
) -> None:
    """Ignitions: those in machining stock (outside the part, machined off: the thin-wall rule) may
    stack; those in the part must not (starts within a bead width of one on the layer below)."""
    spread = None
    stacked = []
    prev = None
    in_stock = 0
    all_starts = np.array([r.points[0] for _i, runs in layers for r in runs])
    if part is not None and part.kind == "solid" and cov and cov.get("sections"):
        # planar slabs: the section the coverage check cut for the start's layer (a 3D inside test on
        # a million-triangle mesh took 35 s of a 55 s run)
        start_layers = [idx for idx, runs in layers for _r in runs]
        all_inside = in_sections(cov["sections"], all_starts, start_layers)
    elif part is not None:
        all_inside = in_part(part, all_starts, width)
    else:
        all_inside = np.ones(len(all_starts), bool)
    offset = 0
    for idx, runs in layers:
        starts = all_starts[offset : offset + len(runs)]
        inside = all_inside[offset : offset + len(runs)]
        offset += len(runs)
        rep.layer(idx)["starts"] = np.round(starts, 3).tolist()
        rep.layer(idx)["stops"] = np.round(np.array([r.points[-1] for r in runs]), 3).tolist()
        in_stock += int(np.count_nonzero(~inside))
        if prev is not None and len(prev) and inside.any():
            diff = starts[inside][:, None, :] - prev[None, :, :]
            if planar:
                diff = diff[..., :2]
            d = np.linalg.norm(diff, axis=2).min(axis=1)
            spread = float(d.min()) if spread is None else min(spread, float(d.min()))
            kept = [r for r, ok in zip(runs, inside) if ok]
            for k in np.nonzero(d < width)[0]:
                stacked.append((idx, kept[k], float(d[k])))
        prev = starts[inside] if inside.any() else prev
    out["start_spread_mm"] = rounded(spread, 3)
    out["stacked_starts"] = len(stacked)
    out["starts_in_stock"] = in_stock
    if stacked and s.stacked_starts != "off":
        idx, r, d = stacked[0]
        rep.problem(
            "stacked_starts",
            s.stacked_starts,
            f"{len(stacked)} ignitions lie within one bead width ({width:g} mm) of an ignition on the "
            f"layer below (first: layer {idx}, section {r.section}, {d:.2f} mm away): stacked starts build "
            "humps and lack of fusion; stagger the seams (sequence `seam`; wall-path `seam` on walls, "
            "`tubular: scattered` on rings and tubes)",
            layer=idx,
            section=r.section,
            value=d,
            limit=width,
            point=r.points[0],
        )


STOCK_TOL_MM = 0.5  # an ignition farther than this outside the part is in machining stock


def in_sections(sections: dict, pts: np.ndarray, layer_of: list[int]) -> np.ndarray:
    """(n,) bool: each point (xy) lies in (or within STOCK_TOL_MM of) its layer's part section."""
    out = np.zeros(len(pts), bool)
    layer_arr = np.asarray(layer_of)
    for idx in np.unique(layer_arr):
        geom = sections.get(int(idx))
        k = np.nonzero(layer_arr == idx)[0]
        if geom is None or geom.is_empty:
            continue
        out[k] = shapely.distance(geom, shapely.points(pts[k][:, :2])) <= STOCK_TOL_MM
    return out


def in_part(part: Part, pts: np.ndarray, width: float) -> np.ndarray:
    """(n,) bool: the points lie in the part (a wall: on its midsurface, within STOCK_TOL_MM), not in
    the stock beyond it that is machined off."""
    if part.kind in ("midsurface", "region"):  # the wall's midsurface, or the 2D region: its distance
        geom = (
            MultiLineString([np.asarray(c)[:, :2] for c in part.curves])
            if part.kind == "midsurface"
            else unary_union([g for _z, _t, g in part.regions])
        )
        return shapely.distance(geom, shapely.points(np.asarray(pts)[:, :2])) <= STOCK_TOL_MM
    from ..geometry.proximity import TriangleBoxes, inside_closed, near_surface, worth_scanning

    vertices, faces = part.mesh()
    pts = np.asarray(pts, dtype=float)
    tol = STOCK_TOL_MM + width / 2.0 if part.kind == "surface" else STOCK_TOL_MM
    if worth_scanning(len(pts), len(faces)):  # a few ignitions: no r-tree of the whole mesh (4.4 s on 1M triangles)
        boxes = TriangleBoxes(vertices, faces)
        near = near_surface(boxes, pts, tol)
        return near if part.kind == "surface" else near | inside_closed(boxes, pts)
    import trimesh

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    _c, dist, _t = trimesh.proximity.closest_point(mesh, pts)
    return dist <= tol if part.kind == "surface" else mesh.contains(pts) | (dist <= tol)
