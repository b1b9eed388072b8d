"""A structural checker of Yaskawa INFORM jobs (.JBI) as the controller's loader reads them:
header sections in order, //NAME an upper-case identifier of at most 32 characters, ///NPOS equal
to the C position lines (numbered from C00000), every MOVL naming a declared position, ARCON /
ARCSET / ARCOF paired with the arc state, comments at most 32 characters, END last. A
coordinated job (a positioner as station 1): ///NPOS's third field equal to the EC position lines
(numbered from EC00000, whole pulses, after `///POSTYPE PULSE` / `///PULSE`, as many per line as
the first), `///GROUP2 ST1` exactly then, and every motion `SMOVL Cn ... +MOVJ ECn` (the station
position of the same point); `station` gives the EC pulses per motion. Written from the INFORM
manual's job-file layout, independent of the writer."""

from __future__ import annotations

import re

INSTRUCTIONS = ("MOVL", "SMOVL", "ARCON", "ARCSET", "ARCOF", "TIMER", "CALL", "SET")


def check_jbi(text: str) -> dict:
    """Structure an INFORM job must have; returns counts. Raises AssertionError naming the fault."""
    lines = text.rstrip("\n").split("\n")
    assert lines[0] == "/JOB" and lines[1].startswith("//NAME ") and lines[2] == "//POS", lines[:3]
    name = lines[1].split()[1]
    assert re.fullmatch(r"[A-Z][A-Z0-9_]{0,31}", name), name
    npos = next(ln for ln in lines if ln.startswith("///NPOS"))
    n_c = int(npos.split()[1].split(",")[0])
    n_ec = int(npos.split()[1].split(",")[2])
    defined = [int(m.group(1)) for ln in lines if (m := re.match(r"^C(\d{5})=", ln))]
    assert defined == list(range(n_c)), f"{name}: NPOS {n_c}, C lines {len(defined)}"
    inst = lines.index("//INST")
    ec_lines = [(int(m.group(1)), m.group(2)) for ln in lines[:inst] if (m := re.match(r"^EC(\d{5})=(.*)$", ln))]
    assert [k for k, _ in ec_lines] == list(range(n_ec)), f"{name}: NPOS EC {n_ec}, EC lines {len(ec_lines)}"
    ec = {}
    if n_ec:
        first_ec = next(i for i, ln in enumerate(lines) if ln.startswith("EC"))
        assert lines[first_ec - 2 : first_ec] == ["///POSTYPE PULSE", "///PULSE"], f"{name}: EC not in pulses"
        for k, vals in ec_lines:
            assert re.fullmatch(r"-?\d+(,-?\d+){0,2}", vals), f"{name}: EC{k:05d}={vals}"
            ec[k] = [int(v) for v in vals.split(",")]
        assert len({len(v) for v in ec.values()}) == 1, f"{name}: EC lines with different axis counts"
    assert "///GROUP1 RB1" in lines[inst:] and lines[-1] == "END"
    assert ("///GROUP2 ST1" in lines[inst:]) == bool(n_ec), f"{name}: GROUP2 ST1 exactly when EC positions exist"
    body = lines[lines.index("NOP") + 1 : -1]
    arc, arcs = False, 0
    used = set()
    station = []
    for ln in body:
        if ln.startswith("'"):
            assert len(ln) <= 33, f"{name}: comment over 32 characters: {ln!r}"
            continue
        word = ln.split()[0]
        assert word in INSTRUCTIONS, f"{name}: {ln!r}"
        if word in ("MOVL", "SMOVL"):
            assert (word == "SMOVL") == bool(n_ec), f"{name}: SMOVL exactly in a coordinated job: {ln!r}"
            m = re.fullmatch(r"S?MOVL C(\d{5}) V=\d+\.\d PL=[0-8]( \+MOVJ EC(\d{5}))?", ln)
            assert m and (m.group(2) is not None) == bool(n_ec), ln
            used.add(int(m.group(1)))
            if n_ec:
                assert m.group(3) == m.group(1), f"{name}: {ln!r}: the station position of another point"
                station.append(ec[int(m.group(3))])
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
    return {"name": name, "positions": n_c, "arcs": arcs, "station": station}


def check_program(files: dict[str, str]) -> dict:
    """Every job of a program; the main job's CALLs name the other jobs in order."""
    info = {k: check_jbi(v) for k, v in files.items()}
    main = next((v for v in files.values() if re.search(r"^CALL JOB:", v, re.M)), None)
    names = {i["name"] for i in info.values()}
    if main is not None:
        calls = re.findall(r"^CALL JOB:(\S+)$", main, re.M)
        called = [c for c in calls if c in names]
        assert called, "the main job calls none of the program's jobs"
    motions = sum(len(re.findall(r"^S?MOVL ", v, re.M)) for v in files.values())
    return {
        "motions": motions,
        "points_declared": sum(i["positions"] for i in info.values()),
        "arcs": sum(i["arcs"] for i in info.values()),
        "jobs": len(files),
        # station pulses per motion, jobs in the main job's call order
        "station": [p for k in _call_order(files) for p in info[k]["station"]],
    }


def _call_order(files: dict[str, str]) -> list[str]:
    """The file keys of the jobs in the order the main job calls them (the main job first)."""
    by_name = {re.search(r"^//NAME (\S+)$", v, re.M).group(1): k for k, v in files.items()}
    main = next((k for k, v in files.items() if re.search(r"^CALL JOB:", v, re.M)), None)
    if main is None:
        return list(files)
    calls = re.findall(r"^CALL JOB:(\S+)$", files[main], re.M)
    return [main, *(by_name[c] for c in calls if c in by_name)]
