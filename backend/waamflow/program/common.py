"""Small helpers shared by the writers: number formatting, process-parameter text, names."""

from __future__ import annotations

import re
import string
from dataclasses import dataclass

import numpy as np

from ..core.process import PARAMETERS_BY_NAME, ZONE_PARAMETERS

_IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def num(x: float, decimals: int = 3) -> str:
    """Fixed-point number without negative zero ("-0.000" → "0.000")."""
    s = f"{float(x):.{decimals}f}"
    return s[1:] if s.startswith("-") and float(s) == 0.0 else s


def short(x: float) -> str:
    """Compact number for comments (`%g`)."""
    return f"{float(x):g}"


def check_identifier(name: str, max_len: int, what: str = "program name") -> str:
    """A controller-safe identifier: letter first, then letters/digits/underscores, ≤ max_len."""
    if not _IDENT.match(name) or len(name) > max_len:
        raise ValueError(
            f"{what} {name!r} must start with a letter, use only letters, digits and "
            f"'_' and have at most {max_len} characters"
        )
    return name


def process_summary(params: dict) -> str:
    """'current 200 A, voltage 20 V, ...' in the table order of core/process.py (values present)."""
    parts = []
    for p in ZONE_PARAMETERS:
        if p.name in params:
            parts.append(f"{p.name} {short(params[p.name])}{(' ' + p.unit) if p.unit else ''}")
    extra = sorted(k for k in params if k not in PARAMETERS_BY_NAME)
    parts += [f"{k} {short(params[k])}" for k in extra]
    return ", ".join(parts)


def check_templates(templates: dict[str, str]) -> dict[str, str]:
    """Validate process-command templates: known parameter names, only the `{value}` field, one
    line without quotes (the `waamflow-weld:` header quotes them); "" = not commanded."""
    for name, tpl in templates.items():
        if name not in PARAMETERS_BY_NAME:
            raise ValueError(
                f"process template for unknown parameter {name!r} (known: {', '.join(PARAMETERS_BY_NAME)})"
            )
        if any(c in tpl for c in '"\n'):
            raise ValueError(f"process template {tpl!r} for {name!r}: one line, no double quotes")
        fields = [f for _, f, _, _ in string.Formatter().parse(tpl) if f is not None]
        if any(f != "value" for f in fields):
            raise ValueError(f"process template {tpl!r} for {name!r} may only use the field {{value}}")
        tpl.format(value=1.0)
    return dict(templates)


def process_lines(
    params: dict, templates: dict[str, str], scale: dict[str, float] | None = None, names=None
) -> list[str]:
    """One command per parameter present in both `params` and `templates` (an empty template
    commands nothing), in table order; the value times `scale[name]` (default 1) fills {value}.
    `names`: only these parameters (e.g. those that changed)."""
    scale = scale or {}
    return [
        templates[p.name].format(value=float(params[p.name]) * float(scale.get(p.name, 1.0)))
        for p in ZONE_PARAMETERS
        if p.name in params and templates.get(p.name) and (names is None or p.name in names)
    ]


# ---- the weld in the program: which command carries which zone parameter ------------------------
# Every program format writes header comments `waamflow-weld: ...`, one line per weld value of a
# zone (WELD_COMMANDED, so no line nears a controller's limit: LinuxCNC rejects lines of 256
# characters), each naming the command that carries it, so an independent reader (the preflight,
# the tests) can read the values back:
#     name[unit]="<template with {value}>"          the command, value in the unit (× scale)
#     name[unit]*<scale>="<template>"               the command carries value × scale
#     name[unit]@start="<template>"                 the form used before an ignition (arc off)
#     name[unit]="<data field>"                     (no {value}) a field of a weld data set
#     name[unit]=none                               the dialect cannot command it (a weld issue)
WELD_COMMANDED = ("current", "voltage", "wire_feed_speed", "job")
WELD_TAG = "waamflow-weld:"
_TAG_ITEM = re.compile(r'(\w+)\[([^\]]*)\](?:\*([-+\d.eE]+))?(@start)?=(?:"([^"]*)"|none)')
_NUMBER = r"([-+]?(?:\d+\.?\d*|\.\d+))"


