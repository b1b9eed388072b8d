"""Yaskawa INFORM read back: the jobs in the order the main job calls them, C positions from each
job's //POS, current and voltage from ARCON/ARCSET."""

from __future__ import annotations

import math
import re

import numpy as np

from .core import NUM, ProgramRead, RunBuilder

_JOB_NAME = re.compile(r"^//NAME\s+(\S+)", re.MULTILINE)
_JOB_CALL = re.compile(r"^CALL\s+JOB:(\S+)", re.MULTILINE)
_CPOS = re.compile(r"^C(\d+)=(" + NUM + r"),(" + NUM + r"),(" + NUM + r")", re.MULTILINE)
_INF_MOVE = re.compile(r"^S?MOV[LJ]\s+C(\d+)\b.*?\bV=(" + NUM + r")")
_INF_VAL = re.compile(r"\b(AC|AV)=(" + NUM + r")")


def read_inform(files: dict[str, str]) -> ProgramRead:
    """INFORM jobs in the order the main job calls them (`CALL JOB:`); positions from each job's
    own //POS; the weld values are ARCON/ARCSET's AC= (current A) and AV= (voltage V)."""
    jobs = {m.group(1).upper(): t for t in files.values() if (m := _JOB_NAME.search(t))}
    main = next((t for t in files.values() if _JOB_CALL.search(t)), next(iter(files.values())))
    order = [jobs[c.upper()] for c in _JOB_CALL.findall(main) if c.upper() in jobs] or [main]
    b = RunBuilder("inform")
    vals: dict[str, float] = {}
    line_no = 0
    for text in order:
        pos = {int(k): np.array([float(x), float(y), float(z)]) for k, x, y, z in _CPOS.findall(text)}
        inst = text.split("//INST", 1)[-1]
        for raw in inst.splitlines():
            line_no += 1
            ln = raw.strip()
            if ln.startswith("'"):
                b.comment(ln[1:])
                continue
            if ln.startswith(("ARCON", "ARCSET")):
                vals.update({k: float(v) for k, v in _INF_VAL.findall(ln)})
                if ln.startswith("ARCON"):
                    b.arc_on(line_no)
                continue
            if ln.startswith("ARCOF"):
                b.close()
                continue
            m = _INF_MOVE.match(ln)
            if m:
                k = int(m.group(1))
                if k not in pos:
                    b.out.notes.append(f"line {line_no}: C{k:05d} not in the job's //POS")
                    continue
                weld = bool(vals.get("AC") or vals.get("AV"))
                b.move(pos[k], float(m.group(2)), math.nan, weld)
    b.close()
    return b.out
