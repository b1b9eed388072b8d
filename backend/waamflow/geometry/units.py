"""Length units declared by files, a plausibility check of part sizes, and build-plate placement.

File units: DXF `$INSUNITS` (header variable, AutoCAD unit codes), 3MF `<model unit="...">`
(3MF core spec: micron, millimeter, centimeter, inch, foot, meter; default millimeter). Formats
without a unit (STL, OBJ, PLY, JSON sketches) are taken as millimetres.
"""

from __future__ import annotations

import io
import zipfile

import numpy as np

# $INSUNITS codes, the full table of the DXF reference (ezdxf.units.InsertUnits; 0 = unitless);
# factors in transform.UNIT_TO_MM (exact; tests check them against ezdxf.units.METER_FACTOR).
DXF_INSUNITS = {
    1: "in",
    2: "ft",
    3: "mi",
    4: "mm",
    5: "cm",
    6: "m",
    7: "km",
    8: "uin",
    9: "mil",
    10: "yd",
    11: "angstrom",
    12: "nm",
    13: "um",
    14: "dm",
    15: "dam",
    16: "hm",
    17: "Gm",
    18: "au",
    19: "ly",
    20: "pc",
    21: "us_ft",
    22: "us_in",
    23: "us_yd",
    24: "us_mi",
}
# IGES global section parameter 14 (unit flag), IGES 5.3 §2.2.4.3
IGES_UNIT_FLAGS = {1: "in", 2: "mm", 4: "ft", 5: "mi", 6: "m", 7: "km", 8: "mil", 9: "um", 10: "cm", 11: "uin"}
THREEMF_UNITS = {"micron": "um", "millimeter": "mm", "centimeter": "cm", "inch": "in", "foot": "ft", "meter": "m"}

# WAAM parts: a few mm (one bead is ~3-10 mm wide) up to a few metres (robot reach)
PLAUSIBLE_MM = (5.0, 5000.0)
# Beyond this a part is refused, not warned about: no cell builds it, and planning it costs memory in
# proportion (a sketch wall of 1 km took 3 GB and 60 s; one of 1e9 mm was killed by the kernel at 23.7 GB)
MAX_PART_MM = 100_000.0

PLACEMENTS = ("as_is", "on_plate", "centred")


def dxf_units(doc) -> str | None:
    """Unit of an ezdxf document's coordinates from $INSUNITS, None when unitless/unknown."""
    try:
        code = int(doc.header.get("$INSUNITS", 0))
    except (TypeError, ValueError):
        return None
    return DXF_INSUNITS.get(code)


def threemf_units(data: bytes) -> str | None:
    """Unit of a 3MF package's model (`unit` attribute of the root <model>, parsed as XML wherever
    it is in the file), mm when absent; None when the package cannot be read (the mesh reader
    reports that) or the unit is not one of the 3MF core spec's."""
    import xml.etree.ElementTree as ET

    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            names = [n for n in z.namelist() if n.lower().endswith(".model")]
            if not names:
                return None
            main = next((n for n in names if n.lower() == "3d/3dmodel.model"), names[0])
            with z.open(main) as fh:
                _, root = next(ET.iterparse(fh, events=("start",)))  # the root element only
    except (zipfile.BadZipFile, OSError, KeyError, ET.ParseError, StopIteration):
        return None
    unit = root.attrib.get("unit")
    if unit is None:
        return "mm"
    return THREEMF_UNITS.get(unit.strip().lower())


def conversion_notice(file_unit: str | None, units: str) -> tuple[str, float, str | None]:
    """(unit applied, factor to mm, notice text or None) for a file declaring `file_unit` (None:
    declares none) read with the node's `units` ('file' or a unit name). One rule for every
    format: the file's unit is converted exactly once; an explicit `units` applies to a file
    that declares none, and overrides a declared unit that differs (said so)."""
    from .transform import UNIT_NAMES, unit_scale

    name = UNIT_NAMES.get
    if units == "file" or units == file_unit:
        applied = file_unit or "mm"
        f = unit_scale(applied)
        note = None if applied == "mm" else f"file unit {name(applied, applied)} → mm ×{f:g}"
        return applied, f, note
    f = unit_scale(units)
    if file_unit is None:
        return (
            units,
            f,
            (
                None
                if units == "mm"
                else f"unit {name(units, units)} (set by 'units'; the file declares none) → mm ×{f:g}"
            ),
        )
    return (
        units,
        f,
        (
            f"'units': {units} overrides the file unit {name(file_unit, file_unit)}: the file's numbers "
            f"are read in {name(units, units)} → mm ×{f:g} (instead of ×{unit_scale(file_unit):g})"
        ),
    )


def implausible_size(extent_mm: float) -> str | None:
    """A warning text when the largest extent (mm) of a part is implausible for WAAM, else None."""
    lo, hi = PLAUSIBLE_MM
    if extent_mm < lo:
        return (
            f"part is only {extent_mm:.3g} mm across (< {lo:g} mm): smaller than a few weld beads; "
            "check the node's 'units' (file in m or in?)"
        )
    if extent_mm > hi:
        return (
            f"part is {extent_mm / 1000:.3g} m across (> {hi / 1000:g} m): beyond a WAAM cell; "
            "check the node's 'units' (file in mm read as m or in?)"
        )
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
