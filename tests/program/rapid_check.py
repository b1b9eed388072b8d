"""An independent structural parser for the ABB RAPID modules we emit (tests only).

No open RAPID grammar covers robtargets and motion instructions (grammars-v4's `abb` parses
.sys declarations of six data types only), so this is a small tokeniser + recursive-descent
parser after the RAPID reference: MODULE … ENDMODULE; data declarations `[LOCAL] CONST|PERS|VAR
type name [:= expression];` with aggregates `[…]`; routines `PROC name() … ENDPROC`; procedure
calls `Name arg, arg\\Switch, arg\\Opt:=value;`. Then the semantic checks a controller would make
on load (`parse_program`: a main module that loads part modules, StartLoad/WaitLoad/UnLoad and
late-bound calls `%"name"%;` of routines those modules declare): identifiers ≤ 32 characters, declared once and before use, each data type's aggregate
shape, and the argument list of each motion / ArcWare instruction with the type of every
argument. `parse_module` raises `RapidError` naming the line; it returns the parsed module.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

TOKEN = re.compile(
    r"""
    (?P<ws>[ \t\r]+) | (?P<nl>\n) | (?P<comment>![^\n]*)
  | (?P<num>\d+\.\d*(?:[eE][-+]?\d+)? | \.\d+(?:[eE][-+]?\d+)? | \d+[eE][-+]?\d+ | \d+)
  | (?P<str>"[^"\n]*") | (?P<ident>[A-Za-z][A-Za-z0-9_]*)
  | (?P<op>:=|\\|[\[\](),;+\-*/{}:<>=%])
