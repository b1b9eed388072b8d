"""Fanuc TP (.LS) read back: the programs in call order, positions from each /POS, the weld values
of each Arc Start's schedule in the schedule table."""

from __future__ import annotations

import math
import re

import numpy as np

from .core import NUM, ProgramRead, RunBuilder
from .orient import axes_euler

_TP_NAME = re.compile(r"^/PROG\s+(\S+)", re.MULTILINE)
_TP_LINE = re.compile(r"^\s*\d+:(.*?);\s*$")
_TP_CALL = re.compile(r"^CALL\s+(\w+)")
_TP_MOVE = re.compile(r"^[LJ]\s+P\[(\d+)\]\s+(" + NUM + r")(mm/sec|cm/min)\b")
_TP_ARC = re.compile(r"^Arc (Start|End)\[(\d+)\]")
_TP_FRAME = re.compile(r"^(UFRAME|UTOOL)_NUM\s*=\s*(\w+)", re.IGNORECASE)
_TP_WAIT = re.compile(r"WAIT\s+(" + NUM + r")\s*\(sec\)")
_TP_CIRCULAR = re.compile(r"[CA]\s+P\[")
_TP_OFFSET = re.compile(r"\b(Offset|Tool_Offset|INC)\b", re.IGNORECASE)
_TP_POS = re.compile(
    r"P\[(\d+)\]\{.*?X =\s*(" + NUM + r")\s*mm,\s*Y =\s*(" + NUM + r")\s*mm,\s*Z =\s*(" + NUM + r")\s*mm"
    r"(?:,\s*W =\s*(" + NUM + r")\s*deg,\s*P =\s*(" + NUM + r")\s*deg,\s*R =\s*(" + NUM + r")\s*deg)?",
    re.DOTALL,
)
_TP_GP2 = re.compile(  # motion group 2's joints in a position block
    r"GP2:[^}]*?J1 =\s*(" + NUM + r")\s*deg(?:,\s*J2 =\s*(" + NUM + r")\s*deg)?(?:,\s*J3 =\s*(" + NUM + r")\s*deg)?"
)
_TP_SPEED = {"mm/sec": 1.0, "cm/min": 10.0 / 60.0}


def _tp_group2(pos: str) -> dict[int, tuple[float, ...]]:
    """P number → motion group 2's joints J1..J3 (a positioner's, degrees; nan where not stated),
    of the /POS blocks that have a `GP2:`: found from the literal GP2, the block's number looked up
    behind it (a regex from each P[ lazily up to its GP2 took 23 ms on curved-duct's 6,787 points)."""
    out: dict[int, tuple[float, ...]] = {}
    seen: dict[tuple[str, ...], tuple[float, ...]] = {}  # the joints' text → values (a layer's points repeat them)
    for m in _TP_GP2.finditer(pos):
        k = pos.rfind("P[", 0, m.start()) + 2
        number = pos[k : pos.find("]", k)]
        if k >= 2 and number.isdigit():
            g = m.groups()
            v = seen.get(g)
            if v is None:
                v = seen[g] = tuple(float(x) if x else math.nan for x in g)
            out[int(number)] = v
    return out


def _tp_schedules(text: str) -> dict[int, dict[str, float]]:
    """schedule → {voltage, current, wire_feed_speed, job} (present, finite values) from the table
    `<NAME>_SCHED.CSV` (columns program.tp.SCHEDULE_COLUMNS, read by name)."""
    import csv
    import io

    cols = {"voltage_V": "voltage", "current_A": "current", "wire_feed_speed_m_min": "wire_feed_speed", "job": "job"}
    out: dict[int, dict[str, float]] = {}
    for row in csv.DictReader(io.StringIO(text)):
        try:
            k = int(row["schedule"])
        except (KeyError, TypeError, ValueError):
            continue
        out[k] = {name: float(row[c]) for c, name in cols.items() if (row.get(c) or "").strip()}
    return out


