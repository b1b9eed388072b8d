"""Interpass control: a per-layer lumped heat model and a minimum layer time set each layer's
dwell so the part is back under an interpass temperature before the next layer starts (issue 16;
curved-parts study: heat causes its 5.2 mm deviations; slicer users ask for minimum layer times).

Model (lumped capacitance, Incropera & DeWitt, Fundamentals of Heat and Mass Transfer, ch. 5.1:
valid while the Biot number h·t/k ≪ 1, e.g. 35 W/m²K × 6 mm / 40 W/mK ≈ 0.005 across a steel
wall). Assumptions, stated because they matter:

1. The deposited part plus an effective substrate mass (`substrate_mass_kg`) is one body at one
   temperature T. Its mass grows layer by layer (ρ × deposited volume, volume = bead cross
   section × arc-ON length, the cross-section being layer height × bead width × 2/3 for a
   parabolic bead — Ding et al. 2015).
2. Each layer adds η·P·t_arc of heat at once at the end of the layer (arc power P = U·I from the
   zones when both are set, else `arc_power_w`; arc efficiency η = 0.8 for GMAW/CMT, DuPont &
   Marder, Welding Journal 74 (1995) 406s). Cooling during deposition is neglected — the
   conservative side: the model's peak is higher than the real one.
3. Between layers the body cools by convection + linearised radiation (`h_w_m2k`, default
   35 W/m²K ≈ 10 convection + 25 radiation at 300-500 °C, ε 0.8) over its exposed surface (the
   layers' side walls, perimeter × height, plus the top layer's area) and conducts into the table
   through `base_conductance_w_k`: T − T_amb decays with τ = m·c / (h·A + G).
4. Interpass rule: the next layer starts only when T ≤ `interpass_c`; a minimum layer time
   (`min_layer_time_s`, arc time + travel + dwell) applies on top. The dwell is the larger of the
   two needs, minus the travel time the robot already spends between layers.

Units: SI inside the heat balance (kg, J, W, K), mm/s/°C at the edges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, NamedTuple

import numpy as np

from ..core.model import Layer, LayerPaths, Layered, SectionPath


@dataclass(frozen=True)
class HeatModel:
    interpass_c: float = 200.0  # °C, maximum temperature when a layer starts
    ambient_c: float = 20.0  # °C
    min_layer_time_s: float = 0.0  # s
    density_kg_m3: float = 7850.0  # steel
    specific_heat_j_kgk: float = 600.0  # steel, averaged 20-600 °C
    arc_efficiency: float = 0.8  # DuPont & Marder 1995 (GMAW)
    arc_power_w: float = 4000.0  # used where a zone has no current and voltage
    h_w_m2k: float = 35.0  # convection + linearised radiation
    base_conductance_w_k: float = 2.0  # conduction into the table/fixture
    substrate_mass_kg: float = 1.0  # effective substrate mass heated with the part
    bead_width_mm: float = 6.0
    travel_speed: float = 100.0  # mm/s, arc-OFF moves without a speed


class Spanning(NamedTuple):
    """A section welded through several layers' heights in one go (a helix): where it lies and
    how far it climbs along its layer's build direction."""

    layer: int
    section: str
    z_from: float
    z_to: float
    laps: int  # layers' heights it climbs, its first lap's included


def climb(sp: SectionPath, layer: Layer) -> Spanning | None:
    """The section as a `Spanning` when its arc-ON points climb more than 1.5 of its layer's
    thickness along the layer's build direction (a helix), else None."""
    arc = np.asarray(sp.arc, bool)
    if not arc.any() or not layer.thickness > 0:
        return None
    idx = np.unique(np.concatenate([np.flatnonzero(arc), np.flatnonzero(arc) + 1]))
    h = np.asarray(sp.points, float)[idx] @ layer.normal
    span = float(h.max() - h.min())
    if span <= 1.5 * layer.thickness:
        return None
    return Spanning(layer.index, sp.key, float(h.min()), float(h.max()), int(round(span / layer.thickness)) + 1)


def climbing_note(span: Spanning, what: str) -> str:
    """The warning of a per-layer process (`what` it cannot do) over a section that climbs."""
    return (
        f"section {span.section} climbs {span.laps} layers' heights in one go (a helix, {span.z_from:.1f} to "
        f"{span.z_to:.1f} mm): {what}; lay it layer by layer (wall-path `tubular: aligned` or `scattered`) where "
        "every layer needs it"
    )


def spanning_sections(toolpath: Layered) -> list[Spanning]:
    """The sections welded through several layers' heights in one go (`climb`): no dwell between
    layers falls inside them (their heat is one layer's), no treatment reaches their lower laps."""
    return [c for lp in toolpath.items if lp is not None for sp in lp.sections if (c := climb(sp, lp.layer))]


