"""The study's programs (da Silva Viola et al. 2023, robot-study.md): objective-rectangle paths.

Used to calibrate the shipped KUKA profile and to validate the model against the study's other
measurements. Built as ordinary toolpaths (`SectionPath` → `flatten`), the same interface the
simulate-robot node receives.

OR of width W × length L (mm) in the plane z = `z`; passes along x (length L), spaced W_WB.
Pass layout (robot-study.md, "Objective rectangle"): n = floor(W / W_WB); W_bound =
(W − (n − 1)·W_WB)/2; if W_bound > 0.4·W_WB: n += 1 and recompute. Small OR → n = 5,
W_bound = 1.89 mm; large OR → n = 10, W_bound = 1.57 mm.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.model import Layer, LayerPaths, Layered, SectionPath
from ..core.moves import Moves, flatten

SMALL_OR = (21.5, 43.0)  # W, L mm
LARGE_OR = (43.0, 86.0)
W_WB = 4.43  # pass spacing, mm


def pass_layout(width: float, spacing: float = W_WB) -> tuple[int, float]:
    """(number of passes, W_bound mm) per the study's rule."""
    n = int(math.floor(width / spacing))
    bound = (width - (n - 1) * spacing) / 2
    if bound > 0.4 * spacing:
        n += 1
        bound = (width - (n - 1) * spacing) / 2
    return n, bound


def _moves(points, arc, inside, speed, key, z=50.0) -> Moves:
    pts = np.column_stack([np.asarray(points, float), np.full(len(points), z)])
    sp = SectionPath(
        key=key,
        strategy=key,
        points=pts,
        arc=np.asarray(arc, bool),
        inside=np.asarray(inside, bool),
        speed=np.asarray(speed, float),
    )
    layer = Layer(index=0, z=z, thickness=1.5)
    return flatten(Layered((LayerPaths(layer, (sp,)),)))


def raster(speed: float, size=SMALL_OR, spacing: float = W_WB) -> Moves:
    """Raster-pass: every pass +x, arc ON; arc-OFF diagonal return to the next pass start."""
    W, L = size
    n, b = pass_layout(W, spacing)
    pts = []
    for i in range(n):
        y = b + i * spacing
        pts += [(0.0, y), (L, y)]
    m = len(pts) - 1
    arc = np.arange(m) % 2 == 0
    return _moves(pts, arc, np.ones(m, bool), np.full(m, speed), "raster")


def _boustrophedon_with_links(speed, size, spacing, link, arc_outside: bool, key) -> Moves:
    W, L = size
    n, b = pass_layout(W, spacing)
    pts = [(0.0, b)]
    inside: list[bool] = []
    for i in range(n):
        y = b + i * spacing
        fwd = i % 2 == 0
        pts.append((L, y) if fwd else (0.0, y))
        inside.append(True)
        if i < n - 1:
            x_edge = L if fwd else 0.0
            out = 1.0 if fwd else -1.0
            for p in link(x_edge, y, out):
                pts.append(p)
                inside.append(False)
    ins = np.asarray(inside, bool)
    arc = ins | arc_outside
    return _moves(pts, arc, ins, np.full(len(ins), speed), key)


def triangular(
    speed: float, angle_deg: float = 45.0, arc_outside: bool = True, size=SMALL_OR, spacing: float = W_WB
) -> Moves:
    """Boustrophedon linked outside the OR by an isosceles triangle (base W_WB, apex angle θ)."""
    h = (spacing / 2) / math.tan(math.radians(angle_deg) / 2)

    def link(x, y, out):
        return [(x + out * h, y + spacing / 2), (x, y + spacing)]

    return _boustrophedon_with_links(speed, size, spacing, link, arc_outside, f"triangular{angle_deg:g}")


def semicircular(
    speed: float, arc_outside: bool = True, size=SMALL_OR, spacing: float = W_WB, chord_mm: float = 0.5
) -> Moves:
    """Boustrophedon linked outside the OR by half circles of diameter W_WB (G1-smooth)."""
    r = spacing / 2
    k = max(4, int(math.ceil(math.pi * r / chord_mm)))

    def link(x, y, out):
        ang = np.linspace(-math.pi / 2, math.pi / 2, k + 1)[1:]
        return [(x + out * r * math.cos(a), y + r + r * math.sin(a)) for a in ang]

    return _boustrophedon_with_links(speed, size, spacing, link, arc_outside, "semicircular")


