"""What a run will cost, estimated before it starts from the recipe and the heads of its files:
layers (part height / layer height), triangles, DXF entities, the uncompressed size of a 3MF.
The server refuses a run or preview whose estimate is over its limits (422 with the estimate)
instead of finding out after computing every layer.

Cheap by design: a binary STL's triangle count is its header and its z range one vectorised pass;
a 3MF's uncompressed size is its zip directory (a zip bomb declares what it will expand to); a
DXF's entities are counted as group-code-0 lines, not parsed. Files are read through the run's
resolver (same sandbox and size limit as the nodes)."""

from __future__ import annotations

import io
import math
import re
import zipfile
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.errors import WaamflowError

if TYPE_CHECKING:
    from .executor import FileResolver
    from .graph import Graph, GraphNode

UNIT_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "ft": 304.8, "file": 1.0}
STL_VERTEX = re.compile(rb"vertex\s+\S+\s+\S+\s+(\S+)")


class EstimateError(WaamflowError):
    """The estimate of a run is over a server limit: 422 before anything runs."""

    kind = "limit"
    http_status = 422


@dataclass
class Estimate:
    layers: int | None = None
    triangles: int = 0
    dxf_entities: int = 0
    uncompressed_bytes: int = 0
    notes: list[str] = field(default_factory=list)
    layers_node: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "layers": self.layers,
            "triangles": self.triangles,
            "dxf_entities": self.dxf_entities,
            "uncompressed_mb": round(self.uncompressed_bytes / 2**20, 1),
            "notes": self.notes,
        }


def _stl(data: bytes) -> tuple[int, tuple[float, float] | None]:
    """(triangles, (z min, z max)) of an STL, binary or ASCII."""
    if len(data) >= 84:
        n = int.from_bytes(data[80:84], "little")
        if 84 + 50 * n == len(data):
            rec = np.frombuffer(
                data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]), count=n, offset=84
            )
            if n == 0:
                return 0, None
            z = rec["v"][:, :, 2]
            return n, (float(np.nanmin(z)), float(np.nanmax(z)))
    tri = data.count(b"facet")
    zs = [float(m) for m in STL_VERTEX.findall(data[:50_000_000])] if tri else []
    try:
        return tri, (min(zs), max(zs)) if zs else None
    except ValueError:
        return tri, None


def _dxf_entities(data: bytes) -> int:
    """Group-code-0 pairs of an ASCII DXF (each starts an entity, table entry or section)."""
    codes = data.split(b"\n")[0::2]
    return sum(1 for c in codes if c.strip() == b"0")


def _threemf_size(data: bytes) -> int:
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            return sum(i.file_size for i in z.infolist())
    except (zipfile.BadZipFile, OSError, ValueError):
        return 0


_FACTS: dict[tuple[str, str], tuple[int, tuple[float, float] | None, int]] = {}


def _mesh_facts(resolver: FileResolver, path: str, cap: int) -> tuple[int, tuple[float, float] | None, int] | None:
    """(triangles, z range in file units, uncompressed bytes) of a mesh file, memoised on its
    content signature (the GUI's previews ask again on every edit)."""
    sig = resolver.signature(path)
    key = (path, sig)
    if sig != "missing" and key in _FACTS:
        return _FACTS[key]
    data = _read(resolver, path, cap)
    if data is None:
        return None
    ext = path.lower().rsplit(".", 1)[-1]
    tri, zr, unpacked = 0, None, 0
    if ext == "stl":
        tri, zr = _stl(data)
    elif ext == "3mf":
        unpacked = _threemf_size(data)
    elif ext == "obj":
        tri = len(re.findall(rb"(?m)^f\s", data))
    if len(_FACTS) > 256:
        _FACTS.clear()
    _FACTS[key] = (tri, zr, unpacked)
    return _FACTS[key]