def layer_times(lp: LayerPaths, travel_speed: float) -> tuple[float, float]:
    """(arc-ON time s, arc-OFF time s) of one layer at programmed speeds."""
    t_on = t_off = 0.0
    for sp in lp.sections:
        L = sp.segment_lengths
        v = np.where(np.isfinite(sp.speed) & (sp.speed > 0), sp.speed, travel_speed)
        arc = np.asarray(sp.arc, bool)
        t_on += float((L[arc] / v[arc]).sum())
        t_off += float((L[~arc] / v[~arc]).sum())
        if sp.approach is not None and len(sp.approach):
            pts = np.vstack([sp.approach, sp.points[:1]])
            t_off += float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() / travel_speed)
    return t_on, t_off


def _arc_power(lp: LayerPaths, default_w: float) -> float:
    """Length-weighted arc power of the layer's zones (U·I where both are set), W."""
    num = den = 0.0
    for sp in lp.sections:
        L = sp.segment_lengths
        for j, z in enumerate(sp.zone or ()):
            if not sp.arc[j]:
                continue
            p = sp.zone_params.get(z, {})
            pw = p["current"] * p["voltage"] if p.get("current") and p.get("voltage") else default_w
            num += pw * L[j]
            den += L[j]
        if not sp.zone:
            la = float(L[np.asarray(sp.arc, bool)].sum())
            num += default_w * la
            den += la
    return num / den if den > 0 else default_w


def plan_dwells(toolpath: Layered, m: HeatModel) -> tuple[Layered, dict]:
    """Toolpath with `dwell_after_s` per layer (never below what it had) and the per-layer report."""
    if m.interpass_c <= m.ambient_c:
        raise ValueError(f"interpass temperature {m.interpass_c} °C must be above ambient {m.ambient_c} °C")
    items = [lp for lp in toolpath.items]
    mass = m.substrate_mass_kg
    lateral_m2 = 0.0
    T = m.ambient_c
    rows: list[Any] = []
    out: list[Any] = []
    for k, lp in enumerate(items):
        if lp is None:
            out.append(None)
            continue
        t_on, t_off = layer_times(lp, m.travel_speed)
        arc_len = sum(float(sp.segment_lengths[np.asarray(sp.arc, bool)].sum()) for sp in lp.sections)
        h_mm = float(lp.layer.thickness)
        vol_m3 = arc_len * h_mm * m.bead_width_mm * (2.0 / 3.0) * 1e-9
        mass += m.density_kg_m3 * vol_m3
        region = lp.layer.region
        # side walls: the layer outline × its height (a single-bead layer without a region: both bead flanks)
        lateral_m2 += (float(region.boundary.length) if not region.is_empty else 2.0 * arc_len) * h_mm * 1e-6
        top_m2 = float(region.area) * 1e-6
        power = _arc_power(lp, m.arc_power_w)
        T_peak = T + m.arc_efficiency * power * t_on / (mass * m.specific_heat_j_kgk)
        tau = mass * m.specific_heat_j_kgk / (m.h_w_m2k * (lateral_m2 + top_m2) + m.base_conductance_w_k)
        need_cool = (
            tau * math.log((T_peak - m.ambient_c) / (m.interpass_c - m.ambient_c)) if T_peak > m.interpass_c else 0.0
        )
        # the travel to the next layer's start (its approach) already cools the part
        nxt = items[k + 1] if k + 1 < len(items) else None
        t_next_travel = 0.0
        if nxt is not None and nxt.sections and nxt.sections[0].approach is not None:
            pts = np.vstack([nxt.sections[0].approach, nxt.sections[0].points[:1]])
            t_next_travel = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() / m.travel_speed)
        need_time = max(0.0, m.min_layer_time_s - (t_on + t_off)) if nxt is not None else 0.0
        need = max(need_cool - t_next_travel, need_time, 0.0) if nxt is not None else 0.0
        dwell = max(need, float(lp.dwell_after_s))
        T_next = m.ambient_c + (T_peak - m.ambient_c) * math.exp(-(dwell + t_next_travel) / tau)
        limited_by = (
            "none"
            if nxt is None
            else "existing"
            if dwell > need
            else "temperature"
            if need_cool - t_next_travel >= need_time and need_cool > 0
            else "min_layer_time"
            if need_time > 0
            else "none"
        )
        rows.append(
            {
                "layer": lp.index,
                "arc_time_s": round(t_on, 3),
                "travel_time_s": round(t_off, 3),
                "arc_power_w": round(power, 1),
                "mass_kg": round(mass, 4),
                "tau_s": round(tau, 2),
                "peak_c": round(T_peak, 2),
                "dwell_s": round(dwell, 3),
                "added_dwell_s": round(dwell - float(lp.dwell_after_s), 3),
                "start_next_c": round(T_next, 2) if nxt is not None else None,
                "limited_by": limited_by,
            }
        )
        out.append(
            replace(
                lp,
                dwell_after_s=dwell,
                dwell_note=dwell_note(limited_by, m, T_peak, T_next, lp.index) if dwell > 0 else lp.dwell_note,
            )
        )
        T = T_next
    report = {
        "interpass_c": m.interpass_c,
        "min_layer_time_s": m.min_layer_time_s,
        "total_dwell_s": round(sum(r["dwell_s"] for r in rows), 3),
        "total_added_dwell_s": round(sum(r["added_dwell_s"] for r in rows), 3),
        "max_peak_c": round(max((r["peak_c"] for r in rows), default=m.ambient_c), 2),
        "model": {k: v for k, v in m.__dict__.items()},
        "layers": rows,
    }
    return Layered(tuple(out)), report


