"""Interpass dwell from a measured temperature: the cell measures the part after a layer (a
pyrometer or thermocouple reading posted with the layer's scan); the next layer's program waits
until the part is back at the target interpass temperature.

The cooling is the project's lumped heat model (`waamflow.process.interpass`): the deposited part
plus an effective substrate mass is one body that cools towards ambient with the time constant
τ = m·c / (h·A + G) of the layers built so far (m, A grow layer by layer; `plan_dwells` reports τ
per layer). From a measured T_m after layer k the part reaches the target T_t after

    t = τ_k · ln((T_m − T_amb) / (T_t − T_amb))      (0 when T_m ≤ T_t)

less the travel to the next layer's start (the part cools during it too), clamped to
[0, `max_dwell_s`] (a clamp is reported). The model's own heat input is not used: the measured
temperature replaces the model's prediction of the peak.

Units: °C, s.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from ..core.model import LayerPaths, Layered
from ..process.interpass import HeatModel, plan_dwells

MIN_TEMP_C = -50.0  # a measured temperature outside this range is refused (a sensor fault)
MAX_TEMP_C = 2000.0
MAX_DWELL_S = 1800.0  # default upper clamp: half an hour


@dataclass(frozen=True)
class DwellRule:
    """The heat model (its `interpass_c` is the target) and the largest dwell a program may hold."""

    model: HeatModel = HeatModel()
    max_dwell_s: float = MAX_DWELL_S
    source: str = "default heat model"  # where the model came from (a recipe node, the request)

    def to_dict(self) -> dict:
        return {
            "target_c": self.model.interpass_c,
            "ambient_c": self.model.ambient_c,
            "max_dwell_s": self.max_dwell_s,
            "source": self.source,
            "model": asdict(self.model),
        }

    @classmethod
    def from_dict(cls, d: dict | None) -> "DwellRule":
        if not d:
            return cls()
        return cls(HeatModel(**d["model"]), float(d["max_dwell_s"]), str(d.get("source", "")))


def check_temperature(value: float, field: str = "interpass_temp_c") -> float:
    """A measured temperature, or ValueError naming `field` (NaN, infinite, < −50 or > 2000 °C)."""
    v = float(value)
    if not math.isfinite(v) or not MIN_TEMP_C <= v <= MAX_TEMP_C:
        raise ValueError(
            f"{field} = {value} °C is not a plausible part temperature "
            f"(expected a number from {MIN_TEMP_C:g} to {MAX_TEMP_C:g} °C)"
        )
    return v


def heat_model_of(params, interpass_c: float | None = None) -> HeatModel:
    """The `HeatModel` of an interpass node's params (`nodes.process.Interpass.Params`)."""
    return HeatModel(
        interpass_c=params.interpass_c if interpass_c is None else interpass_c,
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


def time_constants(items: list[LayerPaths], model: HeatModel) -> list[float]:
    """τ (s) of the part after each layer of `items` (the heat model's, see module doc)."""
    _, report = plan_dwells(Layered(tuple(items)), model)
    return [float(r["tau_s"]) for r in report["layers"]]


def approach_time(lp: LayerPaths, travel_speed: float) -> float:
    """Seconds of the travel to `lp`'s first section start (its approach), at `travel_speed`."""
    if not lp.sections or lp.sections[0].approach is None or not len(lp.sections[0].approach):
        return 0.0
    pts = np.vstack([lp.sections[0].approach, lp.sections[0].points[:1]])
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() / travel_speed)


def interpass_dwell(measured_c: float, tau_s: float, rule: DwellRule, travel_s: float = 0.0) -> dict:
    """The dwell (s) before the next layer from the temperature measured after the layer before
    (see module doc), with everything that went into it."""
    m = rule.model
    t_m = check_temperature(measured_c)
    if t_m > m.interpass_c:
        need = tau_s * math.log((t_m - m.ambient_c) / (m.interpass_c - m.ambient_c)) - travel_s
    else:
        need = 0.0
    dwell = min(max(need, 0.0), rule.max_dwell_s)
    return {
        "measured_c": round(t_m, 2),
        "target_c": m.interpass_c,
        "ambient_c": m.ambient_c,
        "tau_s": round(tau_s, 2),
        "travel_s": round(travel_s, 3),
        "needed_s": round(max(need, 0.0), 3),
        "dwell_s": round(dwell, 3),
        "clamped": need > rule.max_dwell_s,
    }


def note(d: dict, layer: int) -> str:
    """Why the program waits (ASCII: robot controllers)."""
    s = (
        f"interpass: part measured {d['measured_c']:g} degC after layer {layer}, target {d['target_c']:g} degC: "
        f"wait {d['dwell_s']:.1f} s (lumped heat model, tau {d['tau_s']:.0f} s)"
    )
    return s + (f", clamped from {d['needed_s']:.0f} s" if d["clamped"] else "")


def with_dwell_before(lp: LayerPaths, seconds: float, why: str) -> Layered:
    """The one-layer toolpath `lp` starting with a wait of `seconds` (an empty layer before it
    whose dwell-after is the wait: the posts write it as the interlayer dwell at the first point)."""
    if seconds <= 0:
        return Layered((lp,))
    return Layered((replace(lp, sections=(), dwell_after_s=float(seconds), dwell_note=why), lp))
