"""One-layer re-plan for the GUI's mask canvas: run a node (and what it needs) for one layer.

Uses the server's warm cache, so after an edit only that layer of the edited node and of what
depends on it is recomputed.
"""

from __future__ import annotations

import threading
import time
from typing import Any, cast

from fastapi import APIRouter, HTTPException, Request
import numpy as np
import shapely
from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic.config import JsonDict

from ...core.errors import PlanningError, RecipeError
from ...core.memo import Memo, digest
from ...core.model import Layer, LayerPaths, Layered, LayerSections
from ...core.serialize import coords, layer_json, polygon_json, section_path_json
from ...engine.cache import MemoryCache, TieredCache
from ...engine.executor import FileResolver, execute
from ...engine.graph import build_graph
from ...engine.recipe import Recipe, apply_overrides
from ...process.laps import layer_view
from ..services import parse_api_recipe
from ..deps import ServicesDep
from ..schemas import PREVIEW_REQUEST_RULES, LayerIndex, LayerJSON, PolygonJSON, SectionJSON, SectionPathJSON, errors
from ..store import GRAPH_NAME_PATTERN
from ..worker import is_memory_error

router = APIRouter(tags=["preview"])


class PreviewRequest(BaseModel):
    model_config = ConfigDict(extra="forbid", json_schema_extra=cast(JsonDict, PREVIEW_REQUEST_RULES))
    recipe: dict[str, Any] = Field(..., description="the current (possibly unsaved) recipe (see Recipe)")
    node: str = Field(..., min_length=1, max_length=64, description="node whose output to show (e.g. the zone node)")
    layer: LayerIndex = Field(..., description="layer index")
    graph: str | None = Field(
        None, pattern=GRAPH_NAME_PATTERN, max_length=80, description="saved graph whose files/parameter XML to use"
    )
    params_xml: str | None = Field(
        None, max_length=20_000_000, description="with `graph`: draft zone-parameter XML instead of the saved one"
    )
    inputs: dict[str, Any] = Field(default_factory=dict)
    coverage: bool = Field(False, description="also return each path's bead coverage (void/overlap polygons)")
    bead_width: float | None = Field(
        None,
        gt=0.05,
        le=100,
        description="bead width for coverage, mm (default: what the recipe's coverage "
        "node uses: its per-section widths and connected bead model, with "
        "$input values; else the strategy's width of the section; else 6)",
    )

    @model_validator(mode="after")
    def _xml_needs_graph(self) -> "PreviewRequest":
        if self.params_xml is not None and self.graph is None:
            raise ValueError("'params_xml' needs 'graph' (the graph whose files the preview uses)")
        return self


class CoverageJSON(BaseModel):
    """Bead coverage of one section path (waamflow.process.coverage): areas in mm², polygons layer-local."""

    key: str
    region_area_mm2: float
    footprint_area_mm2: float
    void_area_mm2: float
    overlap_area_mm2: float
    over_deposit_area_mm2: float
    void_share: float
    overlap_share: float
    bead_width_mm: float
    cell_mm: float
    void: list[PolygonJSON]
    overlap: list[PolygonJSON]


class PreviewResponse(BaseModel):
    layer: LayerJSON | None
    sections: list[SectionJSON]
    paths: list[SectionPathJSON]
    layer_count: int | None
    error: dict[str, Any] | None
    ms: float
    coverage: list[CoverageJSON] | None = None


def _item(value: Any, index: int) -> Any:
    if isinstance(value, Layered) and 0 <= index < len(value):
        return value.items[index]
    return None


def _collect(
    graph, outputs: dict, node: str, index: int
) -> tuple[Layer | None, LayerSections | None, LayerPaths | None, Layered | None]:
    """The layer, its sections and its paths as the node (or the nearest node before it) hands them
    out, and the toolpath the paths are a layer of."""
    upstream = graph.ancestors(node)
    order = [n for n in reversed(graph.order) if n == node or n in upstream]
    layer = sections = paths = source = None
    for nid in order:
        for value in outputs.get(nid, {}).values():
            it = _item(value, index)
            if isinstance(it, LayerPaths) and paths is None:
                paths, source = it, value
            elif isinstance(it, LayerSections) and sections is None:
                sections = it
            elif isinstance(it, Layer) and layer is None:
                layer = it
    for it in (paths, sections):
        if layer is None and it is not None:
            layer = it.layer
    return layer, sections, paths, source