def dwell_note(limited_by: str, m: HeatModel, peak_c: float, next_c: float, layer: int) -> str:
    """Why a layer dwells, for the program comment beside the dwell (ASCII: robot controllers)."""
    if limited_by == "temperature":
        return (
            f"interpass control: limit {m.interpass_c:g} degC, lumped heat model: part {peak_c:.0f} degC "
            f"after layer {layer}, {next_c:.0f} degC at the next layer's start"
        )
    if limited_by == "min_layer_time":
        return f"interpass control: minimum layer time {m.min_layer_time_s:g} s"
    return ""


def summary_report(report: dict) -> dict:
    """The part of the interpass report that summary.json states: per layer dwell, rule and
    temperatures; totals."""
    keys = ("layer", "dwell_s", "added_dwell_s", "limited_by", "peak_c", "start_next_c")
    return {
        "interpass_c": report["interpass_c"],
        "min_layer_time_s": report["min_layer_time_s"],
        "total_dwell_s": report["total_dwell_s"],
        "total_added_dwell_s": report["total_added_dwell_s"],
        "max_peak_c": report["max_peak_c"],
        "layers": [{k: r[k] for k in keys} for r in report["layers"]],
    }


def interpass_svg(report: dict) -> str:
    """The part's temperature over the build as the lumped model sees it: each layer's heat
    (drawn as a rise over the layer's arc + travel time; the model adds it at the layer's end),
    the exponential cooling after it, the dwells (shaded, labelled) and the interpass limit."""
    from .svgplot import Chart, caption, figure

    rows = report["layers"]
    amb = float(report.get("model", {}).get("ambient_c", 20.0))
    limit = float(report["interpass_c"])
    t, T = 0.0, amb
    segs, bands = [], []
    for r in rows:
        t_layer = r["arc_time_s"] + r["travel_time_s"]
        segs.append(([t, t + t_layer], [T, r["peak_c"]], "layer"))
        t += t_layer
        peak = r["peak_c"]
        if r["start_next_c"] is not None:
            nxt = r["start_next_c"]
            d = r["tau_s"] * math.log((peak - amb) / (nxt - amb)) if peak > nxt > amb else r["dwell_s"]
            if r["dwell_s"] > 0:
                bands.append((t, t + r["dwell_s"], r["dwell_s"]))
        else:  # after the last layer: cooling down to the limit, for reference
            nxt = min(peak, limit)
            d = r["tau_s"] * math.log((peak - amb) / (nxt - amb)) if peak > nxt > amb else 0.0
        ts = np.linspace(0.0, max(d, 0.0), 40)
        segs.append(
            (t + ts, amb + (peak - amb) * np.exp(-ts / r["tau_s"]), "last" if r["start_next_c"] is None else "cool")
        )
        t, T = t + max(d, 0.0), nxt
    t_end = max(t, 1.0)
    t_max = max([limit] + [r["peak_c"] for r in rows] + [amb + 1])
    ch = Chart(
        64,
        44,
        760,
        300,
        (0.0, t_end),
        (0.0, t_max * 1.08),
        x_label="build time, s",
        y_label="part temperature, °C",
        title=f"Interpass control: {len(rows)} layers, limit {limit:g} °C"
        + (f", minimum layer time {report['min_layer_time_s']:g} s" if report["min_layer_time_s"] else ""),
    )
    for a, b, dwell in bands:
        ch.span(a, b, "#dde6f0", label="dwell")
        if len(bands) <= 16:
            ch.text((a + b) / 2, t_max * 0.06, f"{dwell:.0f} s", anchor="middle", color="#1d3557", size=10)
    ch.hline(limit, "#555555", label=f"interpass limit {limit:g} °C")
    for xs, ys, kind in segs:
        ch.line(xs, ys, "#d62828" if kind == "layer" else "#1d3557", dash="4 3" if kind == "last" else "")
    ch.legend_items += [("layer deposited (heat)", "#d62828", "line"), ("cooling", "#1d3557", "line")]
    note = (
        f"total dwell {report['total_dwell_s']:.0f} s (added {report['total_added_dwell_s']:.0f} s); "
        f"peak {report['max_peak_c']:.0f} °C; lumped model: one body, η·U·I·t per layer, "
        f"convection + radiation + conduction to the table"
    )
    return figure(860, 400, [ch], [caption(64, 392, note)])
