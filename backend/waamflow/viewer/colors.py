"""Colours for the 3D preview: one place for palettes and colour maps (pure numpy).

Colours are uint8 RGB. Scalar maps take float arrays and a (lo, hi) range and return (n, 3)
uint8; NaN maps to `NAN_RGB`.
"""

from __future__ import annotations

import hashlib

import numpy as np

# Viridis sampled at 9 stops (matplotlib's `viridis`, perceptually uniform, colour-blind safe):
# used for speed and deviation so "slow" / "small" reads dark blue and "fast" / "large" yellow.
_VIRIDIS = np.array(
    [
        [68, 1, 84],
        [71, 44, 122],
        [59, 81, 139],
        [44, 113, 142],
        [33, 144, 141],
        [39, 173, 129],
        [92, 200, 99],
        [170, 220, 50],
        [253, 231, 37],
    ],
    dtype=float,
)

VIRIDIS_STOPS = _VIRIDIS.astype(np.uint8)  # the map's stops, low → high (for legends drawn elsewhere)

NAN_RGB = np.array([150, 150, 150], dtype=np.uint8)
TRAVEL_RGB = np.array([205, 205, 205], dtype=np.uint8)  # arc-OFF moves: pale, drawn faint
ARC_ON_RGB = np.array([230, 57, 70], dtype=np.uint8)
ARC_OFF_RGB = np.array([69, 123, 157], dtype=np.uint8)
PROGRAMMED_RGB = np.array([20, 20, 20], dtype=np.uint8)  # near black: reads against every map colour
OUTLINE_RGB = np.array([76, 201, 240], dtype=np.uint8)  # port colour of "layers"
CURVE_RGB = np.array([247, 37, 133], dtype=np.uint8)
MESH_RGB = (141, 153, 174)
ROBOT_RGB = np.array(
    [255, 140, 0], dtype=np.uint8
)  # KUKA orange                                  # port colour of "mesh"

# Categorical palette (Tableau 10) for sections and zones without an explicit colour.
PALETTE = np.array(
    [
        [78, 121, 167],
        [242, 142, 43],
        [225, 87, 89],
        [118, 183, 178],
        [89, 161, 79],
        [237, 201, 72],
        [176, 122, 161],
        [255, 157, 167],
        [156, 117, 95],
        [186, 176, 172],
    ],
    dtype=np.uint8,
)

# Default zone colours, used only when a toolpath carries no `zone_colors` (before the zone node
# has assigned them); the zone node's own colours (the ones the XML editor shows) always win.
DEFAULT_ZONE_RGB = {
    "start": np.array([46, 196, 182], dtype=np.uint8),
    "end": np.array([231, 111, 81], dtype=np.uint8),
    "": np.array([120, 120, 120], dtype=np.uint8),
}

FEATURE_RGB = {
    "free_end": (230, 57, 70),
    "corner": (244, 162, 97),
    "continuous": (42, 157, 143),
    "t_crossing": (38, 70, 83),
    "direct_crossing": (131, 56, 236),
    "odd_t_crossing": (255, 0, 110),
    "odd_direct_crossing": (251, 86, 7),
    "four_direct_crossing": (58, 134, 255),
    "tubular": (233, 196, 106),
}


def hex_to_rgb(color: str) -> np.ndarray:
    """'#rrggbb' (or 'rrggbb', or '#rgb') → (3,) uint8. Raises ValueError on anything else."""
    c = color.strip().lstrip("#")
    if len(c) == 3:
        c = "".join(ch * 2 for ch in c)
    if len(c) != 6:
        raise ValueError(f"not a #rrggbb colour: {color!r}")
    return np.array([int(c[i : i + 2], 16) for i in (0, 2, 4)], dtype=np.uint8)


def rgb_to_hex(rgb) -> str:
    r, g, b = (int(v) for v in np.asarray(rgb).reshape(3))
    return f"#{r:02x}{g:02x}{b:02x}"


def categorical(key: str) -> np.ndarray:
    """A stable palette colour for a name (same key → same colour in every run and process)."""
    h = int.from_bytes(hashlib.blake2b(key.encode(), digest_size=4).digest(), "little")
    return PALETTE[h % len(PALETTE)]


def zone_rgb(zone: str, zone_colors: dict[str, str]) -> np.ndarray:
    """Colour of a zone id: the toolpath's own `zone_colors` entry, else a default."""
    if zone in zone_colors:
        try:
            return hex_to_rgb(zone_colors[zone])
        except ValueError:
            pass
    if zone in DEFAULT_ZONE_RGB:
        return DEFAULT_ZONE_RGB[zone]
    return categorical("zone:" + zone)


def colormap(values: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """(n,) float → (n, 3) uint8 viridis colours; `lo`..`hi` spans the map, values are clipped."""
    v = np.asarray(values, dtype=float).reshape(-1)
    span = hi - lo if np.isfinite(hi - lo) and hi - lo > 0 else 1.0
    u = np.clip((v - lo) / span, 0.0, 1.0)
    u = np.where(np.isfinite(u), u, 0.0)
    x = u * (len(_VIRIDIS) - 1)
    i = np.minimum(x.astype(int), len(_VIRIDIS) - 2)
    f = (x - i)[:, None]
    rgb = (_VIRIDIS[i] * (1 - f) + _VIRIDIS[i + 1] * f).round().astype(np.uint8)
    rgb[~np.isfinite(v)] = NAN_RGB
    return rgb


def finite_range(*arrays: np.ndarray) -> tuple[float, float]:
    """(min, max) over the finite entries of the arrays; (0, 1) when there are none."""
    finite = [a[np.isfinite(a)] for a in (np.asarray(x, dtype=float).reshape(-1) for x in arrays)]
    finite = [a for a in finite if a.size]
    if not finite:
        return 0.0, 1.0
    allv = np.concatenate(finite)
    return float(allv.min()), float(allv.max())


# Colour maps span the 2nd–98th percentile of the data: one ignition spike (deposit per mm at a
# standing start) or one absurd speed must not squeeze every ordinary value into one colour.
# Values beyond are clamped to the end colours; legends give the full extent beside the limits.
ROBUST_PERCENTILES = (2.0, 98.0)


def robust_range(*arrays: np.ndarray, pct: tuple[float, float] = ROBUST_PERCENTILES) -> tuple[float, float]:
    """(lo, hi) percentiles `pct` over the finite entries of the arrays (linear interpolation,
    numpy's default); (0, 1) when there are none."""
    finite = [a[np.isfinite(a)] for a in (np.asarray(x, dtype=float).reshape(-1) for x in arrays)]
    finite = [a for a in finite if a.size]
    if not finite:
        return 0.0, 1.0
    lo, hi = np.percentile(np.concatenate(finite), pct)
    return float(lo), float(hi)