def weld_tag(
    templates: dict[str, str], start: dict[str, str] | None = None, scale: dict[str, float] | None = None
) -> list[str]:
    """The `waamflow-weld:` header lines (without comment marks) for these templates (see above),
    one per weld value."""
    lines = []
    for name in WELD_COMMANDED:
        unit = PARAMETERS_BY_NAME[name].unit
        k = (scale or {}).get(name)
        head = f"{name}[{unit}]" + (f"*{k:g}" if k is not None and float(k) != 1.0 else "")
        tpl = templates.get(name) or ""
        parts = [f'{head}="{tpl}"' if tpl else f"{head}=none"]
        st = (start or {}).get(name) or ""
        if tpl and st and st != tpl:
            parts.append(f'{head}@start="{st}"')
        lines.append(WELD_TAG + " " + " ".join(parts))
    return lines


def parse_weld_tag(text: str) -> dict[str, dict]:
    """name → {"unit", "scale", "commands": [templates or data fields]} from a program's
    `waamflow-weld:` lines; names the dialect cannot command map to commands []. {} when absent."""
    tagged = [ln.split(WELD_TAG, 1)[1] for ln in text.splitlines() if WELD_TAG in ln]
    out: dict[str, dict] = {}
    for name, unit, k, _start, tpl in (item for ln in tagged for item in _TAG_ITEM.findall(ln)):
        e = out.setdefault(name, {"unit": unit, "scale": float(k) if k else 1.0, "commands": []})
        if tpl:
            e["commands"].append(tpl)
    return out


def template_regex(tpl: str) -> re.Pattern:
    """A regular expression matching a command written from `tpl`, group 1 = the {value} number."""
    parts = []
    for literal, fld, _spec, _conv in string.Formatter().parse(tpl):
        parts.append(re.escape(literal))
        if fld is not None:
            parts.append(_NUMBER)
    return re.compile(r"(?<![\w$#])" + "".join(parts) + r"(?![\w.])")


def read_weld_commands(text: str) -> dict[str, list[float]]:
    """The weld values a program commands, in program order, read through its `waamflow-weld:`
    line: name → values in the parameter's unit (the scale divided out). Whole-line comments
    (`;`, `(`, `!`) and trailing `;`/`!` comments are skipped. Data-set fields are not read here."""
    tag = parse_weld_tag(text)
    pats = [(name, e["scale"], template_regex(t)) for name, e in tag.items() for t in e["commands"] if "{" in t]
    out: dict[str, list[float]] = {name: [] for name in tag}
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line[0] in ";(!":
            continue
        code = re.split(r"[;!]", line, maxsplit=1)[0]
        for name, k, pat in pats:
            m = pat.search(code)
            if m:
                out[name].append(float(m.group(1)) / k)
                break
    return out


def finite(x: float) -> bool:
    return bool(np.isfinite(x))


def trace_lines(trace: dict) -> list[str]:
    """The traceability lines of a program header (without comment marks): date UTC, waamflow
    version and source revision (`buildinfo.source_revision`, git describe), recipe name, sha256 of the canonical recipe JSON and of each input file read."""
    if not trace:
        return []
    from ..buildinfo import source_revision

    lines = [
        f"waamflow trace: date {trace.get('date', '?')}, waamflow {trace.get('waamflow', '?')}, "
        f"revision {trace.get('revision') or source_revision()}, recipe {trace.get('recipe', '?')}",
        f"waamflow trace: recipe sha256 {trace.get('recipe_sha256', '?')}",
    ]
    for path, digest in (trace.get("inputs") or {}).items():
        lines.append(f"waamflow trace: input {path} sha256 {digest}")
    return lines