def _paths_json(source: Layered | None, paths: LayerPaths | None) -> list[dict]:
    """The paths welded within the layer's height (process.laps): a helix lap by lap, each lap
    saying which helix it is part of (`climbs`)."""
    if paths is None:
        return []
    out = []
    for sp, span in layer_view(source, paths):
        d = section_path_json(sp)
        if span is not None:
            d["climbs"] = {
                "from_layer": span.layer,
                "laps": span.laps,
                "z_from": round(span.z_from, 3),
                "z_to": round(span.z_to, 3),
            }
        out.append(d)
    return out


def _sections_json(ls: LayerSections | None) -> list[dict]:
    if ls is None:
        return []
    out = []
    for s in ls.sections:
        out.append(
            {
                "key": s.key,
                "polygon": polygon_json(s.region),
                "guide": coords(s.guide.coords) if s.guide is not None else None,
                "start": list(s.start) if s.start is not None else None,
                "stop": list(s.stop) if s.stop is not None else None,
            }
        )
    return out


def _coverage_node(graph) -> str | None:
    return next((nid for nid in graph.order if graph.nodes[nid].type == "coverage"), None)


def _width_of(graph, outputs: dict, asked: float | None):
    """sp -> bead width (mm) for the overlay: the request's `bead_width`; else what the recipe's
    coverage node would use (`coverage_width`: resolved params, per-section widths, the connected
    bead model); else the strategy's resolved width for the section; else 6 mm (the MPP study)."""
    from ...nodes.process import coverage_width

    if asked is not None:
        return lambda sp: float(asked)
    cov = _coverage_node(graph)
    if cov is not None:
        gn = graph.nodes[cov]
        src = gn.inputs.get("model")
        model = outputs.get(src[0], {}).get(src[1]) if src else None
        return lambda sp: coverage_width(gn.params, sp, model)
    strat = next((nid for nid in graph.order if graph.nodes[nid].type == "strategy"), None)
    if strat is not None:
        p = graph.nodes[strat].params

        def width(sp) -> float:
            o = p.sections.get(sp.key)
            w = getattr(o, "bead_width", None) if o is not None else None
            return float(w if w is not None else p.default.bead_width)

        return width
    return lambda sp: 6.0


#: A section's coverage overlay (its JSON) per exact input (region WKB, layer-local path points and
#: arc flags, bead width; core.memo): an edit re-plans one section of a layer, the others' overlays
#: are the ones computed before (in a preview worker, the memo lives with the worker).
_COVERAGE: Memo[dict[str, Any]] = Memo(256)


def _section_coverage_json(region: Any, points: np.ndarray, arc: np.ndarray, width: float) -> dict[str, Any]:
    from ...nodes.process import _geom_json
    from ...process.coverage import section_coverage

    pts, flags = np.ascontiguousarray(points, dtype=float), np.ascontiguousarray(arc, dtype=bool)
    key = digest(shapely.to_wkb(region), str(pts.shape), pts.tobytes(), flags.tobytes(), float(width))

    def compute() -> dict[str, Any]:
        cov = section_coverage(region, pts, flags, width)
        return {**cov.summary(), "void": _geom_json(cov.void), "overlap": _geom_json(cov.overlap_outline())}

    return _COVERAGE.get(key, compute)


def _coverage_json(sections: LayerSections | None, paths: LayerPaths | None, width) -> list[dict]:
    from ...nodes.process import layer_local

    if sections is None or paths is None:
        return []
    regions = sections.by_key()
    out = []
    for sp in paths.sections:
        if sp.key in regions:
            cov = _section_coverage_json(regions[sp.key].region, layer_local(paths.layer, sp.points), sp.arc, width(sp))
            out.append({"key": sp.key, **cov})
    return out


