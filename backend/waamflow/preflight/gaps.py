"""Deposited layers with no deposit below them where the part has metal: skipped layers.

The planar coverage check gives each deposited layer the slab from the layer below it to its own
top. A plan that deposits nothing on some layers (every run of a thin shaft's contour shorter than
the sequence's `min_arc_run_mm`, dropped; a mask that misses them) left one slab as tall as the
layers it skipped: libigl's screwdriver at 4 mm layers had layers 24-39 empty, and layer 40 was
checked as a 68 mm slab whose mid-plane its bead covered: the program passed (exit 0) with
`uncovered_share` 0.0 and 64 mm of the shaft without metal. Now a slab taller than
`layer_gap_warn_layers` typical layer heights is a problem (a `fail` beyond
`layer_gap_fail_layers`), and such a slab counts as covered one typical layer high, so the
uncovered share holds the metal the skipped layers lack. The first slab (from the part's bottom) is the
`top_gap`/coverage checks' as before.
"""

from __future__ import annotations

from typing import NamedTuple, Sequence

import numpy as np

from .report import Report
from .settings import PreflightSettings


class Gap(NamedTuple):
    """A deposited layer (`layer`, top `z`) whose slab down to the deposited layer below
    (`below`, top `z_below`) is `height` mm tall where layers are typically `typical` mm; the
    part's section at the slab's middle is `area` mm²."""

    layer: int
    below: int
    z_below: float
    z: float
    height: float
    typical: float
    area: float


def typical_height(bottom: float, tops: Sequence[float], indices: Sequence[int] | None = None) -> float | None:
    """The median height (mm) of a layer: of the slabs under the deposited layers' tops, each
    divided by the number of layers its program numbers span (`indices`, the layer numbers the
    program states: a slab under a layer numbered 3 above the last holds 3 planned layers); None
    without layers. Without the numbers the median slab was the layer height, and a program missing
    every other pair of layers read as one of 4 mm layers with none missing (3MF Consortium's
    dodeca_chain_loop.3mf, 2 mm layers; layers 0, 3, 4, 7 deposited)."""
    if not len(tops):
        return None
    heights = np.diff([bottom, *tops])
    if indices is not None and len(tops) > 1:
        steps = np.diff(np.asarray(indices, dtype=float))
        if np.all(steps >= 1):  # numbered in build order: the slabs above the first, per layer
            return float(np.median(heights[1:] / steps))
    return float(np.median(heights))


def covered_height(k: int, height: float, typical: float | None, s: PreflightSettings) -> float:
    """How much of slab k's height its layer's bead covers: all of it for the first slab and for
    slabs up to `layer_gap_warn_layers` typical heights; one typical layer height of a taller one
    (a skipped layer's: the bead builds one layer, not the ones skipped)."""
    if k == 0 or not typical or typical <= 0 or height <= s.layer_gap_warn_layers * typical + 1e-6:
        return height
    return typical


def slab_gaps(
    indices: Sequence[int], tops: Sequence[float], bottom: float, areas: Sequence[float], s: PreflightSettings
) -> list[Gap]:
    """The deposited layers (after the first) whose slab is taller than `layer_gap_warn_layers`
    typical heights where the part has metal at the slab's middle (`areas`, mm²)."""
    typical = typical_height(bottom, tops, indices)
    if not typical or typical <= 0:
        return []
    out = []
    for k in range(1, len(tops)):
        h = tops[k] - tops[k - 1]
        if h > s.layer_gap_warn_layers * typical + 1e-6 and areas[k] > 0:
            out.append(Gap(indices[k], indices[k - 1], tops[k - 1], tops[k], h, typical, areas[k]))
    return out


def gap_problems(gaps: list[Gap], rep: Report, s: PreflightSettings) -> None:
    """The skipped layers as one problem per severity (the tallest gap named, the others counted);
    each gap's layer gets `gap_below_mm` in the report's layer figures."""
    for g in gaps:
        rep.layer(g.layer)["gap_below_mm"] = round(g.height - g.typical, 3)
    for sev in ("fail", "warn"):
        these = [g for g in gaps if (g.height > s.layer_gap_fail_layers * g.typical + 1e-6) == (sev == "fail")]
        if not these:
            continue
        g = max(these, key=lambda g: g.height)
        skipped = max(1, round(g.height / g.typical) - 1)
        more = f" ({len(these) - 1} more such gaps)" if len(these) > 1 else ""
        rep.problem(
            "skipped_layers",
            sev,
            f"nothing is deposited between layer {g.below} (top {g.z_below:.2f} mm) and layer {g.layer} "
            f"(top {g.z:.2f} mm){more}: {g.height - g.typical:.1f} mm of the part ({g.area:.0f} mm² in section), "
            f"about {skipped} layer{'s' if skipped != 1 else ''} of {g.typical:.2f} mm, get no bead, and layer "
            f"{g.layer} would be welded {g.height:.1f} mm above the deposit below it. The plan skipped or emptied "
            "those layers: see the warnings of the nodes before (a sequence drops arc runs shorter than its "
            "min_arc_run_mm; a mask or strategy may leave a narrow feature without a path)",
            layer=g.layer,
            value=g.height / g.typical,
            limit=(s.layer_gap_fail_layers if sev == "fail" else s.layer_gap_warn_layers),
            point=None,
        )