def stamp_trace(fmt: str, files: dict[str, str], trace: dict) -> dict[str, str]:
    """Program files with the trace lines in their header, in each format's comment syntax:
    G-code `;` at the top, KRL `;` after `DEF`/`DEFDAT`, RAPID `!` after `MODULE`, CSV `#` at
    the top, INFORM `'` after the main job's NOP and Fanuc TP `!` as the main program's first /MN
    lines (32 characters a line: short forms, the recipe hash cut to 16 hex digits). Applied when artifacts are written, so the date never enters a cache key. JSON
    (print points) has no comments and a fixed layout: it stays as it is (the trace is in
    summary.json)."""
    body = trace_lines(trace)
    if not body or fmt == "printpoints":
        return dict(files)
    out = {}
    for suffix, text in files.items():
        lines = text.split("\n")
        if fmt == "gcode":  # before the first comment (after a preamble)
            at = next((i for i, ln in enumerate(lines) if ln.lstrip().startswith((";", "("))), 0)
            paren = lines[at].lstrip().startswith("(") if lines else False  # the profile's comment style
            lines = lines[:at] + [f"({b})" if paren else f"; {b}" for b in body] + lines[at:]
        elif fmt == "csv":
            lines = [f"# {b}" for b in body] + lines
        elif fmt in ("inform", "tp"):  # comments hold 32 characters: short forms
            if suffix != {"inform": "JBI", "tp": "LS"}[fmt]:  # the main job / program carries the trace
                out[suffix] = text
                continue
            from ..buildinfo import source_revision

            short_body = [
                f"waamflow {trace.get('waamflow', '?')}",
                f"rev {trace.get('revision') or source_revision()}",
                f"recipe sha256 {str(trace.get('recipe_sha256', '?'))[:16]}",
                f"date {trace.get('date', '?')}",
            ]
            if fmt == "tp":  # numbered /MN lines: renumbered, LINE_COUNT kept right
                from .tp import with_comments

                out[suffix] = with_comments(text, short_body)
                continue
            at = next((i + 1 for i, ln in enumerate(lines) if ln.strip() == "NOP"), 0)
            lines = lines[:at] + ["'" + b[:32] for b in short_body] + lines[at:]
        else:
            opener = ("MODULE ",) if fmt == "rapid" else ("DEF ", "DEFDAT ")
            at = next((i + 1 for i, ln in enumerate(lines) if ln.lstrip().startswith(opener)), 0)
            mark = "  ! " if fmt == "rapid" else "; "
            lines = lines[:at] + [f"{mark}{b}" for b in body] + lines[at:]
        out[suffix] = "\n".join(lines)
    return out


# ---- post-deposition tool commands (rolling, peening) -------------------------------------------
TOOL_FIELDS = ("tool", "force_n", "tool_width_mm", "speed_mm_s")

# Defaults per format; a machine profile or the post-process params replace them. G-code: LinuxCNC
# user M-codes (M100-M199 take P and Q): the cell's M110 script sets the load and lowers the tool.
# KRL / RAPID: routine calls the cell provides (like the arc routines), force in N, width in mm,
# speed in mm/s.
TOOL_COMMANDS: dict[str, tuple[str, str]] = {
    "gcode": ("M110 P{force_n:.0f} Q{tool_width_mm:g}", "M111"),
    "krl": ("TOOL_ON({force_n:.1f}, {tool_width_mm:.2f}, {speed_mm_s:.2f})", "TOOL_OFF()"),
    "rapid": ("ToolOn {force_n:.1f}, {tool_width_mm:.2f}, {speed_mm_s:.2f};", "ToolOff;"),
    # INFORM: the force (N) into double-integer variable D000, then the cell's jobs TOOL_ON / TOOL_OFF
    "inform": ("SET D000 {force_n:.0f}\nCALL JOB:TOOL_ON", "CALL JOB:TOOL_OFF"),
    # Fanuc TP: the force (N) into register R[1], then the cell's programs TOOL_ON / TOOL_OFF
    "tp": ("R[1]={force_n:.0f}\nCALL TOOL_ON", "CALL TOOL_OFF"),
}


def check_tool_template(tpl: str, what: str) -> str:
    """A tool command template: one or more lines (separated by newlines) using only the fields
    of TOOL_FIELDS and any tool parameter; checked by formatting it with sample values."""
    fields = [f for _, f, _, _ in string.Formatter().parse(tpl) if f is not None]
    bad = [f for f in fields if f not in TOOL_FIELDS]
    if bad:
        raise ValueError(f"{what} {tpl!r} uses unknown field(s) {', '.join(bad)} (known: {', '.join(TOOL_FIELDS)})")
    try:
        tool_lines(tpl, "rolling", {"force_n": 1.0, "tool_width_mm": 1.0, "speed_mm_s": 1.0})
    except (ValueError, KeyError, IndexError) as e:
        raise ValueError(f"{what} {tpl!r}: {e}") from None
    return tpl


