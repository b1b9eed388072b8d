"""Validate a recipe into an executable graph: types, ports, params, connections, order.

Every connection rule lives in `check_connection` (the GUI mirrors it through the catalog's port
types). Ordering (`graphlib.TopologicalSorter`) is kept apart from execution policy.
"""

from __future__ import annotations

import graphlib
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel, ValidationError

from ..core.errors import RecipeError
from .node import REGISTRY, Node, node_class
from .recipe import Recipe, substitute_inputs


@dataclass
class GraphNode:
    id: str
    type: str
    impl: Node
    params: BaseModel
    raw_params: dict[str, Any]
    inputs: dict[str, tuple[str, str]] = field(default_factory=dict)  # input port → (node id, output port)


@dataclass
class Graph:
    recipe: Recipe
    nodes: dict[str, GraphNode]
    order: list[str]  # topological

    def ancestors(self, node_id: str) -> set[str]:
        out: set[str] = set()
        stack = [node_id]
        while stack:
            cur = stack.pop()
            for src, _ in self.nodes[cur].inputs.values():
                if src not in out:
                    out.add(src)
                    stack.append(src)
        return out


def split_endpoint(text: str, which: str) -> tuple[str, str]:
    if not isinstance(text, str) or text.count(".") != 1 or not all(text.split(".")):
        raise RecipeError(f'edge {which} {text!r} must be "nodeid.port"')
    node, port = text.split(".")
    return node, port


def check_connection(src_type: str, src_port: str, dst_type: str, dst_port: str) -> str | None:
    """The one place that decides whether an output may feed an input. None = ok, else why not."""
    src_cls, dst_cls = REGISTRY.get(src_type), REGISTRY.get(dst_type)
    if src_cls is None or dst_cls is None:
        return "unknown node type"
    out = src_cls.output_port(src_port)
    if out is None:
        names = ", ".join(p.name for p in src_cls.outputs) or "none"
        return f"node type '{src_type}' has no output port '{src_port}' (outputs: {names})"
    inp = dst_cls.input_port(dst_port)
    if inp is None:
        names = ", ".join(p.name for p in dst_cls.inputs) or "none"
        return f"node type '{dst_type}' has no input port '{dst_port}' (inputs: {names})"
    if out.type != inp.type:
        return f"type mismatch: output '{src_port}' is {out.type}, input '{dst_port}' expects {inp.type}"
    return None


def _validate_params(node_id: str, cls: type[Node], raw: dict[str, Any]) -> BaseModel:
    try:
        return cls.Params.model_validate(raw)
    except ValidationError as err:
        e = err.errors()[0]
        loc = ".".join(str(x) for x in e["loc"])
        raise RecipeError(
            f"invalid parameter{(' ' + repr(loc)) if loc else ''}: {e['msg']}", node=node_id, field=loc or None
        ) from None


def build_graph(recipe: Recipe) -> Graph:
    """Validate `recipe` (inputs already applied via `recipe.inputs`) and order its nodes. Only
    the node modules declaring the recipe's node types are imported (`node_class`)."""
    nodes: dict[str, GraphNode] = {}
    for entry in recipe.nodes:
        if entry.id in nodes:
            raise RecipeError(f"duplicate node id {entry.id!r}", node=entry.id)
        cls = node_class(entry.type)
        if cls is None:
            raise RecipeError(f"unknown node type {entry.type!r} (see `waamflow nodes`)", node=entry.id, field="type")
        raw = substitute_inputs(entry.params, recipe.inputs, entry.id)
        nodes[entry.id] = GraphNode(entry.id, entry.type, cls(), _validate_params(entry.id, cls, raw), raw)

    for edge in recipe.edges:
        src, sport = split_endpoint(edge.from_, "from")
        dst, dport = split_endpoint(edge.to, "to")
        for nid in (src, dst):
            if nid not in nodes:
                raise RecipeError(f"edge {edge.from_} → {edge.to}: no node with id {nid!r}", node=nid)
        why = check_connection(nodes[src].type, sport, nodes[dst].type, dport)
        if why:
            raise RecipeError(f"edge {edge.from_} → {edge.to}: {why}", node=dst)
        if dport in nodes[dst].inputs:
            raise RecipeError(f"input '{dport}' has more than one incoming edge", node=dst)
        nodes[dst].inputs[dport] = (src, sport)

    for n in nodes.values():
        for port in n.impl.inputs:
            if not port.optional and port.name not in n.inputs:
                raise RecipeError(f"required input '{port.name}' ({port.type}) is not connected", node=n.id)

    sorter = graphlib.TopologicalSorter({n.id: {src for src, _ in n.inputs.values()} for n in nodes.values()})
    try:
        order = list(sorter.static_order())
    except graphlib.CycleError as err:
        cycle = err.args[1]
        raise RecipeError(f"the graph has a cycle: {' → '.join(cycle)}", node=cycle[0]) from None
    # Stable order: keep recipe order among independent nodes (static_order is deterministic but
    # not recipe-ordered); a simple Kahn pass by recipe index gives the user's reading order.
    index = {e.id: i for i, e in enumerate(recipe.nodes)}
    remaining = {n.id: {src for src, _ in n.inputs.values()} for n in nodes.values()}
    order = []
    while remaining:
        ready = sorted((nid for nid, deps in remaining.items() if not deps), key=index.__getitem__)
        nid = ready[0]
        order.append(nid)
        del remaining[nid]
        for deps in remaining.values():
            deps.discard(nid)
    return Graph(recipe, nodes, order)