@router.post("/api/preview", response_model=PreviewResponse, responses=errors(401, 404, 422, 429))
async def preview(req: PreviewRequest, svc: ServicesDep, request: Request) -> PreviewResponse:
    """One layer of one node. Under the run queue's limits: counted in the queue (429 when full),
    refused by its estimate before it starts (422), stopped on preview_timeout_s or when the client
    leaves."""
    t0 = time.perf_counter()
    request.state.audit_target, request.state.audit_node, request.state.audit_layer = req.graph, req.node, req.layer
    if req.graph is not None and svc.store.get_graph(req.graph) is None:
        raise HTTPException(404, detail={"message": f"no graph named {req.graph!r}"})
    recipe = svc.prepare(
        req.graph, apply_overrides(parse_api_recipe(req.recipe), list(req.inputs.items())), req.params_xml
    )
    graph = build_graph(recipe)
    if req.node not in graph.nodes:
        raise RecipeError(f"no node with id {req.node!r}", node=req.node)
    resolver = svc.resolver_for(req.graph, recipe, req.params_xml)
    svc.check_sandbox(graph, resolver)  # → 422 before anything is read
    if svc.runs is None:
        return compute_preview(svc.cache, None, req, recipe, resolver, t0)
    svc.runs.limits.check_estimate(graph, resolver)  # → 422 with the estimate, before anything runs
    job = svc.runs.preview(compute_preview, (req, recipe, resolver, t0))
    result: PreviewResponse = await job.run(request.is_disconnected)
    return result


def compute_preview(
    cache: TieredCache | MemoryCache | None,
    cancel: threading.Event | None,
    req: PreviewRequest,
    recipe: Recipe,
    resolver: FileResolver,
    t0: float,
) -> PreviewResponse:
    """The preview's computation: in the server, or in a preview worker under the run memory limit
    (api/preview_worker.py; then its arguments and result are pickled)."""
    graph = build_graph(recipe)
    error = None
    node = req.node
    cov = _coverage_node(graph) if req.coverage and req.bead_width is None else None
    model_src = graph.nodes[cov].inputs.get("model") if cov is not None else None
    targets = [node] + ([model_src[0]] if model_src and model_src[0] != node else [])
    try:
        result = execute(
            graph,
            resolver=resolver,
            cache=cache,
            targets=targets,
            layers=[req.layer],
            artifacts=False,
            workers=1,
            cancel=cancel,
        )
        outputs, count = result.outputs, result.layer_count
    except PlanningError as err:
        if is_memory_error(err):  # over the memory limit: the preview fails naming it (preview_worker.py)
            raise
        error = err.to_dict()
        parents = [src for src, _ in graph.nodes[err.node].inputs.values()] if err.node in graph.nodes else []
        outputs, count = {}, None
        if parents:
            try:
                r2 = execute(
                    graph,
                    resolver=resolver,
                    cache=cache,
                    targets=parents + targets[1:],
                    layers=[req.layer],
                    artifacts=False,
                    workers=1,
                    cancel=cancel,
                )
                outputs, count, node = r2.outputs, r2.layer_count, parents[0]
            except PlanningError:
                pass
    if count is not None and req.layer >= count:
        raise HTTPException(
            422, detail={"message": f"layer {req.layer} is out of range: the part has {count} layers (0..{count - 1})"}
        )
    layer, sections, paths, source = _collect(graph, outputs, node, req.layer)
    return PreviewResponse(
        layer=layer_json(layer) if layer is not None else None,
        sections=_sections_json(sections),
        paths=_paths_json(source, paths),
        layer_count=count,
        error=error,
        coverage=_coverage_json(sections, paths, _width_of(graph, outputs, req.bead_width)) if req.coverage else None,
        ms=round((time.perf_counter() - t0) * 1000, 2),
    )