def tool_lines(tpl: str, tool: str, params: dict) -> list[str]:
    """The template's lines for one engagement (`tool` and the tool's parameters filled in)."""
    values = {"tool": tool, **{k: float(v) for k, v in params.items()}}
    missing = [f for _, f, _, _ in string.Formatter().parse(tpl) if f is not None and f not in values]
    if missing:
        raise ValueError(
            f"tool command {tpl!r} needs {', '.join(missing)}, the tool section has "
            f"{', '.join(sorted(params)) or 'no parameters'}"
        )
    return [ln for ln in tpl.format(**values).split("\n") if ln.strip()]


def tool_summary(tool: str, params: dict) -> str:
    """'rolling on: force 20000 N, tool width 8 mm, 10 mm/s' (ASCII, for program comments)."""
    parts = []
    if "force_n" in params:
        parts.append(f"force {short(params['force_n'])} N")
    if "tool_width_mm" in params:
        parts.append(f"tool width {short(params['tool_width_mm'])} mm")
    if "speed_mm_s" in params:
        parts.append(f"{short(params['speed_mm_s'])} mm/s")
    return f"{tool} on" + (": " + ", ".join(parts) if parts else "")


# Words a program name must not be (case-insensitive): keywords and names the writers use.
KRL_RESERVED = frozenset(
    w.upper()
    for w in (
        "DEF",
        "END",
        "DEFDAT",
        "ENDDAT",
        "DEFFCT",
        "ENDFCT",
        "DECL",
        "GLOBAL",
        "PUBLIC",
        "LIN",
        "PTP",
        "CIRC",
        "IF",
        "THEN",
        "ELSE",
        "ENDIF",
        "FOR",
        "ENDFOR",
        "WHILE",
        "ENDWHILE",
        "LOOP",
        "ENDLOOP",
        "REPEAT",
        "UNTIL",
        "SWITCH",
        "CASE",
        "DEFAULT",
        "ENDSWITCH",
        "WAIT",
        "SEC",
        "HALT",
        "RETURN",
        "EXIT",
        "GOTO",
        "TRIGGER",
        "WHEN",
        "DISTANCE",
        "DELAY",
        "DO",
        "PRIO",
        "PATH",
        "INTERRUPT",
        "STRUC",
        "ENUM",
        "SIGNAL",
        "TRUE",
        "FALSE",
        "NOT",
        "AND",
        "OR",
        "EXOR",
        "B_AND",
        "B_OR",
        "B_NOT",
        "B_EXOR",
        "BAS",
        "INT",
        "REAL",
        "BOOL",
        "CHAR",
        "E6POS",
        "POS",
        "FRAME",
        "AXIS",
        "E6AXIS",
        "C_DIS",
        "C_PTP",
        "C_ORI",
        "C_VEL",
        "CONTINUE",
    )
)
RAPID_RESERVED = frozenset(
    w.upper()
    for w in (
        "MODULE",
        "ENDMODULE",
        "PROC",
        "ENDPROC",
        "FUNC",
        "ENDFUNC",
        "TRAP",
        "ENDTRAP",
        "CONST",
        "PERS",
        "VAR",
        "LOCAL",
        "TASK",
        "IF",
        "THEN",
        "ELSE",
        "ELSEIF",
        "ENDIF",
        "FOR",
        "FROM",
        "TO",
        "STEP",
        "DO",
        "ENDFOR",
        "WHILE",
        "ENDWHILE",
        "TEST",
        "CASE",
        "DEFAULT",
        "ENDTEST",
        "RETURN",
        "EXIT",
        "GOTO",
        "RAISE",
        "RETRY",
        "TRYNEXT",
        "ERROR",
        "UNDO",
        "BACKWARD",
        "RECORD",
        "ENDRECORD",
        "ALIAS",
        "NOT",
        "AND",
        "OR",
        "XOR",
        "DIV",
        "MOD",
        "TRUE",
        "FALSE",
        "NOSTEPIN",
        "VIEWONLY",
        "READONLY",
        "SYSMODULE",
        "INOUT",
        "WITH",
        "main",
        "fine",
        "num",
        "bool",
        "string",
        "robtarget",
        "speeddata",
        "zonedata",
        "wobjdata",
        "tooldata",
        "welddata",
        "seamdata",
        "arcdata",
        "wobj0",
        "tool0",
    )
)


