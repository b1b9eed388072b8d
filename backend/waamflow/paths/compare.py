"""Compare fill patterns on the same sections: what an engineer weighs when choosing a strategy.

Per pattern: programmed length (mm), arc-ON length (mm), arc switches (ignitions + extinctions:
each brings the robot to a full stop, robot study), length outside the sections and its share,
time at the programmed speed (s; a lower bound — stops and corners add to it, see simulate-robot),
and the bead coverage at the spec's bead width (`waamflow.process.coverage`): void area (section
left bare), overlap area (deposited twice or more) and over-deposit (metal outside the section), mm².
"""

from __future__ import annotations

import math
from html import escape as _html_escape
from dataclasses import dataclass
from typing import Any, Iterable, Sequence

import numpy as np
from shapely.geometry import LineString, Polygon

from ..process.coverage import section_coverage
from .registry import PATTERNS, plan_section
from .spec import StrategySpec


def escape(text: str) -> str:
    """&, < and > escaped for SVG text, as xml.sax.saxutils.escape does (that module imports
    urllib.request, http and ssl: ~15 ms of every CLI run's start)."""
    return _html_escape(text, quote=False)


COVERAGE_KEYS = ("void_area_mm2", "overlap_area_mm2", "over_deposit_area_mm2", "region_area_mm2")


@dataclass(frozen=True)
class Job:
    """One section to fill: region (layer-local polygon, mm), guide, spec, programmed speed (mm/s)."""

    region: Polygon
    guide: LineString | None
    spec: StrategySpec
    speed: float


def parse_variant(text: str) -> tuple[str, dict]:
    """'triangular:60' → ('triangular', {'angle_deg': 60.0}); 'raster' → ('raster', {})."""
    name, _, arg = text.partition(":")
    if name not in PATTERNS:
        raise ValueError(f"unknown pattern {name!r} in compare; known: {', '.join(sorted(PATTERNS))}")
    if not arg:
        return name, {}
    angle = float(arg)
    if not 0.0 < angle < 180.0:
        raise ValueError(f"compare {text!r}: angle must be in (0, 180) degrees")
    return name, {"angle_deg": angle}


def compare(jobs: Sequence[Job], variants: Iterable[str]) -> list[dict]:
    """One row per variant (see module doc), summed over all jobs."""
    rows = []
    for text in variants:
        name, extra = parse_variant(text)
        per = []
        for job in jobs:
            spec = type(job.spec).model_validate({**job.spec.model_dump(), "pattern": name, **extra})
            p = plan_section(job.region, job.guide, spec)
            m = path_metrics(p.segment_lengths, p.arc, p.inside, np.full(len(p.arc), job.speed))
            cov = section_coverage(job.region, p.points, p.arc, spec.bead_width)
            m.update(
                void_area_mm2=cov.void_area,
                overlap_area_mm2=cov.overlap_area,
                over_deposit_area_mm2=cov.over_deposit_area,
                region_area_mm2=cov.region_area,
            )
            per.append(m)
        row: dict[str, Any] = {"pattern": name, "label": text}
        for key in (
            "programmed_length_mm",
            "arc_on_length_mm",
            "arc_switches",
            "outside_length_mm",
            "time_s",
            *COVERAGE_KEYS,
        ):
            row[key] = round(sum(m[key] for m in per), 3)
        total = row["programmed_length_mm"]
        row["outside_share"] = round(row["outside_length_mm"] / total, 4) if total > 0 else 0.0
        rows.append(row)
    return rows


def path_metrics(lengths, arc, inside, speed) -> dict:
    """Metrics of one planned path from its per-segment arrays: lengths (mm), arc, inside (bool),
    speed (mm/s)."""
    lengths = np.asarray(lengths, dtype=float)
    arc = np.asarray(arc, dtype=bool)
    inside = np.asarray(inside, dtype=bool)
    a = np.concatenate([[False], arc, [False]])
    total = float(lengths.sum())
    outside = float(lengths[~inside].sum())
    return {
        "programmed_length_mm": round(total, 3),
        "arc_on_length_mm": round(float(lengths[arc].sum()), 3),
        "arc_switches": int(np.count_nonzero(a[1:] != a[:-1])),
        "outside_length_mm": round(outside, 3),
        "outside_share": round(outside / total, 4) if total > 0 else 0.0,
        "time_s": round(float((lengths / np.asarray(speed, dtype=float)).sum()), 3),
    }


METRICS = (
    ("programmed_length_mm", "Programmed length", "mm"),
    ("arc_switches", "Arc switches (full stops)", ""),
    ("outside_share", "Share of path outside", "%"),
    ("time_s", "Time at programmed speed", "s"),
    ("void_area_mm2", "Void area (bare)", "mm²"),
    ("overlap_area_mm2", "Overlap area (twice or more)", "mm²"),
)


def comparison_json(rows: list[dict], sections: int, layers: int) -> dict:
    best = {}
    for key, _, _ in METRICS:
        if rows:
            low = min(r[key] for r in rows)
            best[key] = [r["label"] for r in rows if r[key] == low]
    return {
        "sections": sections,
        "layers": layers,
        "patterns": rows,
        "lowest": best,
        "units": {
            "programmed_length_mm": "mm",
            "arc_on_length_mm": "mm",
            "outside_length_mm": "mm",
            "outside_share": "1",
            "time_s": "s",
            "arc_switches": "count",
            **{k: "mm²" for k in COVERAGE_KEYS},
        },
    }


def comparison_svg(rows: list[dict], selected: str | None = None) -> str:
    """A small hand-written SVG: one panel of horizontal bars per metric, one bar per pattern; bars
    of the `selected` pattern (the one the toolpath uses) are drawn darker."""
    label_w, bar_w, row_h, pad = 120, 220, 16, 10
    gap = 90  # room for the value printed after the longest bar
    panel_h = 22 + row_h * max(len(rows), 1)
    cols = 2
    width = cols * (label_w + bar_w + gap) + pad
    height = math.ceil(len(METRICS) / cols) * (panel_h + pad) + pad
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'font-family="sans-serif" font-size="11">',
        f'<rect width="{width}" height="{height}" fill="#ffffff"/>',
    ]
    for m, (key, title, unit) in enumerate(METRICS):
        x0 = pad + (m % cols) * (label_w + bar_w + gap)
        y0 = pad + (m // cols) * (panel_h + pad)
        out.append(f'<text x="{x0}" y="{y0 + 12}" font-weight="bold">{escape(title)}</text>')
        values = [float(r[key]) * (100.0 if unit == "%" else 1.0) for r in rows]
        top = max(values + [1e-12])
        for i, (r, v) in enumerate(zip(rows, values)):
            y = y0 + 20 + i * row_h
            w = bar_w * v / top
            text = f"{v:.1f}" if unit in ("mm", "s", "%", "mm²") else f"{v:.0f}"
            out.append(f'<text x="{x0}" y="{y + 11}">{escape(r["label"])}</text>')
            fill = "#b85c00" if r["pattern"] == selected else "#f8961e"
            out.append(f'<rect x="{x0 + label_w}" y="{y + 2}" width="{w:.1f}" height="{row_h - 4}" fill="{fill}"/>')
            out.append(f'<text x="{x0 + label_w + w + 4:.1f}" y="{y + 11}">{text} {escape(unit)}</text>')
    out.append("</svg>")
    return "\n".join(out)