def _read(resolver: FileResolver, path: str, cap: int) -> bytes | None:
    try:
        return resolver.read_bytes(path, cap)
    except (WaamflowError, OSError):
        return None  # the node itself reports a missing or refused file, with its context


def estimate(graph: Graph, resolver: FileResolver, read_cap: int = 512 * 2**20) -> Estimate:
    """The estimate of running `graph` whole (see module doc); unknowns stay None/0 with a note."""
    est = Estimate()
    z_range: dict[str, tuple[float, float]] = {}  # node id → z extent of its part, mm
    for nid in graph.order:
        g = graph.nodes[nid]
        p = g.params
        path = getattr(p, "path", None)
        if g.type == "mesh" and isinstance(path, str):
            got = _mesh_facts(resolver, path, read_cap)
            if got is None:
                continue
            tri, zr, unpacked = got
            scale = UNIT_MM.get(str(getattr(p, "units", "file")), 1.0)
            est.triangles += tri
            est.uncompressed_bytes += unpacked
            if zr is not None:
                z_range[nid] = (zr[0] * scale, zr[1] * scale)
        elif g.type == "sketch" and isinstance(path, str):
            data = _read(resolver, path, read_cap)
            if data is None:
                continue
            if path.lower().endswith(".dxf"):
                est.dxf_entities += _dxf_entities(data)
            h = getattr(p, "height", None)
            if isinstance(h, (int, float)):
                z0 = float(getattr(p, "z0", 0.0) or 0.0)
                z_range[nid] = (z0, z0 + float(h))
        elif g.type == "slice":
            n = _slice_layers(g, z_range)
            if n is not None and (est.layers is None or n > est.layers):
                est.layers, est.layers_node = n, nid
    return est


def _slice_layers(g: GraphNode, z_range: dict[str, tuple[float, float]]) -> int | None:
    p: Any = g.params  # a slice node's params model (layer_count, z_min, z_max, layer_height, ...)
    if getattr(p, "layer_count", None):
        return int(p.layer_count)
    src = g.inputs.get("mesh")
    zr = z_range.get(src[0]) if src else None
    if zr is None:
        return None
    lo = p.z_min if getattr(p, "z_min", None) is not None else zr[0]
    hi = p.z_max if getattr(p, "z_max", None) is not None else zr[1]
    height = hi - lo - float(getattr(p, "start_offset", 0.0) or 0.0)
    thick = list(getattr(p, "thicknesses", []) or [])
    height -= sum(thick)
    lh = float(p.layer_height)
    return len(thick) + max(0, math.ceil(height / lh - 1e-9)) if lh > 0 else None


def check_estimate(
    est: Estimate,
    *,
    max_layers: int = 0,
    max_triangles: int = 0,
    max_dxf_entities: int = 0,
    max_uncompressed_bytes: int = 0,
) -> None:
    """EstimateError (422) naming the first estimate over its limit (0 = no limit)."""
    over = []
    if max_layers and est.layers is not None and est.layers > max_layers:
        over.append(f"{est.layers} layers, over the limit of {max_layers} (max_layers)")
    if max_triangles and est.triangles > max_triangles:
        over.append(f"{est.triangles} triangles, over the limit of {max_triangles} (max_triangles)")
    if max_dxf_entities and est.dxf_entities > max_dxf_entities:
        over.append(f"{est.dxf_entities} DXF entities, over the limit of {max_dxf_entities} (max_dxf_entities)")
    if max_uncompressed_bytes and est.uncompressed_bytes > max_uncompressed_bytes:
        over.append(
            f"3MF expands to {est.uncompressed_bytes / 2**20:.0f} MB, over the limit of "
            f"{max_uncompressed_bytes / 2**20:.0f} MB (max_uncompressed_mb)"
        )
    if over:
        err = EstimateError(
            "refused before running: the estimate is " + "; ".join(over),
            node=est.layers_node if "layers" in over[0] else None,
        )
        err.estimate = est.to_dict()  # type: ignore[attr-defined]
        raise err
