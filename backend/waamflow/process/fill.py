"""Fill the zone-parameter XML from a bead model and targets (issue 16; MPP: "later, algorithms
may fill it").

For every layer > section > zone of a zoned toolpath, every parameter the user left empty gets a
value; values the user gave (in the toolpath's zone parameters, i.e. the zone node's XML, or in
an extra XML) are kept and reported beside what the model would have put there.

Rules (all parameters of `FillRules`):
- body zones (`z1`, `z2`, ..., or the single unnamed zone): (WFS, TS) from the bead model for the
  target bead height (= layer height) and width, or WFS for the height at a given travel speed;
- ignition zone `start` (ramp-in over the zone's length, set by the zone node's start_length):
  TS × start_ts_factor, WFS × start_wfs_factor, dwell start_dwell_s — the substrate is cold at
  ignition, so the bead is laid slower; defaults from the MPP study's example (zone 1 TS 6 mm/s,
  WFS 10 m/min against zone 2 TS 8 mm/s, WFS 12 m/min → 0.75 and 0.83);
- termination zone `end` (ramp-out over its length): TS × end_ts_factor, WFS × end_wfs_factor
  (MPP example zone 3: TS 4 mm/s, WFS 10 m/min → 0.5 and 0.83) — heat has built up along the
  bead and the crater must be filled without a hump;
- current and voltage from a linear synergic line in WFS (I = i0 + i1·WFS, U = u0 + u1·WFS;
  the default current line passes through the MPP example's 200 A at 10 and 210 A at 12 m/min);
  `dwell` 0 outside ignition; `job` only when a job number is given.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..core.model import Layered
from ..core.process import PARAMETERS_BY_NAME
from ..zoning.params_xml import ZoneKey, _toolpath_zones, _write
from ..zoning.zones import apply_zone_params, zone_lengths
from .bead_fit import BeadFit


@dataclass(frozen=True)
class FillRules:
    """Targets (mm, mm/s) and zone rules; see the module doc."""

    height_mm: float | None = None        # None: each layer's thickness
    width_mm: float = 6.0
    travel_speed: float | None = None     # mm/s; set → WFS from the height at this speed
    start_ts_factor: float = 0.75
    start_wfs_factor: float = 0.83
    start_dwell_s: float = 0.5
    end_ts_factor: float = 0.5
    end_wfs_factor: float = 0.83
    current_line: tuple[float, float] = (150.0, 5.0)    # A, A per m/min
    voltage_line: tuple[float, float] = (14.0, 0.5)     # V, V per m/min
    job: float | None = None


def model_values(model: BeadFit, rules: FillRules, zone: str, layer_height: float) -> dict[str, float]:
    """What the rules give one zone of a layer of height `layer_height` (mm)."""
    h = rules.height_mm or layer_height
    if rules.travel_speed is not None:
        ts = rules.travel_speed
        wfs = model.wfs_for(h, ts)
    else:
        wfs, ts = model.speeds_for(h, rules.width_mm)
    dwell = 0.0
    if zone == "start":
        ts, wfs, dwell = ts * rules.start_ts_factor, wfs * rules.start_wfs_factor, rules.start_dwell_s
    elif zone == "end":
        ts, wfs = ts * rules.end_ts_factor, wfs * rules.end_wfs_factor
    out = {"wire_feed_speed": round(wfs, 3), "travel_speed": round(ts, 3), "dwell": dwell,
           "current": round(rules.current_line[0] + rules.current_line[1] * wfs, 1),
           "voltage": round(rules.voltage_line[0] + rules.voltage_line[1] * wfs, 2)}
    if rules.job is not None:
        out["job"] = rules.job
    for k, v in out.items():
        p = PARAMETERS_BY_NAME[k]
        out[k] = min(max(v, p.minimum), p.maximum)
    return out


def fill(toolpath: Layered, model: BeadFit, rules: FillRules,
         user: dict[ZoneKey, dict[str, float]] | None = None) -> tuple[Layered, str, dict]:
    """(toolpath with every zone's parameters filled, the filled XML text, report)."""
    user = dict(user or {})
    values: dict[ZoneKey, dict[str, float]] = {}
    kept, filled, out_of_range = [], 0, []
    layers = []
    for lp in toolpath.items:
        if lp is None:
            layers.append(None)
            continue
        secs = []
        for sp in lp.sections:
            zp = {}
            for z in dict.fromkeys(sp.zone):
                key = (lp.index, sp.key, z)
                given = {**sp.zone_params.get(z, {}), **user.get(key, {})}
                mv = model_values(model, rules, z, float(lp.layer.thickness))
                if not model.in_range(mv["wire_feed_speed"], mv["travel_speed"]):
                    out_of_range.append({"layer": lp.index, "section": sp.key, "zone": z,
                                         "wire_feed_speed": mv["wire_feed_speed"], "travel_speed": mv["travel_speed"]})
                for name, v in given.items():
                    if name in mv and abs(mv[name] - v) > 1e-9:
                        kept.append({"layer": lp.index, "section": sp.key, "zone": z, "parameter": name,
                                     "value": v, "model_value": mv[name]})
                vals = {**mv, **given}
                filled += len(set(mv) - set(given))
                values[key] = vals
                zp[z] = vals
            secs.append(apply_zone_params(sp, zp))
        layers.append(replace(lp, sections=tuple(secs)))
    xml = _write(_toolpath_zones(layers), values)
    ramps = {}
    for lp in layers:
        if lp is None:
            continue
        for sp in lp.sections:
            for z, length in (zone_lengths(sp) if sp.zone else {}).items():
                if z in ("start", "end"):
                    ramps.setdefault(z, []).append(length)
    report = {
        "filled_values": filled, "kept_user_values": kept, "kept_count": len(kept),
        "zones": len(values), "out_of_model_range": out_of_range[:200], "out_of_model_range_count": len(out_of_range),
        "ramp_lengths_mm": {z: {"min": round(min(v), 3), "max": round(max(v), 3)} for z, v in ramps.items()},
        "rules": {k: (list(v) if isinstance(v, tuple) else v) for k, v in rules.__dict__.items()},
    }
    return Layered(tuple(layers)), xml, report
