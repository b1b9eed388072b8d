"""A small SVG chart writer for the process plots (bead fit, deposit per mm, interpass history,
layer plan): axes with round-number ticks, grid, polylines, points, shaded spans, polygons and a
legend. Hand-written SVG keeps the server free of a plotting stack; the same files show in the
GUI's Results tab and convert to PNG for the README (scripts/process_plots.py).
"""

from __future__ import annotations

import math
from html import escape
from typing import Sequence

import numpy as np


def nice_ticks(lo: float, hi: float, n: int = 5) -> list[float]:
    """About n round-number ticks (1, 2, 2.5, 5 × 10^k steps) covering [lo, hi]."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo]
    raw = (hi - lo) / max(n, 1)
    mag = 10 ** math.floor(math.log10(raw))
    # the round step whose tick count is nearest n (ties: the larger step)
    step = min((m * mag for m in (10, 5, 2.5, 2, 1)), key=lambda st: abs((hi - lo) / st - n))
    first = math.ceil(lo / step - 1e-9) * step
    return [round(first + k * step, 10) for k in range(int((hi - first) / step + 1e-9) + 1)]


def _fmt(v: float) -> str:
    return f"{v:g}" if abs(v) < 1e6 else f"{v:.3g}"


class Chart:
    """One panel: data ranges map onto a plot box at (left, top) of size (w, h) pixels.
    `equal=True` keeps one data unit the same length on both axes (plans)."""

    def __init__(
        self,
        left: float,
        top: float,
        w: float,
        h: float,
        x_range: tuple[float, float],
        y_range: tuple[float, float],
        *,
        title: str = "",
        x_label: str = "",
        y_label: str = "",
        equal: bool = False,
        ticks: bool = True,
        legend: str = "right",
    ) -> None:
        (x0, x1), (y0, y1) = x_range, y_range
        if x1 <= x0:
            x1 = x0 + 1.0
        if y1 <= y0:
            y1 = y0 + 1.0
        if equal:  # widen the smaller span so both axes share one scale, centred
            sx, sy = w / (x1 - x0), h / (y1 - y0)
            s = min(sx, sy)
            cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
            x0, x1 = cx - w / s / 2, cx + w / s / 2
            y0, y1 = cy - h / s / 2, cy + h / s / 2
        self.left, self.top, self.w, self.h = left, top, w, h
        self.x0, self.x1, self.y0, self.y1 = x0, x1, y0, y1
        self.title, self.x_label, self.y_label, self.ticks = title, x_label, y_label, ticks
        self.legend = legend
        self.body: list[str] = []
        self.legend_items: list[tuple[str, str, str]] = []  # (label, color, kind)

    def px(self, x) -> np.ndarray:
        return self.left + self.w * (np.asarray(x, float) - self.x0) / (self.x1 - self.x0)

    def py(self, y) -> np.ndarray:
        return self.top + self.h - self.h * (np.asarray(y, float) - self.y0) / (self.y1 - self.y0)

    def _pts(self, xs, ys) -> str:
        # one % over all points (Python floats) instead of an f-string per numpy scalar: same text
        xy = np.column_stack([self.px(xs), self.py(ys)]).ravel().tolist()
        return ("%.1f,%.1f " * (len(xy) // 2) % tuple(xy))[:-1]

    def line(
        self,
        xs,
        ys,
        color: str,
        *,
        width: float = 1.4,
        dash: str = "",
        label: str = "",
        clip: bool = True,
        opacity: float = 1.0,
    ) -> None:
        ys = np.clip(np.asarray(ys, float), self.y0, self.y1) if clip else ys
        d = f' stroke-dasharray="{dash}"' if dash else ""
        o = f' stroke-opacity="{opacity}"' if opacity < 1 else ""
        self.body.append(
            f'<polyline fill="none" stroke="{color}" stroke-width="{width}"{d}{o} '
            f'stroke-linejoin="round" stroke-linecap="round" points="{self._pts(xs, ys)}"/>'
        )
        if label:
            self.legend_items.append((label, color, "line"))

    def points(self, xs, ys, color: str, *, r: float = 3.0, label: str = "") -> None:
        for a, b in zip(self.px(xs), self.py(ys)):
            self.body.append(f'<circle cx="{a:.1f}" cy="{b:.1f}" r="{r}" fill="{color}"/>')
        if label:
            self.legend_items.append((label, color, "point"))

    def hline(self, y: float, color: str, *, dash: str = "5 3", label: str = "") -> None:
        self.line([self.x0, self.x1], [y, y], color, width=1.0, dash=dash, label=label)

    def span(self, x_a: float, x_b: float, color: str, *, label: str = "", opacity: float = 1.0) -> None:
        a, b = float(self.px(x_a)), float(self.px(x_b))
        self.body.append(
            f'<rect x="{a:.1f}" y="{self.top:.1f}" width="{max(b - a, 0.5):.1f}" height="{self.h:.1f}" '
            f'fill="{color}" fill-opacity="{opacity}"/>'
        )
        if label and not any(lb == label for lb, _, _ in self.legend_items):
            self.legend_items.append((label, color, "box"))

    def polygon(
        self, rings: list[np.ndarray], color: str, *, stroke: str = "none", opacity: float = 1.0, label: str = ""
    ) -> None:
        """A polygon with holes (first ring the shell), even-odd filled."""
        d = " ".join(
            "M" + " L".join(f"{a:.2f},{b:.2f}" for a, b in zip(self.px(r[:, 0]), self.py(r[:, 1]))) + " Z"
            for r in rings
            if len(r) >= 3
        )
        if d:
            self.body.append(
                f'<path d="{d}" fill="{color}" fill-opacity="{opacity}" fill-rule="evenodd" '
                f'stroke="{stroke}" stroke-width="0.8"/>'
            )
        if label and not any(lb == label for lb, _, _ in self.legend_items):
            self.legend_items.append((label, color, "box"))

    def text(self, x: float, y: float, s: str, *, color: str = "#222", anchor: str = "start", size: int = 11) -> None:
        self.body.append(
            f'<text x="{float(self.px(x)):.1f}" y="{float(self.py(y)):.1f}" fill="{color}" '
            f'text-anchor="{anchor}" font-size="{size}">{escape(s)}</text>'
        )

    def render(self) -> list[str]:
        L, T, W, H = self.left, self.top, self.w, self.h
        out = [
            f'<defs><clipPath id="c{int(L)}_{int(T)}"><rect x="{L}" y="{T}" width="{W}" height="{H}"/></clipPath></defs>'
        ]
        if self.ticks:
            for v in nice_ticks(self.x0, self.x1, max(3, int(W // 90))):
                p = float(self.px(v))
                out.append(f'<line x1="{p:.1f}" y1="{T}" x2="{p:.1f}" y2="{T + H}" stroke="#e5e5e5"/>')
                out.append(f'<text x="{p:.1f}" y="{T + H + 14}" text-anchor="middle" fill="#444">{_fmt(v)}</text>')
            for v in nice_ticks(self.y0, self.y1, max(3, int(H // 45))):
                p = float(self.py(v))
                out.append(f'<line x1="{L}" y1="{p:.1f}" x2="{L + W}" y2="{p:.1f}" stroke="#e5e5e5"/>')
                out.append(f'<text x="{L - 5}" y="{p + 4:.1f}" text-anchor="end" fill="#444">{_fmt(v)}</text>')
        out.append(f'<g clip-path="url(#c{int(L)}_{int(T)})">')
        out += self.body
        out.append("</g>")
        out.append(f'<rect x="{L}" y="{T}" width="{W}" height="{H}" fill="none" stroke="#444"/>')
        if self.title:
            out.append(f'<text x="{L}" y="{T - 8}" font-weight="bold">{escape(self.title)}</text>')
        if self.x_label:
            out.append(f'<text x="{L + W / 2:.1f}" y="{T + H + 30}" text-anchor="middle">{escape(self.x_label)}</text>')
        if self.y_label:
            out.append(
                f'<text transform="translate({L - 42},{T + H / 2:.1f}) rotate(-90)" '
                f'text-anchor="middle">{escape(self.y_label)}</text>'
            )
        x = (
            L + W - 8
            if self.legend == "right"
            else L + 40 + 6.2 * max((len(lb) for lb, _, _ in self.legend_items), default=0)
        )
        for k, (label, color, kind) in enumerate(self.legend_items):
            y = T + 14 + 15 * k
            if kind == "line":
                mark = f'<line x1="{x - 22}" y1="{y - 4}" x2="{x - 4}" y2="{y - 4}" stroke="{color}" stroke-width="2"/>'
            elif kind == "point":
                mark = f'<circle cx="{x - 12}" cy="{y - 4}" r="3.5" fill="{color}"/>'
            else:
                mark = f'<rect x="{x - 20}" y="{y - 10}" width="14" height="10" fill="{color}" stroke="#888" stroke-width="0.5"/>'
            out.append(
                f'<rect x="{x - 30 - 6.2 * len(label)}" y="{y - 12}" width="{30 + 6.2 * len(label)}" '
                f'height="15" fill="#fff" fill-opacity="0.85"/>'
            )
            out.append(mark + f'<text x="{x - 28}" y="{y}" text-anchor="end">{escape(label)}</text>')
        return out


def figure(width: int, height: int, charts: list[Chart], extra: Sequence[str] = ()) -> str:
    """An SVG document holding the charts (and extra SVG elements, e.g. a caption)."""
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="11">',
        f'<rect width="{width}" height="{height}" fill="#fff"/>',
    ]
    for c in charts:
        out += c.render()
    out += list(extra)
    out.append("</svg>")
    return "\n".join(out)


def caption(x: float, y: float, s: str, size: int = 11) -> str:
    return f'<text x="{x}" y="{y}" fill="#333" font-size="{size}">{escape(s)}</text>'


def layer_plan_svg(
    regions: list,
    paths: list[tuple[np.ndarray, np.ndarray]],
    voids: list,
    overlaps: list,
    strokes: list[np.ndarray],
    title: str,
    note: str = "",
) -> str:
    """One layer seen from above (layer-local mm): section outlines, the deposition path (arc on
    solid, arc off dotted), coverage voids (red) and overlaps (dark), and treatment strokes."""
    import shapely

    def rings(poly) -> list[np.ndarray]:
        return [np.asarray(poly.exterior.coords)] + [np.asarray(h.coords) for h in poly.interiors]

    polys = [p for g in regions for p in shapely.get_parts(g) if not p.is_empty]
    xy = np.vstack([np.asarray(p.exterior.coords) for p in polys] + [pts[:, :2] for pts, _ in paths])
    lo, hi = xy.min(axis=0) - 4.0, xy.max(axis=0) + 4.0
    ch = Chart(
        60,
        40,
        640,
        640,
        (float(lo[0]), float(hi[0])),
        (float(lo[1]), float(hi[1])),
        equal=True,
        title=title,
        x_label="x, mm",
        y_label="y, mm",
    )
    for p in polys:
        ch.polygon(rings(p), "#f4f1de", stroke="#888888", label="section")
    for g, color, label, op in ((voids, "#d62828", "void", 0.85), (overlaps, "#264653", "overlap (2+ passes)", 0.75)):
        for p in (q for geom in g for q in shapely.get_parts(geom) if not q.is_empty):
            ch.polygon(rings(p), color, opacity=op, label=label)
    for st in strokes:  # under the path: wide and pale, as wide as a roller looks next to the bead
        ch.line(st[:, 0], st[:, 1], "#2a9d8f", width=5.0, clip=False, opacity=0.45)
        ch.points(st[:1, 0], st[:1, 1], "#1b6f66", r=2.5)
    if strokes:
        ch.legend_items.append(("rolling stroke (dot: start)", "#2a9d8f", "line"))
    for pts, arc in paths:
        on = np.asarray(arc, bool)
        # contiguous arc-on runs solid, arc-off links dotted
        edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):
            ch.line(pts[a : b + 1, 0], pts[a : b + 1, 1], "#e76f51", width=1.1, clip=False)
        for k in np.flatnonzero(~on):
            ch.line(pts[k : k + 2, 0], pts[k : k + 2, 1], "#777777", width=0.8, dash="2 2", clip=False)
    ch.legend_items.append(("torch path, arc on", "#e76f51", "line"))
    return figure(720, 730 if note else 715, [ch], [caption(60, 722, note)] if note else [])