""",
    re.X,
)
KEYWORDS = {"MODULE", "ENDMODULE", "PROC", "ENDPROC", "CONST", "PERS", "VAR", "LOCAL", "TRUE", "FALSE"}
NUM, AGG = "num", "agg"
ARC = [NUM] * 9  # arcdata as the writers lay it out
SHAPES = {
    "robtarget": [[NUM] * 3, [NUM] * 4, [NUM] * 4, [NUM] * 6],
    "wobjdata": ["bool", "bool", "string", [[NUM] * 3, [NUM] * 4], [[NUM] * 3, [NUM] * 4]],
    "speeddata": [NUM] * 4,
    "zonedata": ["bool"] + [NUM] * 6,
    "welddata": [NUM, NUM, ARC, ARC],
    "seamdata": [NUM, NUM, ARC, NUM, NUM, NUM, NUM, NUM, ARC, NUM, NUM, ARC, NUM, NUM, ARC, NUM],
}
# instruction → positional argument types ("any" = a value or name we do not type), optional args
INSTRUCTIONS = {
    "MoveL": (["robtarget", "speeddata", "zonedata", "tooldata"], {"WObj": "wobjdata"}),
    "MoveC": (["robtarget", "robtarget", "speeddata", "zonedata", "tooldata"], {"WObj": "wobjdata"}),
    "ArcLStart": (["robtarget", "speeddata", "seamdata", "welddata", "zonedata", "tooldata"], {"WObj": "wobjdata"}),
    "ArcL": (["robtarget", "speeddata", "seamdata", "welddata", "zonedata", "tooldata"], {"WObj": "wobjdata"}),
    "ArcLEnd": (["robtarget", "speeddata", "seamdata", "welddata", "zonedata", "tooldata"], {"WObj": "wobjdata"}),
    "ArcC": (
        ["robtarget", "robtarget", "speeddata", "seamdata", "welddata", "zonedata", "tooldata"],
        {"WObj": "wobjdata"},
    ),
    "ArcCEnd": (
        ["robtarget", "robtarget", "speeddata", "seamdata", "welddata", "zonedata", "tooldata"],
        {"WObj": "wobjdata"},
    ),
    "WaitTime": ([NUM], {"InPos": None}),
    "ConfL": ([], {"On": None, "Off": None}),
    "StartLoad": (["string", "loadsession"], {"Dynamic": None, "File": "string"}),
    "WaitLoad": (["loadsession"], {}),
    "UnLoad": (["string"], {"File": "string"}),
    "ActUnit": (["mecunit"], {}),
    "DeactUnit": (["mecunit"], {}),
}
LATE = "%late%"  # a late-bound procedure call
BUILTIN = {"fine": "zonedata", "wobj0": "wobjdata", "tool0": "tooldata"}


class RapidError(ValueError):
    pass


@dataclass
class Call:
    name: str
    args: list  # positional: ("name", str) | ("value", parsed)
    options: dict  # switch / optional argument name → value (None for a switch)
    line: int


@dataclass
class Module:
    name: str
    data: dict = field(default_factory=dict)  # name → (storage, type, value)
    routines: dict = field(default_factory=dict)  # name → [Call]

    def calls(self, *names: str) -> list[Call]:
        return [c for body in self.routines.values() for c in body if not names or c.name in names]


def tokenize(text: str) -> list[tuple[str, str, int]]:
    out, line, pos = [], 1, 0
    while pos < len(text):
        m = TOKEN.match(text, pos)
        if not m:
            raise RapidError(f"line {line}: unexpected character {text[pos]!r}")
        kind = m.lastgroup
        if kind == "nl":
            line += 1
        elif kind not in ("ws", "comment"):
            out.append((kind, m.group(), line))
        pos = m.end()
    out.append(("eof", "", line))
    return out


class _Parser:
    def __init__(self, text: str):
        self.toks = tokenize(text)
        self.i = 0

    def peek(self, k: int = 0):
        return self.toks[self.i + k]

    def next(self):
        t = self.toks[self.i]
        self.i += 1
        return t

    def expect(self, value: str | None = None, kind: str | None = None):
        t = self.next()
        if (value is not None and t[1].upper() != value.upper()) or (kind is not None and t[0] != kind):
            raise RapidError(f"line {t[2]}: expected {value or kind}, found {t[1]!r}")
        return t

    def ident(self) -> str:
        t = self.expect(kind="ident")
        if t[1].upper() in KEYWORDS:
            raise RapidError(f"line {t[2]}: reserved word {t[1]!r} used as a name")
        if len(t[1]) > 32:
            raise RapidError(f"line {t[2]}: identifier {t[1]!r} longer than 32 characters")
        return t[1]

    def expr(self):
        """expression := ['-'|'+'] primary {op primary}; aggregates are [expr, ...]."""
        t = self.peek()
        if t[1] == "[":
            self.next()
            items = [self.expr()]
            while self.peek()[1] == ",":
                self.next()
                items.append(self.expr())
            self.expect("]")
            value = (AGG, items)
        else:
            sign = -1.0 if t[1] == "-" else 1.0
            if t[1] in "+-":
                self.next()
            t = self.next()
            if t[0] == "num":
                value = (NUM, sign * float(t[1]))
            elif t[0] == "str":
                value = ("string", t[1][1:-1])
            elif t[1].upper() in ("TRUE", "FALSE"):
                value = ("bool", t[1].upper() == "TRUE")
            elif t[0] == "ident":
                value = ("name", t[1])
            else:
                raise RapidError(f"line {t[2]}: expected a value, found {t[1]!r}")
        while self.peek()[1] in ("+", "-", "*", "/"):
            self.next()
            self.expr()
            value = (NUM, None)
        return value

    def module(self) -> Module:
        self.expect("MODULE")
        mod = Module(self.ident())
        while True:
            t = self.peek()
            up = t[1].upper()
            if up == "ENDMODULE":
                self.next()
                break
            if up in ("LOCAL", "CONST", "PERS", "VAR"):
                self.declaration(mod)
            elif up == "PROC":
                self.routine(mod)
            else:
                raise RapidError(f"line {t[2]}: expected a declaration, PROC or ENDMODULE, found {t[1]!r}")
        self.expect(kind="eof")
        return mod

    def declaration(self, mod: Module) -> None:
        if self.peek()[1].upper() == "LOCAL":
            self.next()
        storage = self.next()[1].upper()
        dtype = self.ident()
        line = self.peek()[2]
        name = self.ident()
        value = None
        if self.peek()[1] == ":=":
            self.next()
            value = self.expr()
        self.expect(";")
        if name in mod.data:
            raise RapidError(f"line {line}: {name} declared twice")
        if storage == "CONST" and value is None:
            raise RapidError(f"line {line}: CONST {name} without a value")
        if dtype in SHAPES:
            _check_shape(value, SHAPES[dtype], f"line {line}: {dtype} {name}")
        mod.data[name] = (storage, dtype, value)

    def routine(self, mod: Module) -> None:
        self.expect("PROC")
        name = self.ident()
        self.expect("(")
        self.expect(")")
        body = []
        while self.peek()[1].upper() != "ENDPROC":
            if self.peek()[0] == "eof":
                raise RapidError(f"PROC {name} without ENDPROC")
            body.append(self.call())
        self.next()
        if name in mod.routines or name in mod.data:
            raise RapidError(f"PROC {name} declared twice")
        mod.routines[name] = body

    def call(self) -> Call:
        line = self.peek()[2]
        if self.peek()[1] == "%":  # late binding: %"routine"%; (a routine loaded at run time)
            self.next()
            name = self.expect(kind="str")[1][1:-1]
            self.expect("%")
            self.expect(";")
            return Call(LATE, [("string", name)], {}, line)
        name = self.ident()
        args, options = [], {}
        self.options(options)
        if self.peek()[1] == ",":
            self.next()
        while self.peek()[1] != ";":
            args.append(self.expr())
            self.options(options)
            if self.peek()[1] == ",":
                self.next()
            elif self.peek()[1] != ";":
                raise RapidError(f"line {self.peek()[2]}: expected ',' or ';' in {name}, found {self.peek()[1]!r}")
        self.expect(";")
        return Call(name, args, options, line)

    def options(self, options: dict) -> None:
        while self.peek()[1] == "\\":
            self.next()
            opt = self.ident()
            value = None
            if self.peek()[1] == ":=":
                self.next()
                value = self.expr()
            options[opt] = value


def _check_shape(value, shape, where: str) -> None:
    if value is None:
        return
    if isinstance(shape, list):
        if value[0] != AGG or len(value[1]) != len(shape):
            got = len(value[1]) if value[0] == AGG else value[0]
            raise RapidError(f"{where}: expected an aggregate of {len(shape)} components, got {got}")
        for v, s in zip(value[1], shape):
            _check_shape(v, s, where)
    elif value[0] != shape:
        raise RapidError(f"{where}: expected {shape}, got {value[0]}")


def _arg_type(mod: Module, arg, tool: str | None) -> str:
    kind, v = arg
    if kind != "name":
        return kind
    if v in mod.data:
        return mod.data[v][1]
    if v in BUILTIN:
        return BUILTIN[v]
    if v == tool:
        return "tooldata"  # declared on the controller
    return "undeclared"


def parse_module(
    text: str,
    tool: str | None = None,
    units: tuple[str, ...] = (),
    routines: dict[str, list[str]] | None = None,
    extern: dict | None = None,
) -> Module:
    """Parse and check one module; `tool` is the controller's tooldata name, `units` the
    mechanical units the controller knows (for ActUnit/DeactUnit), `routines` the procedures
    other loaded modules declare (name → argument types, e.g. a rolling tool's ToolOn), `extern`
    the global data other modules of the program declare (name → (storage, type, value))."""
    mod = _Parser(text).module()
    _check_calls(mod, tool, units, routines, extern)
    return mod


def _check_calls(mod: Module, tool, units, routines, extern) -> None:
    data = mod.data
    mod = Module(mod.name, {**(extern or {}), **data}, mod.routines)
    known = {**{k: (list(v), {}) for k, v in (routines or {}).items()}, **INSTRUCTIONS}
    for call in mod.calls():
        if call.name == LATE:  # checked against the loaded modules (parse_program)
            continue
        if call.name not in known:
            raise RapidError(f"line {call.line}: unknown instruction {call.name}")
        types, opts = known[call.name]
        if len(call.args) != len(types):
            raise RapidError(f"line {call.line}: {call.name} takes {len(types)} arguments, got {len(call.args)}")
        for a, want in zip(call.args, types):
            if want == "mecunit":
                if a[0] != "name" or a[1] not in units:
                    raise RapidError(f"line {call.line}: {call.name} of unknown mechanical unit {a[1]!r}")
                continue
            got = _arg_type(mod, a, tool)
            if got != want:
                raise RapidError(f"line {call.line}: {call.name} argument {a[1]!r} is {got}, expected {want}")
        for o, v in call.options.items():
            if o not in opts:
                raise RapidError(f"line {call.line}: {call.name} has no argument \\{o}")
            if opts[o] is not None and (v is None or _arg_type(mod, v, tool) != opts[o]):
                raise RapidError(f"line {call.line}: {call.name}\\{o} must be a {opts[o]}")


def values(agg) -> list:
    """A parsed aggregate as nested Python lists of numbers / strings / bools."""
    kind, v = agg
    return [values(x) for x in v] if kind == AGG else v


def parse_program(
    files: dict[str, str],
    tool: str | None = None,
    units: tuple[str, ...] = (),
    routines: dict[str, list[str]] | None = None,
) -> list[Module]:
    """Parse every module of a program (file name → text), main module first then the modules it
    calls in call order. Checks: one module has `main`; every late-bound call names a routine of
    another module whose file main() loads (StartLoad \\File) before the call and unloads after;
    global data is declared in one module only (part modules declare theirs LOCAL)."""
    mods = {}
    for fname, text in files.items():
        mod = _Parser(text).module()
        if fname.rsplit(".", 1)[0] != mod.name:
            raise RapidError(f"{fname}: holds MODULE {mod.name}, not named like its file")
        mods[mod.name] = (mod, text)
    local = {
        n: set(re.findall(r"^\s*LOCAL\s+(?:CONST|PERS|VAR)\s+\w+\s+(\w+)", t, re.M)) for n, (_m, t) in mods.items()
    }
    for name, (mod, _t) in mods.items():
        extern = {
            k: v
            for other, (m, _t2) in mods.items()
            if other != name
            for k, v in m.data.items()
            if k not in local[other]
        }
        _check_calls(mod, tool, units, routines, extern)
    mains = [m for m, _t in mods.values() if "main" in m.routines]
    if len(mains) != 1:
        raise RapidError(f"{len(mains)} modules with PROC main")
    main = mains[0]
    order, loaded = [main], set()
    for c in main.calls():
        if c.name == "StartLoad":
            loaded.add(str(c.options["File"][1]))
        elif c.name == "UnLoad":
            loaded.discard(str(c.options["File"][1]))
        elif c.name == LATE:
            target = c.args[0][1]
            owner = next((m for m, _t in mods.values() if target in m.routines and m is not main), None)
            if owner is None or f"{owner.name}.mod" not in loaded:
                raise RapidError(f'line {c.line}: %"{target}"% calls a routine of no loaded module')
            order.append(owner)
    globals_: dict[str, str] = {}
    for m, _text in mods.values():
        for name in m.data:
            if name not in local[m.name]:
                if name in globals_:
                    raise RapidError(f"{name} declared globally in {globals_[name]} and {m.name}")
                globals_[name] = m.name
    return order
