"""The preflight's `uncovered` problem: how much of the part no bead reaches, and why (check.py
measures it, slab by slab or by 3D samples)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .check import Coverage, Part
    from .report import Report
    from .settings import PreflightSettings


def uncovered_problem(part: Part, cov: Coverage, top_gap: float | None, rep: Report, s: PreflightSettings) -> None:
    """The `uncovered` problem: how much of the part no bead reaches, its worst layer, and where
    the most of it is (in no layer's section, on horizontal faces, in skipped layers)."""
    share = cov["uncovered_share"]
    if cov.get("seen_share") == 0.0 and rep.layers and share > s.uncovered_fail:  # no section holds any of it
        rep.problem("uncovered", "fail", unseen_part(part, rep), value=share, limit=s.uncovered_fail)
    elif share > s.uncovered_warn:
        sev = "fail" if share > s.uncovered_fail else "warn"
        worst = max(
            (L for L in rep.layers.values() if L.get("uncovered_share") is not None),
            key=lambda L: L["uncovered_share"],
            default=None,
        )
        where = ""
        if worst is not None and worst["uncovered_share"] > 0:
            where = (
                f"; worst layer {worst['index']}: {worst['uncovered_share'] * 100:.1f} % "
                + (f"({worst['uncovered_mm2']:.0f} mm²) " if worst.get("uncovered_mm2") is not None else "")
                + "without a bead"
            )
        # the layers reach the part's top, yet most of what no bead reaches lies outside every
        # section, more than the warning's share on its own: features thinner than a layer between
        # mid-planes, which no plan of them reaches (a slanted side's sections miss far less: the
        # midpoint rule, h²/24 of the section area's curvature)
        between = 1.0 - cov.get("seen_share", 1.0) if top_gap is not None and top_gap <= 1e-6 else 0.0
        skipped = cov.get("skipped_share", 0.0)
        between -= skipped  # a skipped layer's slab is not "between mid-planes"
        if skipped >= 0.5 * share:
            what = (
                f"{share * 100:.1f} % of the part gets no bead, {skipped * 100:.1f} % of the part in the layers "
                f"the program skips (skipped_layers){where}"
            )
        elif between >= 0.5 * share and between > s.uncovered_warn:
            what = (
                f"{share * 100:.1f} % of the part gets no bead: {between * 100:.1f} % of the part's volume is in no "
                "layer's mid-plane section (a feature thinner than a layer between two layers' mid-planes, such "
                "as a fin or a flange), so no plan of these layers covers it; finer layers (the slice's layer "
                f"height) would cut it{where}"
            )
        elif cov.get("uncovered_flat_share", 0.0) >= 0.5 * share:
            flat = cov.get("uncovered_flat_share", 0.0)
            what = (
                f"{share * 100:.1f} % of the part gets no bead{where}; {flat * 100:.1f} % of the part is horizontal "
                "faces of the surface (caps, flanges, overhangs), which no planar layer cuts and walls do not "
                "build: build them in another direction (fan-slice on a positioner), as solids, or add them after"
            )
        else:
            what = f"{share * 100:.1f} % of the part gets no bead{where}: add a mask section or a filling pattern there"
        rep.problem(
            "uncovered",
            sev,
            what,
            layer=worst["index"] if worst else None,
            value=share,
            limit=s.uncovered_fail if sev == "fail" else s.uncovered_warn,
            point=(worst or {}).get("uncovered_point"),
        )


def unseen_part(part: Part, rep: Report) -> str:
    """The message when no layer's mid-plane cuts the part (every section empty): the slabs
    measure nothing, so "100 % gets no bead" would blame the plan for what the layers cannot see
    (trimesh's octagonal_pocket.stl read as mm: 0.016 mm tall, one 0.75 mm layer cut at
    0.375 mm): planar slabs whose sections hold none of the part's volume (`seen_share` 0)."""
    rows = list(rep.layers.values())
    mids = sorted(L["z"] - L["height_mm"] / 2 for L in rows if L.get("z") is not None and L.get("height_mm"))
    planes = ", ".join(f"{z:.3f}" for z in mids[:3]) + (", …" if len(mids) > 3 else "")
    height = part.top - part.bottom
    return (
        f"no layer's mid-plane cuts the part: it spans z {part.bottom:.3f}–{part.top:.3f} mm ({height:.3g} mm tall) "
        f"and the layers are cut at z {planes} mm, so no layer sees it. Check the mesh node's 'units' "
        "(a part in m or in read as mm is tiny) or a layer height larger than the part"
    )