def swiping(speed: float, size=SMALL_OR, spacing: float = W_WB, advance: float = 1.0 / 3.0) -> Moves:
    """The study's swiping on any OR: the product's swiping strategy (`waamflow.paths.swiping`).

    Derived from the study's description only (a dense zig-zag with many bead overlaps that stays
    inside the OR), for every OR size: legs along the passes, W_WB/2 short of each end; each leg
    advances `advance`·W_WB across the band between the first and last pass centre lines,
    ceil(band / (advance·W_WB)) legs. Small OR: 12 legs, 463.18 mm (study 464.246 mm, −0.23 %),
    reversals at 4.4°; large OR: 27 legs of 81.6 mm. The study's other swiping figure, a 2.95°
    reversal, cannot hold together with its 464 mm on a zig-zag covering the passes (see
    `paths.swiping`); the 2.95° corner errors are checked on `reversals` instead."""
    return planned("swiping", speed, size=size, spacing=spacing, swipe_advance=advance)


def reversals(speed: float, interior_deg: float = 2.95, size=SMALL_OR, spacing: float = W_WB) -> Moves:
    """A corner test: a zig-zag over the OR's pass band with reversals at `interior_deg`.

    Legs run along the OR's length L, W_WB/2 short of each end (as the swiping's), and advance
    ℓ·tan(interior/2) across each, from the first pass centre line for as many legs as stay
    within the band of the passes — every reversal has the measured interior angle (the study's
    2.95° corner errors: 0.8 mm at 10 mm/s, 1.8 mm at 40 mm/s), whatever the OR size."""
    W, L = size
    n, b = pass_layout(W, spacing)
    ell = L - spacing
    delta = ell * math.tan(math.radians(interior_deg) / 2)
    legs = max(2, int(math.floor((n - 1) * spacing / delta + 1e-9)))
    x0 = spacing / 2
    pts = [(x0 + (ell if i % 2 else 0.0), b + i * delta) for i in range(legs + 1)]
    m = len(pts) - 1
    return _moves(pts, np.ones(m, bool), np.ones(m, bool), np.full(m, speed), "reversals")


def straight_line(speed: float, length: float = 100.0) -> Moves:
    """A single arc-ON straight line (the study's 100 mm line)."""
    return _moves([(0.0, 0.0), (length, 0.0)], [True], [True], [speed], "line")


# the study's calibration table (40 mm/s, small OR) — robot-study.md
CALIBRATION = {
    "raster": {
        "total_time_s": 11.580,
        "actual_length_mm": 386.971,
        "deposited_volume_mm3": 615.133,
        "programmed_length_mm": 387.910,
    },
    "swiping": {
        "total_time_s": 12.036,
        "actual_length_mm": 411.509,
        "deposited_volume_mm3": 1134.389,
        "programmed_length_mm": 464.246,
    },
}

# identified kinematic parameters of the triangular 45° case, small OR (robot-study.md)
IDENTIFIED = {
    (10, "on"): dict(
        T_init_accel=0.144,
        L_init_accel=0.617,
        L_decel=0.0,
        L_accel=0.0,
        T_trans=1.200,
        L_final_decel=0.806,
        T_final_decel=0.180,
    ),
    (10, "off"): dict(
        T_init_accel=0.144,
        L_init_accel=0.610,
        L_decel=0.876,
        L_accel=0.0,
        T_trans=1.410,
        L_final_decel=0.807,
        T_final_decel=0.180,
    ),
    (40, "on"): dict(
        T_init_accel=0.204,
        L_init_accel=4.212,
        L_decel=2.500,
        L_accel=2.200,
        T_trans=0.426,
        L_final_decel=3.862,
        T_final_decel=0.192,
    ),
    (40, "off"): dict(
        T_init_accel=0.216,
        L_init_accel=4.944,
        L_decel=3.670,
        L_accel=4.387,
        T_trans=0.408,
        L_final_decel=3.807,
        T_final_decel=0.192,
    ),
}


def from_path2d(path, speed: float, key: str = "section", z: float = 50.0) -> Moves:
    """Moves of a planned section path (`waamflow.paths.Path2D`: points (n, 2), arc, inside)."""
    m = len(path.points) - 1
    return _moves(path.points, path.arc, path.inside, np.full(m, speed), key, z)


def planned(pattern: str, speed: float, size=SMALL_OR, **spec) -> Moves:
    """The OR filled by `waamflow.paths.plan_section` with `pattern` (guide along the length L)."""
    from shapely.geometry import LineString, box

    from ..paths import StrategySpec, plan_section

    W, L = size
    region = box(0.0, 0.0, L, W)
    guide = LineString([(-1.0, W / 2), (L + 1.0, W / 2)])
    return from_path2d(plan_section(region, guide, StrategySpec(pattern=pattern, **spec)), speed, pattern)
