"""Cutter-location (CL) file as CSV: one row per toolpath point, in part coordinates.

Columns: x, y, z (mm); i, j, k (unit tool axis, torch → part); speed_mm_s, arc (1/0), layer,
section, zone — those of the move that *arrives* at the point (the first row, where the machine
starts, has an empty speed and arc 0); dwell_s — dwell at the point before moving on. Travel
rows have an empty speed (machine travel speed) and an empty zone. Then the weld values of that
move's zone where it states them (empty otherwise): wire_feed_speed_m_min, current_a, voltage_v,
job — a CL file hands the weld on to the downstream post with the path, not only as a zone name.
"""

from __future__ import annotations

import csv
import io

import numpy as np

from ..core.moves import Moves
from .common import num

WELD_COLUMNS = (
    ("wire_feed_speed", "wire_feed_speed_m_min"),
    ("current", "current_a"),
    ("voltage", "voltage_v"),
    ("job", "job"),
)
COLUMNS = (
    "x",
    "y",
    "z",
    "i",
    "j",
    "k",
    "speed_mm_s",
    "arc",
    "layer",
    "section",
    "zone",
    "dwell_s",
    *(c for _name, c in WELD_COLUMNS),
)


def write_cl_csv(moves: Moves, decimals: int = 4) -> str:
    """Render `Moves` as CSV text (see module doc)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    n = len(moves.points)
    for i in range(n):
        p, t = moves.points[i], moves.tool_axis[i]
        seg = i - 1 if i > 0 else (0 if n > 1 else -1)
        weld = [""] * len(WELD_COLUMNS)
        layer: int | str  # "" on the first row of a one-point program
        if seg < 0:
            speed, arc, layer, section, zone = "", 0, "", "", ""
        else:
            sp = float(moves.speed[seg])
            speed = num(sp, 3) if i > 0 and np.isfinite(sp) else ""
            arc = int(bool(moves.arc[seg])) if i > 0 else 0
            layer = int(moves.layer[seg])
            section = moves.section_keys[int(moves.section[seg])]
            z = int(moves.zone[seg])
            zone = moves.zone_ids[z] if (i > 0 and 0 <= z < len(moves.zone_ids)) else ""
            if arc:
                params = moves.zone_params.get((int(moves.section[seg]), z), {})
                weld = [
                    num(float(params[name]), 3) if params.get(name) is not None else "" for name, _c in WELD_COLUMNS
                ]
        w.writerow(
            [
                num(p[0], decimals),
                num(p[1], decimals),
                num(p[2], decimals),
                num(t[0], 6),
                num(t[1], 6),
                num(t[2], 6),
                speed,
                arc,
                layer,
                section,
                zone,
                num(moves.dwell_before[i], 3),
                *weld,
            ]
        )
    return buf.getvalue()
