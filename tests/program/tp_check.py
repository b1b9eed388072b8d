"""A structural checker of Fanuc TP programs (ASCII .LS) as the controller's ASCII loader reads
them: sections /PROG /ATTR /APPL /MN /POS /END in order, a program name of upper-case letters,
digits and '_' (letter first, at most 36), LINE_COUNT equal to the /MN lines, numbered 1..n, every
line ending in `;`, motions `L P[i] <speed>mm/sec|cm/min FINE|CNTn` with whole-number speeds,
every P[i] used declared in /POS and every declared one used, Arc Start / Arc End paired (an Arc
Start while welding is a schedule change), every schedule used in the schedule table, comments at
most 32 characters. Written from the TP program layout, independent of the writer."""

from __future__ import annotations

import csv
import io
import re

SECTIONS = ("/PROG", "/ATTR", "/APPL", "/MN", "/POS", "/END")
INSTRUCTION = re.compile(
    r"^(UFRAME_NUM=\d+|UTOOL_NUM=\d+|WAIT\s+\d+\.\d\d\(sec\)|CALL [A-Z][A-Z0-9_]*|"
    r"R\[\d+\]=[-\d.]+|Arc (Start|End)\[\d+\])$"
)
MOTION = re.compile(r"^L P\[(\d+)\] (\d+)(mm/sec|cm/min) (FINE|CNT(\d{1,3}))( COORD)?$")
POS = re.compile(
    r"^P\[(\d+)\]\{\n   GP1:\n\tUF : \d, UT : \d+,\t\tCONFIG : '[NF] [UD] [TB], 0, 0, 0',\n"
    r"\tX = +-?\d+\.\d{3} mm,\tY = +-?\d+\.\d{3} mm,\tZ = +-?\d+\.\d{3} mm,\n"
    r"\tW = +-?\d+\.\d{3} deg,\tP = +-?\d+\.\d{3} deg,\tR = +-?\d+\.\d{3} deg\n"
    r"(   GP2:\n\tUF : \d, UT : \d+,\n\tJ1 = +-?\d+\.\d{3} deg(?:,\tJ2 = +-?\d+\.\d{3} deg)?"
    r"(?:,\tJ3 = +-?\d+\.\d{3} deg)?\n)?\};$",
    re.M,
)
JOINTS = re.compile(r"J\d = +(-?\d+\.\d{3}) deg")


def read_schedules(text: str) -> dict[int, dict[str, str]]:
    """The schedule table: schedule number → its row (column → text)."""
    return {int(r["schedule"]): r for r in csv.DictReader(io.StringIO(text))}


