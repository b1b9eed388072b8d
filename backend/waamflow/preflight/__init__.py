"""Preflight: after every run, an independent check of each emitted program against its part.

`run_preflight` reads the programs as written (the artifacts' text, through `read`) and the part
(the mesh, sketch or region the recipe starts from), and returns the report that goes into
`preflight.json` and `summary.json["preflight"]`: whole-run figures (`top_gap_mm`,
`uncovered_share`, `wire_part_volume_ratio`, `min_arc_run_mm`, `start_spread_mm`,
`weld_data_missing`, `outside_mm`), per program and per layer, a list of problems naming layer and
section, and a verdict `ok | warn | fail`. Metal outside the part is `outside` (arc-ON centre lines
off the part, machining stock at run ends aside). A recipe without a program is checked on its last
toolpath. Nodes that only order the deposit (the sequence node) are checked to weld what they were
given, read back from their input and output toolpath artifacts (`conserve`).
"""

from __future__ import annotations

import re
from typing import Any

import orjson

from ..core.serialize import dumps_report
from .settings import PreflightSettings

__all__ = ["PreflightSettings", "run_preflight", "stamp_acceptance", "first_error", "gate"]

SUMMARY_KEYS = (
    "top_gap_mm",
    "bottom_gap_mm",
    "uncovered_share",
    "wire_part_volume_ratio",
    "min_arc_run_mm",
    "start_spread_mm",
    "weld_data_missing",
    "outside_mm",
    "weld_position_max_deg",
)
DEFAULT_BEAD_WIDTH_MM = 6.0


def _part_of(graph, outputs: dict, node_id: str):
    from ..core.model import Layered, Layer, MeshData, Midsurface
    from .bodies import united
    from .check import Part

    upstream = graph.ancestors(node_id)
    order = [n for n in graph.order if n in upstream]
    for nid in order:  # the first input in topological order is the part
        for value in outputs.get(nid, {}).values():
            if isinstance(value, MeshData):
                if value.surface:
                    return Part("surface", nid, vertices=value.vertices, faces=value.faces)
                vertices, faces, _n, note = united(value.vertices, value.faces, value.bodies)  # overlapping shells
                return Part("solid", nid, vertices=vertices, faces=faces, notes=(note,) if note else ())
            if isinstance(value, Midsurface):
                return Part("midsurface", nid, curves=value.curves, z0=value.z0, height=value.height)
    for nid in order:
        if graph.nodes[nid].type == "rectangle":
            for value in outputs.get(nid, {}).values():
                if isinstance(value, Layered) and value.items and isinstance(value.items[0], Layer):
                    return Part("region", nid, regions=[(L.z, L.thickness, L.region) for L in value.items])
    return None


def _bead_width(graph, node_id: str, s: PreflightSettings) -> tuple[float, str]:
    if s.bead_width_mm:
        return s.bead_width_mm, "preflight.bead_width_mm"
    upstream = graph.ancestors(node_id) | {node_id}
    for nid in [n for n in graph.order if n in upstream]:
        params = graph.nodes[nid].params
        default = getattr(params, "default", None)
        for owner, path in ((default, f"{nid}.default.bead_width"), (params, f"{nid}.bead_width")):
            w = getattr(owner, "bead_width", None) if owner is not None else None
            if isinstance(w, (int, float)) and w > 0:
                return float(w), path
    return DEFAULT_BEAD_WIDTH_MM, "default 6 mm (no bead_width in the recipe)"


#: parameters that put a run's ends beyond the part on purpose (machining stock: run-ups/-outs,
#: free-end extensions), mm
STOCK_PARAMS = ("extension_before", "extension_after", "free_end_extension")


def _stock_length(graph, node_id: str, width: float) -> float:
    """The machining stock a run's end may reach beyond the part, mm: the longest `STOCK_PARAMS`
    value upstream of the program (in any section override too) plus one bead width."""
    longest = 0.0

    def walk(v) -> None:
        nonlocal longest
        if isinstance(v, dict):
            for k, x in v.items():
                if k in STOCK_PARAMS and isinstance(x, (int, float)) and not isinstance(x, bool):
                    longest = max(longest, float(x))
                else:
                    walk(x)
        elif isinstance(v, (list, tuple)):
            for x in v:
                walk(x)

    for nid in graph.ancestors(node_id) | {node_id}:
        params = graph.nodes[nid].params
        walk(params.model_dump() if hasattr(params, "model_dump") else params)
    return longest + width


