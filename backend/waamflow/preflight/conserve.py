"""Deposit conservation: a node that only orders the deposit welds what it was given.

The sequence node chooses the order and direction of a layer's sections and where a closed loop
starts; it never re-plans a bead. So, read back from the two `toolpath.json` artifacts as written,
every (layer, section) welds as many millimetres arc-ON after the node as before it. The one
licensed change is the minimum arc run: a short run bridged to its neighbour or dropped (the node
warns each one) changes the section's number of arc-ON runs, and such sections are left out. A
section whose run count holds but whose length moves is a planning defect — the fault class of a
filleted L wall read as a two-pass serpentine and re-threaded without its corner (thin-wall-panel,
fillet_radius 3: 1459.479 mm welded on odd layers against 1412.334 mm planned).
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any, Callable, Protocol, cast

import numpy as np
import orjson

from ..core.tolerances import TOL
from .read import ProgramRead, read_toolpath

#: node type → its input port whose deposit the node's `toolpath` output must keep
KEEPS_DEPOSIT = {"sequence": "toolpath"}
#: mm: the artifacts round coordinates to `serialize.DECIMALS` (1e-4 mm), the same on both sides
#: except for the points a sequencer inserts (a loop's seam, zone cuts), which lie on a segment and
#: move its length by ~1e-8 mm; a lost corner moves it by millimetres. One `TOL.min_segment`.
LENGTH_TOL_MM = TOL.min_segment


def arc_on_by_section(prog: ProgramRead) -> dict[tuple[int | None, str | None], tuple[float, int]]:
    """(layer, section) → (arc-ON length mm, number of arc-ON runs)."""
    out: dict = defaultdict(lambda: (0.0, 0))
    for r in prog.runs:
        length = float(np.linalg.norm(np.diff(r.points, axis=0), axis=1).sum())
        total, runs = out[(r.layer, r.section)]
        out[(r.layer, r.section)] = (total + length, runs + 1)
    return dict(out)


def deposit_changes(before: ProgramRead, after: ProgramRead, tol: float = LENGTH_TOL_MM) -> list[dict]:
    """The (layer, section)s with as many arc-ON runs after as before but another arc-ON length:
    dicts with layer, section, before_mm, after_mm; sorted by layer then section."""
    return changes_between(arc_on_by_section(before), arc_on_by_section(after), tol)


def changes_between(a: dict, b: dict, tol: float = LENGTH_TOL_MM) -> list[dict]:
    """`deposit_changes` of two `arc_on_by_section` maps (before, after)."""
    out = []
    for key in sorted(set(a) | set(b), key=lambda k: (-1 if k[0] is None else k[0], k[1] or "")):
        (la, na), (lb, nb) = a.get(key, (0.0, 0)), b.get(key, (0.0, 0))
        if na == nb and abs(lb - la) > tol:
            out.append({"layer": key[0], "section": key[1], "before_mm": la, "after_mm": lb})
    return out


class Submits(Protocol):
    """The run's workers as far as the conservation check uses them: one task started in a worker
    (a future), or None when they cannot take it (the check then runs here)."""

    def submit(self, fn: Callable[[Any], Any], item: Any) -> Any: ...


def read_back_changes(pair: tuple[bytes, bytes]) -> list[dict]:
    """`deposit_changes` of the (before, after) `toolpath.json` artifacts as written (worker side,
    or this process): what a worker sends back is the few changes, not the programs read."""
    before, after = (read_toolpath(orjson.loads(doc)) for doc in pair)
    return deposit_changes(before, after)


def arc_on_of_doc(doc: bytes) -> dict[tuple[int | None, str | None], tuple[float, int]]:
    """`arc_on_by_section` of one `toolpath.json` artifact as written (worker side: one task per
    document, so a node's two read-backs run side by side; what comes back is the few sums)."""
    return arc_on_by_section(read_toolpath(orjson.loads(doc)))


def _pairs(graph, artifacts: dict[str, bytes]) -> list[tuple[str, str, tuple[str, str], tuple[bytes, bytes]]]:
    """(node, its source node, the names and the bytes of (source's, node's toolpath.json)) of every node checked."""
    out = []
    for nid in graph.order:
        node = graph.nodes[nid]
        port = KEEPS_DEPOSIT.get(node.type)
        if port is None or port not in node.inputs:
            continue
        src = node.inputs[port][0]
        names = (f"{src}.toolpath.json", f"{nid}.toolpath.json")
        if all(n in artifacts for n in names):
            out.append((nid, src, names, (artifacts[names[0]], artifacts[names[1]])))
    return out


def start_conservation(
    graph,
    artifacts: dict[str, bytes],
    severity: str = "fail",
    pool: Submits | None = None,
    read_here: frozenset[str] = frozenset(),
) -> Callable[..., list[dict]]:
    """`check_conservation` begun: with the run's workers, its read-backs start in them at once and
    overlap the program checks (two toolpath.json parsed per sequence node: ~0.8 s of the
    500-layer cross's preflight), one task per document (`arc_on_of_doc`): the two halves of a
    node's read-back run side by side instead of one worker taking both while the other waits for
    the slab tasks (the 500-layer cross: 0.42 s of CPU in one task). Call the result for the
    problems, with `{artifact name: arc_on_by_section}` of the documents in `read_here`: those the
    preflight reads back itself (a recipe without a program checks the sequence's toolpath.json),
    summed from its read, not parsed a second time. The same problems either way."""
    if severity == "off":
        return lambda sums_here=None: []
    pairs = _pairs(graph, artifacts)
    futures: list[Any] = []
    for _nid, _src, names, docs in pairs:
        for name, doc in zip(names, docs):
            try:
                futures.append(pool.submit(arc_on_of_doc, doc) if pool is not None and name not in read_here else None)
            except Exception:  # the workers are gone: read it here
                futures.append(None)

    def sums(fut: Any, doc: bytes) -> dict:
        if fut is not None:
            try:
                return cast(dict, fut.result())
            except Exception:  # a worker died: read it here (its own error is raised here)
                pass
        return arc_on_of_doc(doc)

    def finish(sums_here: dict[str, dict] | None = None) -> list[dict]:
        problems: list[dict] = []
        got = sums_here or {}
        for k, (nid, src, names, docs) in enumerate(pairs):
            before, after = (got[names[j]] if names[j] in got else sums(futures[2 * k + j], docs[j]) for j in (0, 1))
            problems += _problems(nid, src, changes_between(before, after), severity)
        return problems

    return finish


def check_conservation(graph, artifacts: dict[str, bytes], severity: str = "fail") -> list[dict]:
    """Preflight problems (check `deposit_changed`, one per node and layer, naming the first section)
    for every node of a `KEEPS_DEPOSIT` type whose input and output toolpath artifacts are both
    present. A node fed by one that writes no `toolpath.json` (bead-trials: `fill-parameters`) is
    not checked: comparing with the planner's objects instead would not be reading what was written."""
    return start_conservation(graph, artifacts, severity)()


def _problems(nid: str, src: str, changes: list[dict], severity: str) -> list[dict]:
    """One problem per layer of a node's deposit changes."""
    problems = []
    by_layer: dict = defaultdict(list)
    for c in changes:
        by_layer[c["layer"]].append(c)
    for layer, cs in by_layer.items():
        first = cs[0]
        la = sum(c["before_mm"] for c in cs)
        lb = sum(c["after_mm"] for c in cs)
        secs = ", ".join(str(c["section"]) for c in cs)
        problems.append(
            {
                "check": "deposit_changed",
                "severity": severity,
                "node": nid,
                "layer": layer,
                "section": first["section"],
                "message": (
                    f"{nid} welds {lb:.3f} mm arc-ON in section(s) {secs} of layer {layer} where {src} "
                    f"planned {la:.3f} mm: a sequencer only orders, reverses and re-seams the deposit, "
                    "so this is a planning defect (report it); the program does not build the planned part"
                ),
                "value": round(lb - la, 4),
                "limit": LENGTH_TOL_MM,
                "point": None,
            }
        )
    return problems


__all__ = [
    "KEEPS_DEPOSIT",
    "arc_on_by_section",
    "arc_on_of_doc",
    "changes_between",
    "check_conservation",
    "deposit_changes",
    "read_back_changes",
    "start_conservation",
]
