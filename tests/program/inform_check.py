"""A structural checker of Yaskawa INFORM jobs (.JBI) as the controller's loader reads them:
header sections in order, //NAME an upper-case identifier of at most 32 characters, ///NPOS equal
to the C position lines (numbered from C00000), every MOVL naming a declared position, ARCON /
ARCSET / ARCOF paired with the arc state, comments at most 32 characters, END last. Written from
the INFORM manual's job-file layout, independent of the writer."""

from __future__ import annotations

import re

INSTRUCTIONS = ("MOVL", "ARCON", "ARCSET", "ARCOF", "TIMER", "CALL", "SET")


def check_jbi(text: str) -> dict:
    """Structure an INFORM job must have; returns counts. Raises AssertionError naming the fault."""
    lines = text.rstrip("\n").split("\n")
    assert lines[0] == "/JOB" and lines[1].startswith("//NAME ") and lines[2] == "//POS", lines[:3]
    name = lines[1].split()[1]
    assert re.fullmatch(r"[A-Z][A-Z0-9_]{0,31}", name), name
    npos = next(ln for ln in lines if ln.startswith("///NPOS"))
    n_c = int(npos.split()[1].split(",")[0])
    defined = [int(m.group(1)) for ln in lines if (m := re.match(r"^C(\d{5})=", ln))]
    assert defined == list(range(n_c)), f"{name}: NPOS {n_c}, C lines {len(defined)}"
    inst = lines.index("//INST")
    assert "///GROUP1 RB1" in lines[inst:] and lines[-1] == "END"
    body = lines[lines.index("NOP") + 1:-1]
    arc, arcs = False, 0
    used = set()
    for ln in body:
        if ln.startswith("'"):
            assert len(ln) <= 33, f"{name}: comment over 32 characters: {ln!r}"
            continue
        word = ln.split()[0]
        assert word in INSTRUCTIONS, f"{name}: {ln!r}"
        if word == "MOVL":
            m = re.fullmatch(r"MOVL C(\d{5}) V=\d+\.\d PL=[0-8]", ln)
            assert m, ln
            used.add(int(m.group(1)))
        elif word == "ARCON":
            assert not arc, f"{name}: ARCON while the arc is on"
            arc, arcs = True, arcs + 1
            assert re.fullmatch(r"ARCON( AC=\d+)?( AV=\d+\.\d)? T=\d+\.\d\d", ln), ln
        elif word == "ARCSET":
            assert arc and re.fullmatch(r"ARCSET( AC=\d+)?( AV=\d+\.\d)?", ln), ln
        elif word == "ARCOF":
            assert arc, f"{name}: ARCOF without ARCON"
            arc = False
    assert not arc, f"{name}: the job ends with the arc on"
    assert used <= set(defined)
    return {"name": name, "positions": n_c, "arcs": arcs}


def check_program(files: dict[str, str]) -> dict:
    """Every job of a program; the main job's CALLs name the other jobs in order."""
    info = {k: check_jbi(v) for k, v in files.items()}
    main = next((v for v in files.values() if re.search(r"^CALL JOB:", v, re.M)), None)
    names = {i["name"] for i in info.values()}
    if main is not None:
        calls = re.findall(r"^CALL JOB:(\S+)$", main, re.M)
        called = [c for c in calls if c in names]
        assert called, "the main job calls none of the program's jobs"
    motions = sum(len(re.findall(r"^MOVL ", v, re.M)) for v in files.values())
    return {"motions": motions, "points_declared": sum(i["positions"] for i in info.values()),
            "arcs": sum(i["arcs"] for i in info.values()), "jobs": len(files)}