def check_ls(text: str, schedules: dict[int, dict] | None = None) -> dict:
    """Structure a TP program must have; returns counts. Raises AssertionError naming the fault."""
    lines = text.rstrip("\n").split("\n")
    at = [next(i for i, ln in enumerate(lines) if ln.split()[0] == s) for s in SECTIONS]
    assert at == sorted(at) and at[0] == 0 and at[-1] == len(lines) - 1, f"sections out of order: {at}"
    name = lines[0].split()[1]
    assert re.fullmatch(r"[A-Z][A-Z0-9_]{0,35}", name), name
    attr = "\n".join(lines[at[1] : at[2]])
    count = int(re.search(r"^LINE_COUNT\s*= (\d+);$", attr, re.M).group(1))
    group = re.search(r"^DEFAULT_GROUP\s*= 1,([1*]),\*,\*,\*;$", attr, re.M)
    assert group, name
    gp2 = group.group(1) == "1"
    assert re.search(r'^COMMENT\s*= "[^"]{0,16}";$', attr, re.M), name
    for key in ("OWNER", "PROG_SIZE", "CREATE", "MODIFIED", "PROTECT", "CONTROL_CODE"):
        assert re.search(rf"^{key}\s*= .*;$", attr, re.M), f"{name}: no {key}"
    mn = lines[at[3] + 1 : at[4]]
    assert len(mn) == count, f"{name}: LINE_COUNT {count}, /MN lines {len(mn)}"
    used: list[int] = []
    arc, arcs, scheds = False, 0, set()
    calls = []
    for k, ln in enumerate(mn, 1):
        m = re.fullmatch(r" *(\d+):(.*);", ln)
        assert m and int(m.group(1)) == k, f"{name}: line {k} numbered wrong: {ln!r}"
        body = m.group(2).strip()
        if body.startswith("!"):
            assert len(body[1:].strip()) <= 32, f"{name}: comment over 32 characters: {ln!r}"
            continue
        mo = MOTION.match(body)
        if mo:
            assert 1 <= int(mo.group(2)) and (mo.group(5) is None or int(mo.group(5)) <= 100), ln
            assert (mo.group(6) is not None) == gp2, f"{name}: line {k}: COORD exactly when group 2 moves"
            used.append(int(mo.group(1)))
            continue
        assert INSTRUCTION.match(body), f"{name}: line {k}: {body!r}"
        a = re.match(r"Arc (Start|End)\[(\d+)\]", body)
        if a:
            s = int(a.group(2))
            scheds.add(s)
            if schedules is not None:
                assert s in schedules, f"{name}: schedule {s} not in the table"
            if a.group(1) == "Start":
                arcs += 0 if arc else 1
                arc = True
            else:
                assert arc, f"{name}: Arc End without Arc Start (line {k})"
                arc = False
        if body.startswith("CALL "):
            calls.append(body.split()[1])
    assert not arc, f"{name}: the program ends with the arc on"
    pos_text = "\n".join(lines[at[4] + 1 : at[5]])
    entries = POS.findall(pos_text)
    declared = [int(x) for x, _gp2 in entries]
    assert all(bool(g) == gp2 for _x, g in entries), f"{name}: a GP2 block exactly when DEFAULT_GROUP has group 2"
    joints = {int(x): [float(v) for v in JOINTS.findall(g)] for x, g in entries}
    assert len(declared) == pos_text.count("P["), f"{name}: a /POS entry the checker cannot read"
    assert declared == list(range(1, len(declared) + 1)), f"{name}: /POS not numbered 1..n"
    assert set(used) == set(declared), (
        f"{name}: used {sorted(set(used) - set(declared))[:5]} undeclared, "
        f"{sorted(set(declared) - set(used))[:5]} declared unused"
    )
    return {
        "name": name,
        "positions": len(declared),
        "motions": len(used),
        "arcs": arcs,
        "schedules": scheds,
        "calls": calls,
        "joints": [joints[i] for i in used] if gp2 else [],
    }  # group 2 per motion, degrees


def check_program(files: dict[str, str]) -> dict:
    """Every .LS program of a program and its schedule table; the main program's CALLs name the
    other programs, each once, and every program but the main one is called."""
    table = next((v for k, v in files.items() if k.upper().endswith(".CSV")), None)
    assert table is not None, "no schedule table"
    schedules = read_schedules(table)
    assert sorted(schedules) == list(range(1, len(schedules) + 1)), "schedules not numbered 1..n"
    info = {k: check_ls(v, schedules) for k, v in files.items() if not k.upper().endswith(".CSV")}
    names = {i["name"] for i in info.values()}
    mains = [i for i in info.values() if set(i["calls"]) & names]  # other CALLs: the cell's own programs
    if len(info) > 1:
        (main,) = mains
        calls = [c for c in main["calls"] if c in names]
        assert sorted(calls) == sorted(names - {main["name"]}) and len(set(calls)) == len(calls), main["calls"]
    used = set().union(*(i["schedules"] for i in info.values()))
    assert used == set(schedules), f"schedules used {sorted(used)}, in the table {sorted(schedules)}"
    return {
        "motions": sum(i["motions"] for i in info.values()),
        "points_declared": sum(i["positions"] for i in info.values()),
        "arcs": sum(i["arcs"] for i in info.values()),
        "programs": len(info),
        "schedules": len(schedules),
        "joints": [j for k in sorted(info) for j in info[k]["joints"]],
    }
