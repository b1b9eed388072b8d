"""Length units declared by files, a plausibility check of part sizes, and build-plate placement.

File units: DXF `$INSUNITS` (header variable, AutoCAD unit codes), 3MF `<model unit="...">`
(3MF core spec: micron, millimeter, centimeter, inch, foot, meter; default millimeter). Formats
without a unit (STL, OBJ, PLY, JSON sketches) are taken as millimetres.
"""

from __future__ import annotations

import io
import re
import zipfile

import numpy as np

# $INSUNITS codes (AutoCAD / ezdxf.units): 0 unitless, 1 in, 2 ft, 4 mm, 5 cm, 6 m, 13 µm
DXF_INSUNITS = {1: "in", 2: "ft", 4: "mm", 5: "cm", 6: "m", 13: "um"}
THREEMF_UNITS = {"micron": "um", "millimeter": "mm", "centimeter": "cm", "inch": "in", "foot": "ft", "meter": "m"}

# WAAM parts: a few mm (one bead is ~3-10 mm wide) up to a few metres (robot reach)
PLAUSIBLE_MM = (5.0, 5000.0)

PLACEMENTS = ("as_is", "on_plate", "centred")


def dxf_units(doc) -> str | None:
    """Unit of an ezdxf document's coordinates from $INSUNITS, None when unitless/unknown."""
    try:
        code = int(doc.header.get("$INSUNITS", 0))
    except (TypeError, ValueError):
        return None
    return DXF_INSUNITS.get(code)


def threemf_units(data: bytes) -> str | None:
    """Unit of a 3MF package's model (`unit` attribute of the root <model>), mm when absent;
    None when the package cannot be read (the mesh reader reports that)."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            names = [n for n in z.namelist() if n.lower().endswith(".model")]
            if not names:
                return None
            main = next((n for n in names if n.lower() == "3d/3dmodel.model"), names[0])
            head = z.open(main).read(4096).decode("utf-8", "replace")
    except (zipfile.BadZipFile, OSError, KeyError):
        return None
    m = re.search(r"<(?:\w+:)?model\b[^>]*?\bunit\s*=\s*[\"']([A-Za-z]+)[\"']", head)
    if not m:
        return "mm"
    return THREEMF_UNITS.get(m.group(1).lower())


def implausible_size(extent_mm: float) -> str | None:
    """A warning text when the largest extent (mm) of a part is implausible for WAAM, else None."""
    lo, hi = PLAUSIBLE_MM
    if extent_mm < lo:
        return (f"part is only {extent_mm:.3g} mm across (< {lo:g} mm): smaller than a few weld beads; "
                "check the node's 'units' (file in m or in?)")
    if extent_mm > hi:
        return (f"part is {extent_mm / 1000:.3g} m across (> {hi / 1000:g} m): beyond a WAAM cell; "
                "check the node's 'units' (file in mm read as m or in?)")
    return None


def placement_offset(lo: np.ndarray, hi: np.ndarray, placement: str) -> np.ndarray:
    """Translation (3,) mm that places a part with bounds lo, hi (mm): as_is → 0; on_plate →
    its lowest point on z = 0; centred → additionally its x/y bounding-box centre on the origin."""
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    if placement == "as_is":
        return np.zeros(3)
    if placement == "on_plate":
        return np.array([0.0, 0.0, -lo[2]])
    if placement == "centred":
        c = (lo + hi) / 2.0
        return np.array([-c[0], -c[1], -lo[2]])
    raise ValueError(f"unknown placement {placement!r}; use one of {', '.join(PLACEMENTS)}")