def read_tp(files: dict[str, str]) -> ProgramRead:
    """Fanuc TP programs in the order the main program calls them (`CALL`); positions from each
    program's own /POS; the weld values of a run are those of its `Arc Start[k]` schedule in the
    schedule table (a run is weld-commanded when schedule k is in the table with a non-zero
    current, voltage or wire feed; a schedule change while welding switches the values)."""
    progs = {m.group(1).upper(): t for t in files.values() if (m := _TP_NAME.search(t))}
    table = next((t for t in files.values() if t.lstrip().startswith("schedule,")), "")
    scheds = _tp_schedules(table)
    b = RunBuilder("tp")
    if not table:
        b.out.notes.append("no weld schedule table (<NAME>_SCHED.CSV): the weld values cannot be read")

    def body(text: str) -> list[str]:
        mn = text.split("\n/MN\n", 1)[-1].split("\n/POS\n", 1)[0]
        return [m.group(1).strip() for ln in mn.splitlines() if (m := _TP_LINE.match(ln))]

    main = next((t for t in progs.values() if any(_TP_CALL.match(x) for x in body(t))), next(iter(progs.values()), ""))
    calls = [m.group(1).upper() for x in body(main) if (m := _TP_CALL.match(x))]
    order = [progs[c] for c in calls if c in progs] or [main]
    vals: dict[str, float] = {}
    line_no = 0
    for text in order:
        found = _TP_POS.findall(text.split("\n/POS\n", 1)[-1])
        pos = {int(f[0]): np.array([float(f[1]), float(f[2]), float(f[3])]) for f in found}
        wpr = [(int(f[0]), f[4:]) for f in found if f[4]]  # Fanuc tool z along the torch, R = Rz(R)·Ry(P)·Rx(W)
        axes = dict(zip((k for k, _ in wpr), axes_euler(np.array([a for _, a in wpr], float), "xyz", 2)))
        ext = _tp_group2(text.split("\n/POS\n", 1)[-1])
        for ln in body(text):
            line_no += 1
            if ln.startswith("!"):
                b.comment(ln[1:].strip())
                continue
            m = _TP_ARC.match(ln)
            if m:
                k = int(m.group(2))
                if m.group(1) == "End":
                    b.close()
                    continue
                if k not in scheds and table:
                    b.out.notes.append(f"line {line_no}: Arc Start[{k}]: schedule {k} not in the table")
                vals = scheds.get(k, {})
                if b.pts is None:
                    b.arc_on(line_no)
                continue
            fr = _TP_FRAME.match(ln)
            if fr:
                b.frame(
                    "user frame" if fr.group(1).upper() == "UFRAME" else "tool frame",
                    fr.group(2),
                    f"line {line_no}: {ln}",
                )
                continue
            w = _TP_WAIT.match(ln)
            if w:  # with the arc on, the wire feeds in one spot
                b.dwell(float(w.group(1)), vals.get("wire_feed_speed", math.nan))
                continue
            if _TP_CIRCULAR.match(ln):
                b.unplaced(f"line {line_no}: {ln}: a circular motion the preflight does not follow (write L motions)")
                continue
            m = _TP_MOVE.match(ln)
            if m and _TP_OFFSET.search(ln):
                b.unplaced(f"line {line_no}: {ln}: an offset or incremental motion the preflight cannot place")
                continue
            if m:
                k = int(m.group(1))
                if k not in pos:
                    b.unplaced(f"line {line_no}: P[{k}] not in the program's /POS")
                    continue
                weld = any(vals.get(n, 0.0) > 0 for n in ("current", "voltage", "wire_feed_speed"))
                b.axis = axes.get(k)
                if k in ext:
                    b.positioner(ext[k])
                b.move(pos[k], float(m.group(2)) * _TP_SPEED[m.group(3)], vals.get("wire_feed_speed", math.nan), weld)
    b.close()
    return b.out
