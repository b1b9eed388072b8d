"""An independent structural parser for the KUKA KRL programs we emit (tests only).

A tokeniser + line-oriented recursive-descent parser after the KRL reference for the statement
kinds a waamflow program may hold: `DEF name( )` … `END` (.src), `DEFDAT name [PUBLIC]` … `ENDDAT`
(.dat) with `DECL type name=value` (structure aggregates `{field value, field[] "text", …}`,
enumerations `#name`); motions LIN/CIRC/PTP with an optional approximation C_DIS; assignments
to system variables (`$VEL.CP=…`, `$OUT[1]=TRUE`); `WAIT SEC`; `TRIGGER WHEN DISTANCE=…|PATH=…
DELAY=… DO … [PRIO=…]`; subprogram and routine calls `name(args)`; `IF … THEN` / `ENDIF`; HALT.
Checks: names ≤ 24 characters, DEF name = DEFDAT name, every motion target declared once in the
.dat as an E6POS with X Y Z A B C E1..E6, every data set a call names declared, and the ArcTech
call discipline (each motion wrapped by Before/After calls of one data set; ON, SWI…, OFF).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

TOKEN = re.compile(
    r"""
    (?P<ws>[ \t\r]+) | (?P<comment>;[^\n]*)
  | (?P<num>\d+\.\d*(?:[eE][-+]?\d+)? | \.\d+ | \d+)
  | (?P<str>"[^"\n]*") | (?P<sys>\$[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*)
  | (?P<enum>\#[A-Za-z_][A-Za-z0-9_]*) | (?P<ident>[A-Za-z_][A-Za-z0-9_]*)
  | (?P<op><=|>=|<>|==|[\[\](){},=<>+\-*/])
""",
    re.X,
)
E6POS = ["X", "Y", "Z", "A", "B", "C", "E1", "E2", "E3", "E4", "E5", "E6"]


class KrlError(ValueError):
    pass


@dataclass
class Stmt:
    kind: str  # "LIN" | "CIRC" | "PTP" | "assign" | "wait" | "trigger" | "call" | "if" | "endif" | "halt"
    args: list
    line: int


@dataclass
class Program:
    name: str
    body: list = field(default_factory=list)  # [Stmt]
    data: dict = field(default_factory=dict)  # name → (type, value)

    def motions(self) -> list[Stmt]:
        return [s for s in self.body if s.kind in ("LIN", "CIRC", "PTP")]

    def e6pos(self) -> dict[str, dict[str, float]]:
        return {n: dict(v) for n, (t, v) in self.data.items() if t == "E6POS"}


def _tokens(line: str, no: int) -> list[tuple[str, str]]:
    out, pos = [], 0
    while pos < len(line):
        m = TOKEN.match(line, pos)
        if not m:
            raise KrlError(f"line {no}: unexpected character {line[pos]!r}")
        if m.lastgroup not in ("ws", "comment"):
            out.append((m.lastgroup, m.group()))
        pos = m.end()
    for kind, text in out:
        if kind == "ident" and len(text) > 24:
            raise KrlError(f"line {no}: name {text!r} longer than 24 characters")
    return out


class _Line:
    def __init__(self, toks, no):
        self.t, self.i, self.no = toks, 0, no

    def peek(self):
        return self.t[self.i] if self.i < len(self.t) else ("eol", "")

    def next(self):
        t = self.peek()
        self.i += 1
        return t

    def expect(self, text=None, kind=None):
        t = self.next()
        if (text is not None and t[1].upper() != text.upper()) or (kind is not None and t[0] != kind):
            raise KrlError(f"line {self.no}: expected {text or kind}, found {t[1]!r}")
        return t

    def end(self):
        if self.i != len(self.t):
            raise KrlError(f"line {self.no}: unexpected {self.peek()[1]!r}")

    def value(self):
        """A literal, name, enum, call, structure aggregate, or arithmetic/comparison of them."""
        t = self.next()
        if t[1] in ("-", "+"):
            v = self.value()
            return -v if isinstance(v, float) and t[1] == "-" else v
        if t[1] == "{":
            return self.struct()
        if t[1] == "(":
            v = self.value()
            self.expect(")")
            out = v
        elif t[0] == "num":
            out = float(t[1])
        elif t[0] == "str":
            out = t[1][1:-1]
        elif t[0] == "enum":
            out = t[1]
        elif t[0] in ("ident", "sys"):
            out = t[1]
            if t[0] == "sys" and self.peek()[1] == "[":
                self.next()
                self.value()
                self.expect("]")
            elif self.peek()[1] == "(":
                out = ("call", t[1], self.call_args())
            if t[1].upper() in ("TRUE", "FALSE"):
                out = t[1].upper() == "TRUE"
        else:
            raise KrlError(f"line {self.no}: expected a value, found {t[1]!r}")
        while self.peek()[1] in ("+", "-", "*", "/", "<", ">", "<=", ">=", "==", "<>"):
            self.next()
            self.value()
            out = ("expr",)
        return out

    def call_args(self) -> list:
        self.expect("(")
        args = []
        while self.peek()[1] != ")":
            args.append(self.value())
            if self.peek()[1] == ",":
                self.next()
            elif self.peek()[1] != ")":
                raise KrlError(f"line {self.no}: expected ',' or ')', found {self.peek()[1]!r}")
        self.expect(")")
        return args

    def struct(self) -> list[tuple[str, object]]:
        fields = []
        while True:
            name = self.expect(kind="ident")[1]
            if self.peek()[1] == "[":
                self.next()
                self.expect("]")
            fields.append((name, self.value()))
            if self.peek()[1] == ",":
                self.next()
                continue
            self.expect("}")
            return fields


def _statement(p: _Line) -> Stmt:
    t = p.peek()
    up = t[1].upper()
    if up in ("LIN", "PTP"):
        p.next()
        target = p.next()[1]
        blend = p.next()[1] if p.peek()[0] == "ident" else None
        p.end()
        return Stmt(up, [target, blend], p.no)
    if up == "CIRC":
        p.next()
        via = p.expect(kind="ident")[1]
        p.expect(",")
        end = p.expect(kind="ident")[1]
        blend = p.next()[1] if p.peek()[0] == "ident" else None
        p.end()
        return Stmt("CIRC", [via, end, blend], p.no)
    if up == "WAIT":
        p.next()
        p.expect("SEC")
        v = p.value()
        p.end()
        return Stmt("wait", [v], p.no)
    if up == "HALT":
        p.next()
        p.end()
        return Stmt("halt", [], p.no)
    if up == "IF":
        p.next()
        cond = p.value()
        p.expect("THEN")
        p.end()
        return Stmt("if", [cond], p.no)
    if up == "ENDIF":
        p.next()
        p.end()
        return Stmt("endif", [], p.no)
    if up == "TRIGGER":
        p.next()
        p.expect("WHEN")
        kind = p.expect(kind="ident")[1].upper()
        if kind not in ("DISTANCE", "PATH"):
            raise KrlError(f"line {p.no}: TRIGGER WHEN DISTANCE|PATH, not {kind}")
        p.expect("=")
        when = p.value()
        p.expect("DELAY")
        p.expect("=")
        delay = p.value()
        p.expect("DO")
        action = _statement_tail(p)
        if p.peek()[1].upper() == "PRIO":
            p.next()
            p.expect("=")
            p.value()
        p.end()
        return Stmt("trigger", [kind, when, delay, action], p.no)
    st = _statement_tail(p)
    p.end()
    return st


def _statement_tail(p: _Line) -> Stmt:
    """An assignment `$VAR[=…]=value` or a call `name(args)`."""
    t = p.next()
    if t[0] == "sys":
        if p.peek()[1] == "[":
            p.next()
            p.value()
            p.expect("]")
        p.expect("=")
        return Stmt("assign", [t[1], p.value()], p.no)
    if t[0] == "ident":
        return Stmt("call", [t[1], p.call_args()], p.no)
    raise KrlError(f"line {p.no}: expected a statement, found {t[1]!r}")


def _lines(text: str):
    for no, raw in enumerate(text.split("\n"), 1):
        if raw.strip().startswith("&"):
            continue
        toks = _tokens(raw, no)
        if toks:
            yield _Line(toks, no)


def parse_program(src: str, dat: str) -> Program:
    """Parse a .src/.dat pair and check it (see the module doc)."""
    lines = list(_lines(src))
    head = lines[0]
    head.expect("DEF")
    name = head.expect(kind="ident")[1]
    head.expect("(")
    head.expect(")")
    head.end()
    last = lines[-1]
    last.expect("END")
    last.end()
    prog = Program(name)
    depth = 0
    for ln in lines[1:-1]:
        st = _statement(ln)
        depth += {"if": 1, "endif": -1}.get(st.kind, 0)
        if depth < 0:
            raise KrlError(f"line {ln.no}: ENDIF without IF")
        prog.body.append(st)
    if depth:
        raise KrlError("IF without ENDIF")
    dlines = list(_lines(dat))
    dlines[0].expect("DEFDAT")
    dname = dlines[0].expect(kind="ident")[1]
    if dlines[0].peek()[1].upper() == "PUBLIC":
        dlines[0].next()
    dlines[0].end()
    if dname.upper() != name.upper():
        raise KrlError(f"DEFDAT {dname} does not match DEF {name}")
    dlines[-1].expect("ENDDAT")
    for ln in dlines[1:-1]:
        ln.expect("DECL")
        dtype = ln.expect(kind="ident")[1]
        dn = ln.expect(kind="ident")[1]
        ln.expect("=")
        v = ln.value()
        ln.end()
        if dn in prog.data:
            raise KrlError(f"line {ln.no}: {dn} declared twice")
        if dtype == "E6POS":
            if not isinstance(v, list) or [f for f, _ in v] != E6POS or not all(isinstance(x, float) for _, x in v):
                raise KrlError(f"line {ln.no}: E6POS {dn} must give X Y Z A B C E1..E6 numbers")
        prog.data[dn] = (dtype, v)
    # every target declared as an E6POS; every routine argument that names data declared
    for st in prog.motions():
        for target in st.args[:-1]:
            if st.kind == "PTP" and target.startswith("$"):
                continue
            if prog.data.get(target, ("",))[0] != "E6POS":
                raise KrlError(f"line {st.line}: motion target {target} not declared as E6POS in the .dat")
    for st in prog.body:
        call = st.args[3] if st.kind == "trigger" else st
        if call.kind == "call":
            for a in call.args[1]:
                if isinstance(a, str) and a[:1].isalpha() and a not in prog.data:
                    raise KrlError(f"line {st.line}: {call.args[0]} names undeclared data {a}")
    return prog


def arctech_seams(prog: Program, routine: str = "ArcMainNG") -> list[list[tuple[str, str, Stmt]]]:
    """The ArcTech seams of a program: lists of (phase, data set, motion) with phase "On" | "Swi" |
    "Off", checking that every motion between Before and After calls is exactly one motion with the
    same data set, and that seams run On, Swi…, Off."""
    seams, cur, pending = [], None, None
    for st in prog.body:
        if st.kind == "call" and st.args[0] == routine:
            action, wdat = st.args[1][0], st.args[1][1]
            m = re.fullmatch(r"#Arc(On|Swi|Off)(Before|After)MoveStd", action)
            if not m:
                continue
            phase, when = m.groups()
            if when == "Before":
                if pending is not None:
                    raise KrlError(f"line {st.line}: {action} inside another wrapped motion")
                pending = (phase, wdat, None)
            else:
                if pending is None or pending[:2] != (phase, wdat) or pending[2] is None:
                    raise KrlError(f"line {st.line}: {action} without its Before call and one motion")
                if phase == "On":
                    if cur is not None:
                        raise KrlError(f"line {st.line}: ARC ON inside a seam")
                    cur = []
                if cur is None:
                    raise KrlError(f"line {st.line}: ARC {phase.upper()} outside a seam")
                cur.append(pending)
                if phase == "Off":
                    seams.append(cur)
                    cur = None
                pending = None
        elif st.kind in ("LIN", "CIRC") and pending is not None:
            if pending[2] is not None:
                raise KrlError(f"line {st.line}: two motions between {routine} Before/After calls")
            pending = (pending[0], pending[1], st)
    if cur is not None or pending is not None:
        raise KrlError("a seam is not closed by ARC OFF")
    return seams
