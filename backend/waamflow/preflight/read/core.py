"""What every program reader gives (`ProgramRead`: the arc-ON runs in program order) and the
builder they fill from the program's motions and comments (`RunBuilder`)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_LAYER = re.compile(r"\blayer (\d+)\b")
_SECTION = re.compile(r"\bsection (\S+)")


@dataclass
class Run:
    """One arc-ON run: ignition to extinction.

    points: (k, 3) float mm. speed: (k - 1,) float mm/s (nan: not stated). wfs: (k - 1,) float
    m/min (nan: not commanded). weld: (k - 1,) bool, some weld parameter commanded for the segment.
    ext: where the external axes the program states (a positioner's, degrees; nan where one is
    not stated) change along the run: [(index of the first point they hold for, values (m,))];
    empty when the program states none (check `weld_position`).
    """

    points: np.ndarray
    speed: np.ndarray
    wfs: np.ndarray
    weld: np.ndarray
    layer: int | None
    section: str | None
    line: int
    ext: list[tuple[int, np.ndarray]] = field(default_factory=list)

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.diff(self.points, axis=0), axis=1).sum()) if len(self.points) > 1 else 0.0


@dataclass
class ProgramRead:
    format: str
    runs: list[Run] = field(default_factory=list)
    travel_mm: float = 0.0
    # the lowest point a motion with the arc off reaches, and the layer it is in (bottom.py: a travel
    # below the plate); None without travel
    travel_low: tuple[np.ndarray, int | None] | None = None
    notes: list[str] = field(default_factory=list)  # what the reader could not interpret
    # motions it cannot place and frames changed after the program has moved (check: `unreadable`)
    unplaced: list[str] = field(default_factory=list)
    weld_commanded: bool = True  # False: the format carries no weld data at all
    # arc-ON motion targets whose torch orientation the program states: (point (3,), tool axis (3,):
    # the unit vector from the torch towards the part, in the program's frame), check `torch_axis`
    oriented: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    # arc-OFF straight moves between known points: (from (3,), to (3,), the number of runs welded
    # before it), check `travel_collision`
    travels: list[tuple[np.ndarray, np.ndarray, int]] = field(default_factory=list)
    # dwells with the arc on: [where (3,), seconds, wire feed m/min or nan, the Run it is in (None: a
    # run with no motion, dropped)]: metal laid in one spot
    dwells: list[list] = field(default_factory=list)

    @property
    def travel_z_min(self) -> float:
        """The z of `travel_low`, mm; inf without travel."""
        return float(self.travel_low[0][2]) if self.travel_low is not None else math.inf


def circle_through(p0: np.ndarray, via: np.ndarray, p1: np.ndarray, step_deg: float = 5.0) -> np.ndarray:
    """A circular motion as a robot controller runs it (KRL CIRC, RAPID MoveC/ArcC): the arc of the
    circle through start p0, auxiliary point `via` and end p1 that passes `via`, as points every
    `step_deg` at most after p0 (p1 last). Three points on a line (or two that coincide): the
    straight moves p0 → via → p1."""
    a, b = via - p0, p1 - p0
    n = np.cross(a, b)
    nn = float(n @ n)
    if nn < 1e-12 * max(float(a @ a) * float(b @ b), 1e-30):
        return np.vstack([via, p1])
    # the centre: p0 + (|a|² (b × n) + |b|² (n × a)) / (2 |n|²)
    c = p0 + (float(a @ a) * np.cross(b, n) + float(b @ b) * np.cross(n, a)) / (2.0 * nn)
    u = p0 - c
    r = float(np.linalg.norm(u))
    u /= r
    w = np.cross(n / math.sqrt(nn), u)  # in the plane, 90° on from u the way p0 → via → p1 turns

    def angle(p: np.ndarray) -> float:
        d = p - c
        return math.atan2(float(d @ w), float(d @ u)) % (2 * math.pi)

    sweep = angle(p1) or 2 * math.pi  # via lies on the way (n is a × b: the turn p0 → via → p1)
    k = max(2, int(math.ceil(math.degrees(sweep) / step_deg)))
    t = sweep * np.arange(1, k + 1) / k
    pts = c + r * (np.outer(np.cos(t), u) + np.outer(np.sin(t), w))
    pts[-1] = p1
    return pts


class RunBuilder:
    """Collects motions while the arc is on; layer/section from the program's comments."""

    def __init__(self, fmt: str) -> None:
        self.out = ProgramRead(fmt)
        self.layer: int | None = None
        self.section: str | None = None
        self.pts: list | None = None
        self.started = False  # pts[0] is a finite position (kept with pts[0]: move_to tests it per motion)
        self.speed: list[float] = []
        self.wfs: list[float] = []
        self.weld: list[bool] = []
        self.line = 0
        self.run_layer: int | None = None
        self.run_section: str | None = None
        self.pos: np.ndarray | None = None
        self.frames: dict[str, str] = {}  # frame kind → what the program set it to (`frame`)
        self.lost = False  # a travel went somewhere unknown (`unplaced`): the program has moved
        self.pending: str | None = None  # KRL TRIGGER ... DISTANCE=1: "on"/"off" at the end of the next motion
        self.axis: np.ndarray | None = None  # the tool axis of the next `move`'s targets (robot dialects)
        # the external axes (a positioner's, degrees) of the next motion's targets, as the program
        # states them (`positioner`); None: it states none (they hold until a reader sets others)
        self.ext: np.ndarray | None = None
        self.run_ext: list[tuple[int, np.ndarray]] = []  # Run.ext of the run under way
        self._ext_made: dict[tuple[float, ...], np.ndarray] = {}  # one array per set of values
        self.run_dwells: list[int] = []  # the dwells (in out.dwells) of the run under way

    def frame(self, kind: str, value: str, where: str) -> None:
        """A frame (work offset, work object, base, tool) set to `value`: once the program has
        moved, a change is a motion the preflight cannot place (the frames' values are the
        controller's, not the program's)."""
        old = self.frames.get(kind)
        if self.moved and value != old:
            self.out.unplaced.append(
                f"{where}: the {kind} changes from {old or 'the one the program started in'} to {value} after the "
                "program has moved; where the new one lies is the controller's setting"
            )
        self.frames[kind] = value

    @property
    def moved(self) -> bool:
        """The program has moved: a position is known, or a travel went somewhere unknown."""
        return self.pos is not None or self.lost

    def unplaced(self, what: str) -> None:
        """A motion the reader cannot place: with the arc on, the deposit there is unknown
        (`ProgramRead.unplaced`, a failed check); with it off, a travel to somewhere unknown (a
        note), after which the torch's position is unknown until the next absolute target."""
        if self.pts is not None:
            self.out.unplaced.append(what)
            return
        self.out.notes.append(f"{what} (arc off: a travel the preflight does not follow)")
        self.pos, self.lost = None, True

    def dwell(self, seconds: float, wfs: float) -> None:
        """A dwell: with the arc on (a run under way, its place known) the wire feeds in one spot
        (`ProgramRead.dwells`); with it off, nothing is laid."""
        if self.pts is None or seconds <= 0:
            return
        here = self.pos if self.pos is not None else self.pts[0]
        if np.isfinite(here).all():
            self.run_dwells.append(len(self.out.dwells))
            self.out.dwells.append([np.array(here, float), float(seconds), float(wfs), None])  # its run: at close

    def comment(self, text: str) -> None:
        m = _LAYER.search(text)
        if m and text.lstrip(" -;!#(").startswith("layer"):
            self.layer = int(m.group(1))
        m = _SECTION.search(text)
        if m and text.lstrip(" -;!#(").startswith("section"):
            self.section = m.group(1)

    def arc_on(self, line: int) -> None:
        self.close()
        start = self.pos if self.pos is not None else np.full(3, np.nan)
        self.pts, self.speed, self.wfs, self.weld, self.line = [start.copy()], [], [], [], line
        self.started = bool(np.isfinite(start).all())
        self.run_layer, self.run_section = self.layer, self.section
        self.run_ext = []
        self._mark_ext(0)

    def close(self) -> None:
        if self.pts is not None and len(self.pts) > 1 and np.isfinite(self.pts[0]).all():
            self.out.runs.append(
                Run(
                    np.asarray(self.pts, float),
                    np.asarray(self.speed, float),
                    np.asarray(self.wfs, float),
                    np.asarray(self.weld, bool),
                    self.run_layer,
                    self.run_section,
                    self.line,
                    self.run_ext,
                )
            )
            for i in self.run_dwells:  # the run's dwells are in it (a run dropped: theirs stay None)
                self.out.dwells[i][3] = self.out.runs[-1]
        self.run_dwells = []
        self.run_ext = []
        self.pts = None

    def positioner(self, values: tuple[float, ...]) -> None:
        """The external axes' values (degrees; nan: not stated) of the next motions' targets. Equal
        values give the very same array, so a run records only where they change (`_mark_ext`),
        at the cost of a dictionary look-up per target (100,000 targets on curved-bracket)."""
        e = self._ext_made.get(values)
        if e is None:
            e = self._ext_made[values] = np.array(values, float)
        self.ext = e

    def _mark_ext(self, at: int) -> None:
        """The external axes in force hold from point `at` of the run under way (a change only)."""
        e = self.ext
        if e is None or (self.run_ext and self.run_ext[-1][1] is e):
            return
        self.run_ext.append((at, e))

    def move(self, targets: np.ndarray, speed: float, wfs: float, weld: bool) -> None:
        targets = np.atleast_2d(np.asarray(targets, float))
        last = targets[-1].copy()  # where the motion ends (targets may lose its first row below)
        if self.pts is not None:
            if not np.isfinite(self.pts[0]).all():  # arc on before any position: start where it first moves
                self.pts = [targets[0]]
                self.started = bool(np.isfinite(targets[0]).all())
                targets = targets[1:]
                self.run_ext = []
                self._mark_ext(0)
            if len(targets):
                self._mark_ext(len(self.pts))
            for t in targets:
                self.pts.append(t)
                self.speed.append(speed)
                self.wfs.append(wfs)
                self.weld.append(weld)
                if self.axis is not None:
                    self.out.oriented.append((t, self.axis))
        else:
            if self.pos is not None:
                seg = np.vstack([self.pos, targets])
                self.out.travel_mm += float(np.linalg.norm(np.diff(seg, axis=0), axis=1).sum())
                done = len(self.out.runs)
                self.out.travels.extend((a, b, done) for a, b in zip(seg[:-1], seg[1:]))
            z = targets[:, 2]
            k = int(np.nanargmin(z)) if np.isfinite(z).any() else -1  # nan: an axis not yet known
            if k >= 0 and z[k] < self.out.travel_z_min:
                self.out.travel_low = (targets[k].copy(), self.layer)
        self.pos = last
        self._after_move()

    def extend(self, p: np.ndarray, speed: float, wfs: float, weld: bool) -> bool:
        """`move` to the one point p (shape (3,)) in a run under way, without move's arrays (most
        motions of a program); False, nothing done, when no run is under way."""
        if self.pts is None or not self.started:
            return False
        if self.ext is not None:
            self._mark_ext(len(self.pts))
        self.pts.append(p)
        self.speed.append(speed)
        self.wfs.append(wfs)
        self.weld.append(weld)
        self.pos = p
        self._after_move()
        return True

    def move_to(self, x: float, y: float, z: float, speed: float, wfs: float, weld: bool) -> None:
        """`move` of one straight motion, without the arrays (a G-code program is mostly these)."""
        if self.extend(np.array((x, y, z)), speed, wfs, weld):
            return
        if self.pts is None and self.pos is not None:
            p = self.pos
            self.out.travel_mm += math.sqrt((x - p[0]) ** 2 + (y - p[1]) ** 2 + (z - p[2]) ** 2)
            self.pos = np.array((x, y, z))
            self.out.travels.append((p, self.pos, len(self.out.runs)))
            if z < self.out.travel_z_min:
                self.out.travel_low = (self.pos.copy(), self.layer)
            self._after_move()
        else:
            self.move(np.array((x, y, z)), speed, wfs, weld)

    def moves_to(self, xyz: np.ndarray, speeds: list[float], wfs: float, weld: bool) -> None:
        """`move_to` of each row of xyz (k, 3) in turn, `speeds` (k,) their speeds: the points of a
        run under way are added at once (rows of xyz, the same values `move_to` would add)."""
        i, n = 0, len(xyz)
        while i < n and not (self.pts is not None and self.started and self.pending is None):
            x, y, z = xyz[i].tolist()
            self.move_to(x, y, z, speeds[i], wfs, weld)
            i += 1
        if i == n:
            return
        assert self.pts is not None  # the loop ended with a run under way
        if self.ext is not None:
            self._mark_ext(len(self.pts))
        rows = list(xyz[i:])
        self.pts.extend(rows)
        self.speed.extend(speeds[i:])
        self.wfs.extend([wfs] * (n - i))
        self.weld.extend([weld] * (n - i))
        self.pos = rows[-1]

    def _after_move(self) -> None:
        if self.pending == "off":
            self.close()
        elif self.pending == "on":
            self.arc_on(self.line)
        self.pending = None