def run_preflight(
    graph,
    outputs: dict[str, dict[str, Any]],
    artifacts: dict[str, bytes],
    settings: PreflightSettings | None = None,
    pool=None,
    prefetch=None,
) -> dict | None:
    """The preflight report of a finished run; None when disabled or when the run hands out neither
    a program nor a toolpath. `pool`: the run's workers (`slabs.Workers`), which check the layers
    of a large part in parallel when that pays; `prefetch`: the part's sections the run cut ahead
    (prefetch.SectionPrefetch). The report is the same without either."""
    from ..program.program import Program
    from .check import check_program
    from .conserve import arc_on_by_section, start_conservation
    from .read import read_program, read_toolpath

    s = settings or PreflightSettings()
    if not s.enabled:
        return None
    # the read-backs of the conservation check start first: in the workers, they overlap the rest;
    # the toolpath this preflight reads itself (a run with no program) is summed from its read
    last = _last_toolpath(graph, outputs)
    doc_name = f"{last}.toolpath.json" if last else None
    no_program = not any(isinstance(v, Program) for nid in graph.order for v in outputs.get(nid, {}).values())
    own = frozenset([doc_name]) if doc_name and no_program else frozenset()
    conservation = start_conservation(graph, artifacts, s.deposit_changed, pool, own)
    sums_here: dict[str, dict] = {}
    reports = []
    for nid in graph.order:
        for value in outputs.get(nid, {}).values():
            if not isinstance(value, Program):
                continue
            names = set(value.file_names(nid).values())
            files = {n: artifacts[n].decode("utf-8", "replace") for n in sorted(names) if n in artifacts}
            if not files:
                continue
            prog = read_program(value.format, files)
            if not prog.runs and value.stats.get("tool_on_count", 0):
                continue  # a rolling/peening program deposits nothing
            width, source = _bead_width(graph, nid, s)
            rep = check_program(
                _part_of(graph, outputs, nid),
                prog,
                nid,
                s,
                width,
                weld_expected=prog.weld_commanded or prog.format == "csv",
                stock_mm=_stock_length(graph, nid, width),
                pool=pool,
                prefetch=prefetch,
                cell=getattr(value, "cell", ""),
            )
            rep.update(files=sorted(files), bead_width_mm=width, bead_width_source=source)
            reports.append(rep)
    if not reports:  # no program: the last toolpath a node hands out that deposits
        if last and doc_name and doc_name in artifacts:
            prog = read_toolpath(orjson.loads(artifacts[doc_name]))
            if doc_name in own:
                sums_here[doc_name] = arc_on_by_section(prog)
            width, source = _bead_width(graph, last, s)
            rep = check_program(
                _part_of(graph, outputs, last),
                prog,
                last,
                s,
                width,
                weld_expected=False,
                stock_mm=_stock_length(graph, last, width),
                pool=pool,
                prefetch=prefetch,
            )
            rep.update(
                files=[doc_name],
                bead_width_mm=width,
                bead_width_source=source,
                notes=rep["notes"]
                + [
                    "no program is emitted: the last toolpath was checked (weld data and "
                    "wire volume are the program's to carry)"
                ],
            )
            reports.append(rep)
    if not reports:
        return None  # nothing leaves this run that could build a part
    if last:
        for rep in reports:
            _planned_empty(rep, outputs.get(last, {}))
    return _summary(reports, conservation(sums_here), s)


def _planned_empty(rep: dict, toolpath_outputs: dict) -> None:
    """A top gap above, or a bottom gap below, layers the plan has (its last toolpath's) but welds
    nothing in: the message names them and why such layers weld nothing, where it said to add
    layers or to slice from the bottom (compas_slicer's bunny: its ear tip's one 5.5 mm run dropped
    as shorter than the sequence's min_arc_run_mm; 3MF Consortium's heartgears.3mf: its 11 mm²
    bottom tip, layer 0)."""
    from ..core.errors import layer_ranges
    from ..core.model import Layered, LayerPaths

    from .bottom import FROM_BOTTOM
    from .check import ADD_LAYERS

    planned: list[int] = []
    for value in toolpath_outputs.values():
        if isinstance(value, Layered) and value.items and isinstance(value.items[0], LayerPaths):
            planned = [lp.layer.index for lp in value.items if lp is not None]
            break
    for check, advice, side in (("top_gap", ADD_LAYERS, "above"), ("bottom_gap", FROM_BOTTOM, "below")):
        gaps = [p for p in rep.get("problems", []) if p["check"] == check and p["severity"] == "fail"]
        if not gaps or gaps[0]["layer"] is None or not gaps[0]["message"].endswith(advice):
            continue
        edge = gaps[0]["layer"]
        empty = [i for i in planned if (i > edge if side == "above" else i < edge)]
        if not empty:
            continue
        which = f"layer {empty[0]}" if len(empty) == 1 else f"layers {layer_ranges(empty)}"
        gaps[0]["message"] = gaps[0]["message"].removesuffix(advice) + (
            f"; the plan has {which} {side} it, which weld{'s' if len(empty) == 1 else ''} nothing: see the "
            "warnings of the nodes before (a sequence drops arc runs shorter than its min_arc_run_mm; a "
            "strategy may leave a feature narrower than a bead without a path)"
        )


