"""`waamflow build-sim RECIPE`: plan the recipe, then build it in the process simulator open loop
and closed loop; write `asbuilt.json` and `asbuilt.svg` (top-height error per layer, both loops).

The toolpath built is the one the recipe's (first) post-process node writes, else the last
`toolpath` output of the graph.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..core.errors import RecipeError
from .adapt import Window
from .sim import Disturbance, simulate_build


def program_toolpath(graph, outputs: dict):
    """The toolpath the recipe's post-process node programs (else the last toolpath output)."""
    for nid in graph.order:
        node = graph.nodes[nid]
        if node.type == "post-process" and "toolpath" in node.inputs:
            src, port = node.inputs["toolpath"]
            return outputs[src][port], src
    last = None
    for nid in graph.order:
        value = (outputs.get(nid) or {}).get("toolpath")
        if value is not None:
            last = (value, nid)
    if last is None:
        raise RecipeError("the recipe has no toolpath to build (add a strategy/sequence node)")
    return last


def build_sim(
    recipe_path: Path,
    overrides: list,
    modes: tuple[str, ...] = ("open", "closed"),
    dist: Disturbance = Disturbance(),
    window: Window = Window(),
) -> dict:
    from ..engine.executor import FileResolver, execute
    from ..engine.graph import build_graph
    from ..engine.recipe import apply_overrides, load_recipe

    recipe = apply_overrides(load_recipe(recipe_path), overrides)
    graph = build_graph(recipe)
    t0 = time.perf_counter()
    result = execute(graph, resolver=FileResolver(recipe_path.resolve().parent), artifacts=False, preflight=False)
    plan_s = time.perf_counter() - t0
    toolpath, node = program_toolpath(graph, result.outputs)
    doc = {
        "recipe": recipe.name,
        "toolpath_node": node,
        "layers_planned": sum(1 for x in toolpath.items if x is not None),
        "plan_seconds": round(plan_s, 3),
        "disturbance": asdict(dist),
        "window": asdict(window),
        "builds": {},
    }
    for mode in modes:
        t1 = time.perf_counter()
        log = simulate_build(toolpath, mode, dist, window)
        doc["builds"][mode] = {**log.summary(), "seconds": round(time.perf_counter() - t1, 3), "layers": log.layers}
    return doc


def svg(doc: dict) -> str:
    from ..process.svgplot import Chart, figure

    colors = {"open": "#c0392b", "closed": "#1f6fb2"}
    rows = {m: b["layers"] for m, b in doc["builds"].items()}
    n = max((len(r) for r in rows.values()), default=1)
    ys = [x["mean_error_mm"] for r in rows.values() for x in r] + [x["rms_error_mm"] for r in rows.values() for x in r]
    lo, hi = (min(ys + [0.0]), max(ys + [0.0])) if ys else (-1.0, 1.0)
    ch = Chart(
        64,
        44,
        760,
        300,
        (0.0, max(n - 1, 1)),
        (lo - 0.1 * (hi - lo + 1e-9), hi + 0.1 * (hi - lo + 1e-9)),
        title=f"{doc['recipe']}: top height vs plan after each layer (simulated build)",
        x_label="layer built (in order)",
        y_label="top error, mm",
        legend="left",
    )
    ch.hline(0.0, "#888")
    for m, r in rows.items():
        xs = np.arange(len(r))
        ch.line(xs, [x["mean_error_mm"] for x in r], colors.get(m, "#333"), label=f"{m} loop: mean")
        ch.line(xs, [x["rms_error_mm"] for x in r], colors.get(m, "#333"), dash="4 3", label=f"{m} loop: RMS")
    return figure(900, 390, [ch])


