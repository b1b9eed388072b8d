"""Fill the zone-parameter XML from a bead model and targets (issue 16; MPP: "later, algorithms
may fill it").

For every layer > section > zone of a zoned toolpath, every parameter the user left empty gets a
value; values the user gave (in the toolpath's zone parameters, i.e. the zone node's XML, or in
an extra XML) are kept and reported beside what the model would have put there.

Rules (all parameters of `FillRules`):
- mass balance (issue #22 item 5): every body zone's wire feed is set so the metal that ends in
  the part, η·WFS·(π d²/4)/TS (d and η from the bead model), equals what the layer needs per mm
  of the section's path: layer height × the passes' step for overlapping passes, k·w·h for a
  single bead (process/mass.py; the step is `step_mm`, else measured on the path);
- body zones (`z1`, `z2`, ..., or the single unnamed zone): TS from the bead model for the target
  bead height (= layer height) and width, or the given travel speed; WFS from the mass balance;
- ignition zone `start` (ramp-in over the zone's length, set by the zone node's start_length):
  TS × start_ts_factor, WFS × start_wfs_factor, dwell start_dwell_s — the substrate is cold at
  ignition, so the bead is laid slower (the MPP study's example: zone 1 at 6 mm/s against zone 2
  at 8 mm/s → 0.75); equal factors keep the zone mass-balanced (the default), a larger wire
  factor over-feeds it;
- termination zone `end` (ramp-out over its length): TS × end_ts_factor, WFS × end_wfs_factor
  (MPP example zone 3 at 4 mm/s → 0.5) — heat has built up along the bead; a wire factor above
  the travel factor fills the crater with extra metal;
- current and voltage from a linear synergic line in WFS (I = i0 + i1·WFS, U = u0 + u1·WFS;
  default I = 55 + 15·WFS, U = 11 + 0.6·WFS: CMT steel 1.2 mm, about 100 A and 12.8 V at 3 m/min,
  205 A at 10 m/min as in the MPP example); `dwell` 0 outside ignition; `job` only when given.

The report states per section the step and metal per mm used, and per zone the feed ratio
(wire over need) of the values written — user values included, so a hand-set zone that
over- or under-feeds shows (`feed_ratio`, `unbalanced_zones`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from ..core.model import Layered
from ..core.process import PARAMETERS_BY_NAME
from ..zoning.params_xml import ZoneKey, _toolpath_zones, _write
from ..zoning.zones import apply_zone_params, zone_lengths
from .bead_fit import BeadFit
from .mass import section_deposit_per_mm, wfs_for

#: A zone whose wire over need is off by more than this share is reported as unbalanced.
BALANCE_TOLERANCE = 0.02


@dataclass(frozen=True)
class FillRules:
    """Targets (mm, mm/s) and zone rules; see the module doc."""

    height_mm: float | None = None  # None: each layer's thickness
    width_mm: float = 6.0
    travel_speed: float | None = None  # mm/s; set → this speed for body zones, else the model's
    start_ts_factor: float = 0.75
    start_wfs_factor: float = 0.75
    start_dwell_s: float = 0.5
    end_ts_factor: float = 0.5
    end_wfs_factor: float = 0.5
    current_line: tuple[float, float] = (55.0, 15.0)  # A, A per m/min
    voltage_line: tuple[float, float] = (11.0, 0.6)  # V, V per m/min
    job: float | None = None
    step_mm: float | None = None  # pass step (mm); None → each section path's own


def model_values(
    model: BeadFit, rules: FillRules, zone: str, layer_height: float, deposit_mm3_per_mm: float | None = None
) -> dict[str, float]:
    """What the rules give one zone of a layer of height `layer_height` (mm) that needs
    `deposit_mm3_per_mm` of metal per mm of path (default: a single bead, k·w·h)."""
    h = rules.height_mm or layer_height
    if deposit_mm3_per_mm is None:
        deposit_mm3_per_mm = model.shape_factor * rules.width_mm * h
    ts = rules.travel_speed if rules.travel_speed is not None else model.speeds_for(h, rules.width_mm)[1]
    wfs = wfs_for(deposit_mm3_per_mm, ts, model.wire_d, model.deposition_efficiency)
    dwell = 0.0
    if zone == "start":
        ts, wfs, dwell = ts * rules.start_ts_factor, wfs * rules.start_wfs_factor, rules.start_dwell_s
    elif zone == "end":
        ts, wfs = ts * rules.end_ts_factor, wfs * rules.end_wfs_factor
    out = {
        "wire_feed_speed": round(wfs, 3),
        "travel_speed": round(ts, 3),
        "dwell": dwell,
        "current": round(rules.current_line[0] + rules.current_line[1] * wfs, 1),
        "voltage": round(rules.voltage_line[0] + rules.voltage_line[1] * wfs, 2),
    }
    if rules.job is not None:
        out["job"] = rules.job
    for k, v in out.items():
        p = PARAMETERS_BY_NAME[k]
        out[k] = min(max(v, p.minimum), p.maximum)
    return out


def _ramp_lengths(layers: list[Any]) -> dict[str, list[float]]:
    """The lengths (mm) of every section's start and end zones, by zone name."""
    ramps: dict[str, list[float]] = {}
    for lp in layers:
        if lp is None:
            continue
        for sp in lp.sections:
            for z, length in (zone_lengths(sp) if sp.zone else {}).items():
                if z in ("start", "end"):
                    ramps.setdefault(z, []).append(length)
    return ramps