def _last_toolpath(graph, outputs: dict[str, dict[str, Any]]) -> str | None:
    """The node of the last toolpath the run hands out that deposits (a rolling pass after it does not)."""
    from ..core.model import Layered, LayerPaths

    last = None
    for nid in graph.order:
        for value in outputs.get(nid, {}).values():
            if isinstance(value, Layered) and value.items and isinstance(value.items[0], LayerPaths):
                if last is None or not _treatment_pass(value):
                    last = nid
    return last


def _treatment_pass(value) -> bool:
    """Whether every section of a toolpath is a post-deposition tool's (rolling, peening: `SectionPath.tool`):
    such a pass is skipped as the toolpath to check, as a rolling program is; a toolpath any of whose
    sections is the torch's is checked, even with its arc off throughout (that fails: nothing deposited)."""
    paths = [sp for lp in value.items for sp in lp.sections]
    return bool(paths) and all(sp.tool for sp in paths)


def _summary(reports: list[dict], conserved: list[dict], s: PreflightSettings) -> dict:
    """The run's report from its programs' reports and the conservation check's problems."""
    from .check import VERDICT_ORDER

    verdict = max([r["verdict"] for r in reports] + [p["severity"] for p in conserved], key=VERDICT_ORDER.__getitem__)
    out: dict = {"verdict": verdict, "accepted": False}
    for key in SUMMARY_KEYS:
        vals = [v for r in reports if (v := r.get(key)) is not None]
        if not vals:
            out[key] = None
        elif key in ("min_arc_run_mm", "start_spread_mm"):
            out[key] = min(vals)
        elif key == "wire_part_volume_ratio":
            out[key] = max(vals, key=lambda v: abs(v - 1.0))
        else:
            out[key] = max(vals)
    out["programs"] = reports
    out["problems"] = [p for r in reports for p in r["problems"]] + conserved
    out["layers"] = reports[0]["layers"] if len(reports) == 1 else []
    out["part"] = None
    out["settings"] = s.model_dump(mode="json")
    return out


def first_error(report: dict) -> dict | None:
    return next((p for p in report.get("problems", []) if p["severity"] == "fail"), None)


_TRACE = re.compile(r"^(.*?)waamflow trace:(.*?)$", re.MULTILINE)


def stamp_acceptance(files: dict[str, bytes], report: dict, who: str = "--accept-preflight") -> dict[str, bytes]:
    """Write into each program file's header that its failed preflight was accepted (and why it
    failed), in the file's own comment style (the line before its first `waamflow trace:` line)."""
    names = {n for r in report.get("programs", []) for n in r.get("files", [])}
    fails = [p for p in report.get("problems", []) if p["severity"] == "fail"]
    # short: the line must stay under controllers' line limits (LinuxCNC: 255 characters)
    text = ", ".join(sorted({p["check"] for p in fails})) + " (preflight.json)"
    out = dict(files)
    for name in names:
        if name not in files or name.endswith(".json"):
            continue
        body = files[name].decode("utf-8", "replace")
        m = _TRACE.search(body)
        if not m:
            continue
        close = ")" if m.group(1).rstrip().endswith("(") else ""
        line = (
            f"{m.group(1)}waamflow preflight: FAILED, accepted by the user ({who}): "
            f"{text.replace('(', '[').replace(')', ']')}{close}\n"
        )
        out[name] = (body[: m.start()] + line + body[m.start() :]).encode("utf-8")
    return out


def gate(report: dict | None, files: dict[str, bytes], accept: bool, who: str) -> tuple[dict[str, bytes], dict | None]:
    """What a run may hand out after its preflight: (files, the first failing problem or None).

    A failed preflight keeps the programs inside waamflow (the files hold the report and the plan;
    `report["withheld"]` names what was kept back) unless the user accepts it, in which case every
    program's header says so (`stamp_acceptance`) and `report["accepted"]` is true."""
    if not report or report.get("verdict") != "fail":
        return files, None
    failed = first_error(report) or {
        "check": "preflight",
        "message": "failed",
        "node": None,
        "layer": None,
        "section": None,
    }
    if accept:
        report["accepted"] = True
        files = stamp_acceptance(files, report, who)
    else:
        held = {n for r in report.get("programs", []) for n in r.get("files", []) if not n.endswith(".toolpath.json")}
        report["withheld"] = sorted(held)
        files = {n: d for n, d in files.items() if n not in held}
    files = {**files, "preflight.json": dumps_report(report)}
    return files, failed