def write(doc: dict, out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    a, b = out / "asbuilt.json", out / "asbuilt.svg"
    a.write_text(json.dumps(doc, indent=1))
    b.write_text(svg(doc))
    return [a, b]


class _PostContext:
    """The little the post-process node asks of the engine when it writes one layer."""

    def __init__(self, node_id: str) -> None:
        self.node_id = node_id
        self.layer = None
        self.warnings: list[dict] = []

    def warn(self, message: str, *, layer: int | None = None, section: str | None = None) -> None:
        self.warnings.append({"node": self.node_id, "message": message, "layer": layer, "section": section})


def post_callable(graph, post_id: str):
    """`(lp, header=(), dwell_s=0, dwell_why="") -> {file name: text}`: the recipe's post-process
    node writing a one-layer program with the recipe's own settings (dialect, profile, weld data,
    cell); `header` lines are stated in the program's header comments (`stamp_header`); `dwell_s`
    > 0 makes the program wait that long at its start (the interlayer dwell, `dwell_why` beside it)."""
    from .dwell import with_dwell_before

    node = graph.nodes[post_id]

    def post(lp, header: tuple[str, ...] | list[str] = (), dwell_s: float = 0.0, dwell_why: str = "") -> dict[str, str]:
        ctx = _PostContext(post_id)
        program = node.impl.run(ctx, node.params, {"toolpath": with_dwell_before(lp, dwell_s, dwell_why)})["program"]
        names = program.file_names(post_id)
        files = stamp_header(program.format, dict(program.files), list(header))
        return {names[k]: v for k, v in files.items()}

    return post


def stamp_header(fmt: str, files: dict[str, str], lines: list[str]) -> dict[str, str]:
    """Program files with `lines` in their header comments, in each format's comment syntax (the
    places `program.common.stamp_trace` puts the trace: G-code and CSV at the top, KRL after
    `DEF`/`DEFDAT`, RAPID after `MODULE`, INFORM after the main job's NOP and Fanuc TP as /MN
    comments — those two hold 32 characters a comment, so long lines are cut into pieces)."""
    if not lines or fmt == "printpoints":
        return dict(files)
    out = {}
    for suffix, text in files.items():
        rows = text.split("\n")
        if fmt == "gcode":
            at = next((i for i, ln in enumerate(rows) if ln.lstrip().startswith((";", "("))), 0)
            paren = rows[at].lstrip().startswith("(") if rows else False
            rows = (
                rows[:at]
                + [f"({b.replace('(', '[').replace(')', ']')})" if paren else f"; {b}" for b in lines]
                + rows[at:]
            )
        elif fmt == "csv":
            rows = [f"# {b}" for b in lines] + rows
        elif fmt in ("inform", "tp"):
            if suffix != {"inform": "JBI", "tp": "LS"}[fmt]:
                out[suffix] = text
                continue
            short = [b[i : i + 32] for b in lines for i in range(0, len(b), 32)]
            if fmt == "tp":
                from ..program.tp import with_comments

                out[suffix] = with_comments(text, short)
                continue
            at = next((i + 1 for i, ln in enumerate(rows) if ln.strip() == "NOP"), 0)
            rows = rows[:at] + ["'" + b for b in short] + rows[at:]
        else:
            opener = ("MODULE ",) if fmt == "rapid" else ("DEF ", "DEFDAT ")
            at = next((i + 1 for i, ln in enumerate(rows) if ln.lstrip().startswith(opener)), 0)
            mark = "  ! " if fmt == "rapid" else "; "
            rows = rows[:at] + [f"{mark}{b}" for b in lines] + rows[at:]
        out[suffix] = "\n".join(rows)
    return out


def dwell_rule_of(graph, interpass_c: float | None = None, max_dwell_s: float | None = None):
    """The interpass dwell rule of a build: the heat model of the recipe's (first) interpass node,
    else the default model; `interpass_c` (the build's target) overrides the node's."""
    from ..process.interpass import HeatModel
    from .dwell import MAX_DWELL_S, DwellRule, heat_model_of

    node = next((graph.nodes[nid] for nid in graph.order if graph.nodes[nid].type == "interpass"), None)
    if node is not None:
        model, source = heat_model_of(node.params, interpass_c), f"heat model of interpass node {node.id!r}"
    else:
        model = HeatModel() if interpass_c is None else HeatModel(interpass_c=interpass_c)
        source = "default heat model (steel, 1 kg substrate)"
    if model.interpass_c <= model.ambient_c:
        raise RecipeError(f"interpass_c {model.interpass_c:g} °C must be above ambient {model.ambient_c:g} °C")
    return DwellRule(model, MAX_DWELL_S if max_dwell_s is None else float(max_dwell_s), source)


def plan_for_build(recipe, resolver):
    """Plan `recipe` and return (toolpath, post callable or None, toolpath node id)."""
    from ..engine.executor import execute
    from ..engine.graph import build_graph

    graph = build_graph(recipe)
    result = execute(graph, resolver=resolver, artifacts=False, preflight=False)
    toolpath, src = program_toolpath(graph, result.outputs)
    post_id = next((nid for nid in graph.order if graph.nodes[nid].type == "post-process"), None)
    return toolpath, (post_callable(graph, post_id) if post_id else None), src
