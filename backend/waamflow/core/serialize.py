"""JSON forms of layers and toolpaths, exactly as in the contract's artifact files."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
from shapely.geometry import Polygon

from .model import Layer, LayerPaths, Layered, region_polygons

DECIMALS = 4  # 0.1 µm: below any machine resolution, keeps files small


def _r(x: float) -> float:
    return round(float(x), DECIMALS)


def coords(arr) -> list[list[float]]:
    a = np.round(np.asarray(arr, dtype=float), DECIMALS)
    return a.tolist()


def polygon_json(p: Polygon) -> dict:
    return {"exterior": coords(p.exterior.coords), "holes": [coords(h.coords) for h in p.interiors]}


def layer_json(layer: Layer) -> dict:
    out = {
        "index": layer.index,
        "z": _r(layer.z),
        "thickness": _r(layer.thickness),
        "area_mm2": _r(layer.area),
        "polygons": [polygon_json(p) for p in region_polygons(layer.region)],
        "curves": [coords(c.coords) for c in layer.curves],
    }
    if layer.frame is not None:
        out["frame"] = coords(layer.frame)
    return out


def layers_json(layers: Layered[Layer]) -> dict:
    return {"units": "mm", "layers": [layer_json(l) for l in layers if l is not None]}


def _num_list(a) -> list:
    r = np.round(np.asarray(a, float), DECIMALS)
    out = r.tolist()
    for i in np.flatnonzero(np.isnan(r)).tolist():   # NaN (no value) → null
        out[i] = None
    return out


def section_path_json(sp) -> dict[str, Any]:
    d: dict[str, Any] = {
        "key": sp.key,
        "strategy": sp.strategy,
        "points": coords(sp.points),
        "zone": list(sp.zone) if sp.zone else [""] * max(len(sp.points) - 1, 0),
        "arc": np.asarray(sp.arc, dtype=bool).tolist(),
        "inside": np.asarray(sp.inside, dtype=bool).tolist(),
        "speed": _num_list(sp.speed),
        "length_mm": _r(sp.length),
    }
    if sp.zone_colors:
        d["zone_colors"] = dict(sp.zone_colors)
    if sp.zone_params:
        d["zone_params"] = {k: dict(v) for k, v in sp.zone_params.items()}
    if sp.approach is not None:
        d["approach"] = coords(sp.approach)
    if sp.tool_axis is not None:
        d["tool_axis"] = coords(sp.tool_axis)
    if sp.tool:
        d["tool"] = sp.tool
        d["tool_params"] = {k: _r(v) for k, v in sp.tool_params.items()}
    return d


def toolpath_json(toolpath: Layered[LayerPaths]) -> dict:
    layers = []
    for lp in toolpath:
        if lp is None:
            continue
        layers.append({
            "index": lp.index,
            "z": _r(lp.layer.z),
            "dwell_after_s": _r(lp.dwell_after_s),
            **({"dwell_note": lp.dwell_note} if lp.dwell_note else {}),
            "sections": [section_path_json(sp) for sp in lp.sections],
        })
    return {"units": "mm", "layers": layers}


def dumps(obj: Any) -> str:
    """Compact, stable JSON for artifacts."""
    return json.dumps(obj, separators=(",", ":"), allow_nan=False)