def fill(
    toolpath: Layered, model: BeadFit, rules: FillRules, user: dict[ZoneKey, dict[str, float]] | None = None
) -> tuple[Layered, str, dict]:
    """(toolpath with every zone's parameters filled, the filled XML text, report)."""
    user = dict(user or {})
    values: dict[ZoneKey, dict[str, float]] = {}
    beads: dict[ZoneKey, float] = {}
    kept, filled, out_of_range, sections, ratios = [], 0, [], [], []
    layers: list[Any] = []
    for lp in toolpath.items:
        if lp is None:
            layers.append(None)
            continue
        secs = []
        for sp in lp.sections:
            zp = {}
            need = step = None
            if sp.zone and sp.arc.any():
                need, step = section_deposit_per_mm(
                    sp, lp.layer, rules.width_mm, rules.step_mm, model.shape_factor, rules.height_mm
                )
                sections.append(
                    {
                        "layer": lp.index,
                        "section": sp.key,
                        "step_mm": None if step is None else round(step, 4),
                        "deposit_mm3_per_mm": round(need, 4),
                    }
                )
            for z in dict.fromkeys(sp.zone):
                key = (lp.index, sp.key, z)
                given = {**sp.zone_params.get(z, {}), **user.get(key, {})}
                mv = model_values(model, rules, z, float(lp.layer.thickness), need)
                if not model.in_range(mv["wire_feed_speed"], mv["travel_speed"]):
                    out_of_range.append(
                        {
                            "layer": lp.index,
                            "section": sp.key,
                            "zone": z,
                            "wire_feed_speed": mv["wire_feed_speed"],
                            "travel_speed": mv["travel_speed"],
                        }
                    )
                for name, v in given.items():
                    if name in mv and abs(mv[name] - v) > 1e-9:
                        kept.append(
                            {
                                "layer": lp.index,
                                "section": sp.key,
                                "zone": z,
                                "parameter": name,
                                "value": v,
                                "model_value": mv[name],
                            }
                        )
                vals = {**mv, **given}
                filled += len(set(mv) - set(given))
                values[key] = vals
                zp[z] = vals
                if need is not None:
                    beads[key] = need
                    r = model.wire_per_mm(vals["wire_feed_speed"], vals["travel_speed"]) / need
                    ratios.append({"layer": lp.index, "section": sp.key, "zone": z, "feed_ratio": round(r, 4)})
            secs.append(apply_zone_params(sp, zp))
        layers.append(replace(lp, sections=tuple(secs)))
    xml = _write(_toolpath_zones(layers), values, beads)
    ramps = _ramp_lengths(layers)
    report = {
        "filled_values": filled,
        "kept_user_values": kept,
        "kept_count": len(kept),
        "zones": len(values),
        "out_of_model_range": out_of_range[:200],
        "out_of_model_range_count": len(out_of_range),
        "ramp_lengths_mm": {z: {"min": round(min(v), 3), "max": round(max(v), 3)} for z, v in ramps.items()},
        "mass_balance": {
            "definition": "feed_ratio = eta * WFS * (pi d^2/4) / TS over the metal the layer needs per mm of path "
            "(layer height x pass step, or k * w * h for a single bead)",
            "wire_diameter_mm": model.wire_d,
            "deposition_efficiency": model.deposition_efficiency,
            "shape_factor_k": model.shape_factor,
            "width_mm": rules.width_mm,
            "feed_ratio": (
                {"min": min(r["feed_ratio"] for r in ratios), "max": max(r["feed_ratio"] for r in ratios)}
                if ratios
                else None
            ),
            "unbalanced_zones": [r for r in ratios if abs(r["feed_ratio"] - 1) > BALANCE_TOLERANCE][:200],
            "unbalanced_count": sum(abs(r["feed_ratio"] - 1) > BALANCE_TOLERANCE for r in ratios),
            "sections": sections[:500],
        },
        "rules": {k: (list(v) if isinstance(v, tuple) else v) for k, v in rules.__dict__.items()},
    }
    return Layered(tuple(layers)), xml, report