def program_identifier(name: str, max_len: int, reserved: frozenset[str] = frozenset(), prefix: str = "P") -> str:
    """`name` (e.g. a node id) made a controller identifier: every character other than a letter,
    digit or '_' becomes '_', `prefix` is put in front when it does not start with a letter or
    when it is a reserved word, and it is cut to `max_len` characters (KRL 24, RAPID 32)."""
    ident = re.sub(r"[^A-Za-z0-9_]", "_", name.strip()) or prefix
    if not ident[0].isalpha() or ident.upper() in reserved:
        ident = f"{prefix}_{ident}" if ident[0] != "_" else prefix + ident
    return ident[:max_len].rstrip("_") or prefix


@dataclass(frozen=True)
class WeldDataIssue:
    """A zone whose weld data the power source would get empty or zero."""

    section: str  # section key
    layer: int | None
    zone: str  # zone id
    message: str


WELD_VALUES = ("current", "voltage", "wire_feed_speed")


def weld_data_issues(
    plan, required: tuple[str, ...] = (), commanded: tuple[str, ...] | None = None, hint: str = "", empty: bool = True
) -> list[WeldDataIssue]:
    """Zones welded in `plan` whose weld data is empty (none of current, voltage, wire feed speed
    or job given; only with `empty`), has a zero value (current, voltage, wire feed speed, weld
    speed), lacks one of the `required` parameters (e.g. those mapped to ArcTech channels) or has
    a weld value (WELD_COMMANDED) the program cannot command (not in `commanded`, when given;
    `hint` says what to set), once per (section, zone), in deposition order."""
    from .plan import Motion

    moves = plan.moves
    seen: dict[tuple[int, int], WeldDataIssue] = {}
    for st in plan.steps:
        if not isinstance(st, Motion) or st.mode != "weld" or (st.section, st.zone) in seen:
            continue
        key = (st.section, st.zone)
        params = moves.zone_params.get(key, {})
        zid = moves.zone_ids[st.zone] if 0 <= st.zone < len(moves.zone_ids) else "-"
        problems = []
        has_data = any(float(params.get(k, 0.0) or 0.0) > 0 for k in WELD_VALUES + ("job",))
        if not has_data:
            if empty:
                problems.append("no weld data (current, voltage, wire_feed_speed and job all missing or 0)")
        else:
            zero = [k for k in WELD_VALUES if k in params and float(params[k]) <= 0]
            if zero:
                problems.append(f"{', '.join(zero)} 0")
            missing = [
                k
                for k in required
                if k not in WELD_VALUES
                and float(params.get(k, 0.0) or 0.0) <= 0
                or k in WELD_VALUES
                and k not in params
            ]
            if missing:
                problems.append(f"{', '.join(missing)} missing (written as 0)")
        if commanded is not None:
            lost = [k for k in WELD_COMMANDED if k in params and k not in commanded]
            if lost:
                vals = ", ".join(
                    f"{k} {short(params[k])}{(' ' + PARAMETERS_BY_NAME[k].unit) if PARAMETERS_BY_NAME[k].unit else ''}"
                    for k in lost
                )
                problems.append(
                    f"{vals} not commanded: the program has no command for "
                    f"{'it' if len(lost) == 1 else 'them'}" + (f" ({hint})" if hint else "")
                )
        if not (np.isfinite(st.speed) and st.speed > 0):
            problems.append("weld speed 0")
        issue = WeldDataIssue(moves.section_keys[st.section], st.layer, zid, "; ".join(problems))
        seen[key] = issue
    return [i for i in seen.values() if i.message]
