"""Programs that are tables: the cutter-location CSV, compas print points and the toolpath JSON
(recipes that write no program)."""

from __future__ import annotations

import json
import math

import numpy as np

from .core import ProgramRead, RunBuilder


def read_cl_csv(text: str) -> ProgramRead:
    lines = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    head = lines[0].split(",")
    col = {h.strip(): i for i, h in enumerate(head)}
    b = RunBuilder("csv")
    wfs_col = next((c for c in ("wire_feed_speed_m_min", "wire_feed_speed", "wfs_m_min") if c in col), None)
    weld_cols = [c for c in (wfs_col, "current_a", "voltage_v", "job") if c and c in col]
    if wfs_col is None:
        b.out.weld_commanded = False
        b.out.notes.append("the CL file has no wire feed column")
    arc_prev = False
    for ln, row in enumerate(lines[1:], start=2):
        f = row.split(",")
        p = np.array([float(f[col["x"]]), float(f[col["y"]]), float(f[col["z"]])])
        arc = f[col["arc"]].strip() in ("1", "true", "True")
        b.layer = int(f[col["layer"]]) if f[col["layer"]].strip() else b.layer
        b.section = f[col["section"]] or b.section
        if arc and not arc_prev:
            b.arc_on(ln)
        if not arc and arc_prev:
            b.close()
        sp = f[col["speed_mm_s"]].strip()
        w = f[col[wfs_col]].strip() if wfs_col else ""
        b.move(
            p[None],
            float(sp) if sp else math.nan,
            float(w) if w else math.nan,
            any(f[col[c]].strip() for c in weld_cols),
        )
        arc_prev = arc
    b.close()
    return b.out


def read_printpoints(text: str) -> ProgramRead:
    """compas_slicer's print points as a driver runs them (program/printpoints.py): move to the
    point (its `velocity`; its `layer` and `section` are the motion's), set the arc to its
    `extruder_toggle` (the motion leaving the point), wait its `wait_time` (metal in one spot
    while the toggle is on)."""
    data = json.loads(text)
    entries = (
        data
        if isinstance(data, list)
        else [data[k] for k in sorted(data, key=lambda s: int(s))]
        if all(str(k).isdigit() for k in data)
        else data.get("points", [])
    )
    b = RunBuilder("printpoints")
    b.out.weld_commanded = any("wire_feed_speed" in e for e in entries)
    for i, e in enumerate(entries):
        p = np.asarray(e["point"], float)
        b.layer = e.get("layer", b.layer)
        b.section = e.get("section", b.section)
        w = e.get("wire_feed_speed")
        wfs = float(w) if w is not None else math.nan
        b.move(p[None], float(e.get("velocity") or math.nan), wfs, w is not None)
        on = b.pts is not None
        if e.get("extruder_toggle") and not on:
            nxt = entries[i + 1] if i + 1 < len(entries) else e  # the run is the next motions' layer and section
            b.layer, b.section = nxt.get("layer", b.layer), nxt.get("section", b.section)
            b.arc_on(i)
        elif not e.get("extruder_toggle") and on:
            b.close()
        b.dwell(float(e.get("wait_time") or 0.0), wfs)
    b.close()
    return b.out


def read_toolpath(doc: dict) -> ProgramRead:
    """A `<node>.toolpath.json` for recipes that write no program: the arc-ON runs and the zone
    parameters in force (weld data as the toolpath states it)."""
    b = RunBuilder("toolpath")
    for layer in doc.get("layers", []):
        b.layer = layer.get("index")
        for sec in layer.get("sections", []):
            b.section = sec.get("key")
            pts = np.asarray(sec.get("points", []), float)
            arcs = sec.get("arc", [])
            speeds = sec.get("speed", [])
            zones = sec.get("zone", [])
            zp = sec.get("zone_params", {})
            if len(pts) == 0:
                continue
            b.close()
            b.pos = pts[0].copy()
            for i in range(len(pts) - 1):
                if arcs[i] and b.pts is None:
                    b.arc_on(0)
                elif not arcs[i] and b.pts is not None:
                    b.close()
                params = zp.get(zones[i], {}) if i < len(zones) else {}
                w = params.get("wire_feed_speed")
                speed = float(v) if i < len(speeds) and (v := speeds[i]) is not None else math.nan  # null: not stated
                wfs = float(w) if w is not None else math.nan
                # a point of a run under way without move's arrays (27,000 on the 500-layer cross:
                # 0.13 of the read-back's 0.16 s, on a parallel run's critical path)
                if not b.extend(pts[i + 1], speed, wfs, bool(params)):
                    b.move(pts[i + 1][None], speed, wfs, bool(params))
            b.close()
    b.out.weld_commanded = False
    return b.out
