"""The preflight's `hole` check: one place of one layer that no bead reaches, large enough to be a
defect whatever the rest of the part gets.

The part's uncovered share is a share of the whole part: 34 % of one of the bracket's 300 layers
(six moves of a serpentine deleted, the torch cutting straight across five passes) is 0.05 % of the
part, and half a layer welded arc OFF is 0.07 %; both programs passed "ok". A layer's uncovered
places are measured one by one instead:

- **a solid's layer** (planar slabs): the slab's section less the beads' footprint, opened by a
  quarter of a bead width (shrunk and grown again: the slivers beads leave in corners and between
  touching passes go, a place at least half a bead wide stays); its largest piece;
- **a wall, or a solid built in fan layers** (3D samples of its midsurface or boundary,
  `samples.wall_cover`): the layer's uncovered samples joined where they lie within 1.5 sample
  spacings, each cluster's area the samples' share of the surface (a column through the layers,
  such as a crossing's centre left void, is a place on each layer, not one; a fan's places are
  joined across its layers, whose wedges name a sample's layer less surely).

A place's size is said in bead widths of bead: the bead length that would cover it over a bead
width (a slab's area / width²; a wall's area / (layer height × width)). Beyond `hole_warn_widths`
it is a warning, beyond `hole_fail_widths` a failure (`hole`: off, warn or fail), one problem per
severity naming the largest place, its layer, section and point, and how many layers have one.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .read import Run
    from .report import Report
    from .settings import PreflightSettings

#: Uncovered samples of a wall within this many sample spacings of each other are one place.
JOIN_SPACINGS = 1.5


def wall_holes(
    samples: np.ndarray,
    unc: np.ndarray,
    lay: np.ndarray,
    cell_mm2: float,
    spacing: float,
    flat: np.ndarray | None = None,
    by_layer: bool = True,
) -> dict[int, tuple[float, np.ndarray, bool]]:
    """Layer → (area mm², a sample inside it, whether most of it is horizontal faces (`flat`)) of its
    largest cluster of uncovered samples (joined within JOIN_SPACINGS sample spacings; `by_layer`:
    only samples of one layer, `lay`, else all, each cluster given to the layer most of it is
    given to: a fan's wedge layers name an uncovered sample's layer less surely than layers that
    go straight up, and one place came out split over four)."""
    idx = np.flatnonzero(unc)
    if not len(idx):
        return {}
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pts = samples[idx]
    pairs = cKDTree(pts).query_pairs(JOIN_SPACINGS * spacing, output_type="ndarray")
    if len(pairs) and by_layer:  # a place is one layer's: a column through the layers (a crossing's centre) is many
        pairs = pairs[lay[idx[pairs[:, 0]]] == lay[idx[pairs[:, 1]]]]
    n = len(idx)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)) if len(pairs) else None
    if graph is None:
        labels = np.arange(n)
    else:
        labels = connected_components(graph, directed=False)[1]
    out: dict[int, tuple[float, np.ndarray, bool]] = {}
    order = np.argsort(labels, kind="stable")
    cuts = np.flatnonzero(np.diff(labels[order])) + 1
    for members in np.split(order, cuts):
        layers, counts = np.unique(lay[idx[members]], return_counts=True)
        layer = int(layers[np.argmax(counts)])
        area = len(members) * cell_mm2
        if layer not in out or area > out[layer][0]:
            centre = pts[members].mean(axis=0)
            inside = pts[members][np.argmin(np.linalg.norm(pts[members] - centre, axis=1))]
            on_flat = flat is not None and float(np.mean(flat[idx[members]])) > 0.5
            out[layer] = (area, inside, on_flat)
    return out


def _section_at(runs: list[Run], point: tuple[float, ...]) -> str | None:
    """The section of the run passing nearest to a point (x, y[, z]) of its layer."""
    best, name = math.inf, None
    p = np.asarray(point[:2], dtype=float)
    for r in runs:
        if len(r.points):
            d = float(np.min(np.linalg.norm(r.points[:, :2] - p, axis=1)))
            if d < best:
                best, name = d, r.section
    return name


def hole_problems(
    layers: list[tuple[int, list[Run]]], width: float, height: float | None, rep: Report, s: PreflightSettings
) -> None:
    """The `hole` problems from the layers' `hole_mm2` figures (a wall's measured on `height`, the
    layer spacing; a slab's on its own width): one per severity, the largest place named."""
    if s.hole == "off" or width <= 0:
        return
    runs_of = dict(layers)
    found = []
    for idx, L in rep.layers.items():
        area = L.get("hole_mm2") or 0.0
        if area <= 0:
            continue
        across = width if L.get("hole_kind") == "slab" else (height or 0.0)
        if across <= 0:
            continue
        widths = area / (across * width)
        L["hole_widths"] = round(widths, 2)
        if widths > s.hole_warn_widths:
            found.append((widths, idx, area, L))
    for kind in ("fail", "warn", "flat"):
        if kind == "flat":
            these = [f for f in found if f[3].get("hole_flat")]
        else:
            these = [f for f in found if not f[3].get("hole_flat") and (f[0] > s.hole_fail_widths) == (kind == "fail")]
        if not these:
            continue
        widths, idx, area, L = max(these, key=lambda f: f[0])
        point = L.get("hole_point")
        section = _section_at(runs_of.get(idx, []), point) if point is not None else None
        more = f"; {len(these) - 1} more layers have such a place" if len(these) > 1 else ""
        where = f" at ({point[0]:.1f}, {point[1]:.1f}, {point[2]:.1f})" if point is not None else ""
        wall = L.get("hole_kind") == "wall"
        what = (
            "moves missing there, the arc switched off early or on late, a mask or pattern that leaves it out"
            + (", or a wall that moves across by more than its bead reaches from one layer to the next" if wall else "")
            + "; whatever the rest of the part gets, a layer with a place like this builds a void"
            if kind != "flat"
            else "it is a horizontal face of the surface (a cap, a flange, an overhang), which no planar layer cuts "
            "and walls do not build: build it in another direction (fan-slice on a positioner), as a solid, or "
            "add it after"
        )
        rep.problem(
            "hole",
            s.hole if kind == "fail" else "warn",
            f"{area:.0f} mm² of the part{where} gets no bead, {widths:.1f} bead widths of bead ({widths * width:.0f} "
            f"mm of a {width:.1f} mm bead){more}: {what}",
            layer=idx,
            section=section,
            value=widths,
            limit=s.hole_fail_widths if kind == "fail" else s.hole_warn_widths,
            point=point,
        )
