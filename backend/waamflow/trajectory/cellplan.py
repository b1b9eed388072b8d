"""Positioner policy `auto`: the cell plans its own positioner angles and torch lean, layer by layer.

For each layer (in build order) candidates are tried from the cheapest to the most intrusive and
each one is verified with the same checks as the simulation — the arm's IK over the layer's
samples (seeded from the previous layer's last pose), joint limits (2° margin), near-singular
stretches and coal collisions of the arm and torch with the cell's bodies and the layers built so
far (`trajectory.collide.check_path` with 2 mm clearance) over the layer's own samples, the
travel into it included (the positioner turning from the previous layer's angles) — the same
samples, IK seed and collision spacing as the simulation's — and the first that passes is taken:

1. `gravity`: the layer turned flat (normal up), both Paden–Kahan branches with ±360° shifts,
   nearest the previous layer's angles first (the least axis motion);
2. `e2-turn` (2-axis positioners): the turntable turned by ±15°…±180° from the gravity angle, the
   tilt re-solved to bring the layer closest to flat, kept while the layer stays within the flat
   tolerance;
3. `lean`: the gravity angles with the torch leaned up to `max_lean_deg` from the layer normal
   (5° steps, towards ±x / ±y of the world);
4. `tilt-relax`: the tilt backed off the gravity angle by up to the flat tolerance (the layer no
   longer flat, within tolerance), with and without the lean;
5. `follow-normal` (`trajectory.cellfollow`): the angles vary along the layer, each point at the
   gravity angles of its own normal — a layer whose points' tool axes spread so that no single
   set of angles keeps every point within the flat tolerance;
6. `follow-turn` (2-axis positioners): the tilt at the gravity angle and the turntable turning
   along the layer so each point is welded at a fixed azimuth on the robot's side (0°, ±30°, ±60°
   off it) — a layer whose far side the arm cannot reach (or reaches colliding) at any fixed angle.

Stages 1-4 keep one set of angles for the whole layer; they count only when every point of the
layer (its own normal, not just the mean) stays within the flat tolerance. After a layer took a
`follow-*` stage the next tries that stage right after its gravity angles. A layer that follows
reports the angles at its first point, their span and the fastest positioner axis rate the
programmed speed needs against the URDF's (above it the simulation slows the path there).

A layer whose normal no positioner angle brings within the flat tolerance (a 1-axis positioner and
a part that leans about the other axis; for a layer whose normals spread, the point the worst off
at its own best angles) fails before any IK. When a layer has no passing candidate
the plan stops there with the best compromise (fewest failing samples) and, when asked, tries
cell changes — a riser under the part, a longer torch, the robot base moved away from the
positioner, a shipped 2-axis cell with the same arm, the part turned on a 1-axis table — re-running
the whole plan on each modified cell; only changes whose plan passes every layer are suggested.
Units: mm, deg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import cellfollow as follow
from .cell import Cell, _gravity_solutions, _rz, _sp1, positioner_kin, xyz3

# the suggested cell changes moved to trajectory.cellchanges (issue 27): still importable from here
from .cellchanges import BASE_SHIFTS_MM as BASE_SHIFTS_MM
from .cellchanges import RISERS_MM as RISERS_MM
from .cellchanges import TORCH_EXTENSIONS_MM as TORCH_EXTENSIONS_MM
from .cellchanges import modified_cell as modified_cell
from .cellchanges import suggest_changes

PLAN_LIMIT_MARGIN_DEG = 2.0  # a planned pose keeps every arm joint this far inside its limits
PLAN_CLEARANCE_MM = 2.0  # ... and every body this far from the others
LEAN_STEP_DEG = 5.0
E2_STEPS_DEG = tuple(d for k in range(1, 13) for d in (15.0 * k, -15.0 * k))
SPREAD_EPS_DEG = follow.SPREAD_EPS_DEG


@dataclass(frozen=True)
class AutoLimits:
    """Process limits of the `auto` policy: torch lean from the layer normal and how far the layer
    normal may stay off vertical (flat-position tolerance), deg."""

    max_lean_deg: float = 15.0
    flat_tol_deg: float = 5.0


@dataclass
class AutoPlan:
    """angles: (n, axes) deg per programmed point; tool_axis: (n, 3) part-frame torch axes with
    the chosen lean; layers: per layer what was chosen and why; ok: every layer passed; failed:
    None or {layer, reason, best}; suggestions: verified cell changes (when planning failed)."""

    angles: np.ndarray
    tool_axis: np.ndarray
    layers: list[dict] = field(default_factory=list)
    ok: bool = True
    failed: dict | None = None
    suggestions: list[dict] = field(default_factory=list)

    def report(self, limits: AutoLimits) -> dict:
        return {
            "policy": "auto",
            "max_lean_deg": limits.max_lean_deg,
            "flat_tol_deg": limits.flat_tol_deg,
            "ok": self.ok,
            "failed": self.failed,
            "layers": self.layers,
            "suggestions": self.suggestions,
        }


def _lean_rot(lean_deg: float, dir_deg: float) -> np.ndarray:
    """World rotation leaning a vertical torch by lean_deg with its tip moving towards azimuth dir_deg."""
    if lean_deg == 0:
        return np.eye(3)
    a = math.radians(dir_deg)
    k = np.array([-math.sin(a), math.cos(a), 0.0])  # rotation axis ⟂ to the lean direction
    th = math.radians(lean_deg)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(th) * K + (1 - math.cos(th)) * K @ K


class _Planner:
    def __init__(
        self,
        cell: Cell,
        moves,
        arm,
        limits: AutoLimits,
        step_mm: float,
        step_deg: float,
        collision_step_mm: float,
        collisions: bool,
    ):
        from .collide import layer_boxes

        self.cell, self.moves, self.arm, self.lim = cell, moves, arm, limits
        self.step_mm, self.step_deg, self.col_step, self.collisions = step_mm, step_deg, collision_step_mm, collisions
        self.m = cell.axes
        pos = cell.positioner
        if pos is None:  # plan_auto keeps a cell without a positioner at its fixed angles
            raise ValueError(f"cell {cell.name}: the auto plan needs a positioner")
        pk = positioner_kin(pos.urdf)
        self.lo, self.hi = pk.lower_deg, pk.upper_deg
        Rb = _rz(pos.base.yaw_deg)
        self.w = pk.axes_base(pos.flange) @ Rb.T
        self.R0 = cell.work_pose(np.zeros(self.m))[0]
        self.P = np.asarray(moves.points, float)
        self.A = np.asarray(moves.tool_axis, float)
        self.seg_layer = np.asarray(moves.layer)
        self.arc = np.asarray(moves.arc, bool)
        yaw = math.radians(cell.robot_base.yaw_deg)
        self.base_R = np.array([[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0, 0, 1.0]])
        self.base_t = np.asarray(cell.robot_base.xyz_mm, float)
        self.layer_boxes = layer_boxes(moves) if collisions else {}
        margin = math.radians(PLAN_LIMIT_MARGIN_DEG)
        self.qlo, self.qhi = arm.lower + margin, arm.upper - margin

    # ---- geometry --------------------------------------------------------------------------
    def tilt(self, e, n) -> float:
        """Angle (deg) of the part-frame normal n from world vertical at angles e."""
        up = self.cell.work_pose(e)[0] @ n
        return math.degrees(math.acos(float(np.clip(up[2], -1.0, 1.0))))

    def inside(self, e) -> bool:
        return bool(np.all(e >= self.lo - 1e-7) and np.all(e <= self.hi + 1e-7))

    def shifted(self, c, prev) -> np.ndarray | None:
        """c (deg) with ±360° shifts per axis nearest prev inside the limits (None: outside)."""
        v = np.empty(len(c))
        for j in range(len(c)):
            k0 = round((prev[j] - c[j]) / 360.0)
            ok = [
                c[j] + 360.0 * k
                for k in (k0 - 1, k0, k0 + 1)
                if self.lo[j] - 1e-7 <= c[j] + 360.0 * k <= self.hi[j] + 1e-7
            ]
            if not ok:
                return None
            v[j] = min(ok, key=lambda o: abs(o - prev[j]))
        return v

    def gravity(self, n, prev) -> list[np.ndarray]:
        sols = [np.degrees(s) for s in _gravity_solutions(self.w, self.R0 @ n, np.array([0.0, 0.0, 1.0]))]
        if self.m == 2 and np.linalg.norm(np.cross(self.R0 @ n, self.w[1])) < 1e-6:
            sols = [np.array([s[0], prev[1]]) for s in sols]
        out = [v for v in (self.shifted(s, prev) for s in sols) if v is not None]
        return sorted(out, key=lambda v: (float(np.abs(v - prev).sum()), -float(v[0])))

    def best_tilt(self, n, prev) -> tuple[np.ndarray, float]:
        """The in-limit angles bringing n closest to vertical (the gravity angles, else the
        closest clipped) and the tilt left (deg)."""
        g = self.gravity(n, prev)
        if g:
            return g[0], self.tilt(g[0], n)
        from .cell import _nearest

        sols = [np.degrees(s) for s in _gravity_solutions(self.w, self.R0 @ n, np.array([0.0, 0.0, 1.0]))]
        e, _ = _nearest(sols, prev, self.lo, self.hi)
        return e, self.tilt(e, n)

    def candidates(self, n, prev, last: dict | None, quick: bool = False):
        """(stage, angles, lean deg, lean direction deg, note) cheapest first. quick: the gravity
        angles and the largest lean only (a first test of a cell change)."""
        lim = self.lim
        grav = self.gravity(n, prev)
        base = grav[0] if grav else self.best_tilt(n, prev)[0]
        seen = []

        def fresh(e, lean, d):
            key = (tuple(np.round(e, 6)), round(lean, 6), round(d, 6) if lean else 0.0)
            if key in seen:
                return False
            seen.append(key)
            return True

        for k, e in enumerate(grav):
            if fresh(e, 0.0, 0.0):
                yield "gravity", e, 0.0, 0.0, "layer flat" + (" (other branch)" if k else "")
        if last and last["stage"] in ("e2-turn", "lean", "tilt-relax") and grav:  # what worked on the layer before
            e = base.copy()
            if last["stage"] == "tilt-relax":
                e[0] = base[0] + last["relax_deg"]
            if (
                self.inside(e)
                and self.tilt(e, n) <= lim.flat_tol_deg + 1e-6
                and fresh(e, last["lean_deg"], last["lean_dir_deg"])
            ):
                yield last["stage"], e, last["lean_deg"], last["lean_dir_deg"], f"as the previous layer: {last['note']}"
        leans = [LEAN_STEP_DEG * k for k in range(1, int(lim.max_lean_deg / LEAN_STEP_DEG + 1e-9) + 1)]
        if lim.max_lean_deg not in leans and lim.max_lean_deg > 0:
            leans.append(lim.max_lean_deg)
        dirs = (0.0, 180.0, 90.0, 270.0)
        if quick:
            for d in dirs if leans else ():
                if fresh(base, leans[-1], d):
                    yield "lean", base, leans[-1], d, f"torch leaned {leans[-1]:g}° towards azimuth {d:g}°"
            return
        if self.m == 2 and grav:
            for d in E2_STEPS_DEG:
                e2 = base[1] + d
                Rz2 = _axis_rot(self.w[1], e2)
                e1 = math.degrees(_sp1(self.w[0], Rz2 @ (self.R0 @ n), np.array([0.0, 0.0, 1.0])))
                turned = self.shifted(np.array([e1, e2]), prev)
                if turned is None or self.tilt(turned, n) > lim.flat_tol_deg + 1e-6 or not fresh(turned, 0.0, 0.0):
                    continue
                yield "e2-turn", turned, 0.0, 0.0, f"turntable {d:+.0f}° from the gravity angle"
        for lean in leans:
            for d in dirs:
                if fresh(base, lean, d):
                    yield "lean", base, lean, d, f"torch leaned {lean:g}° towards azimuth {d:g}°"
        relax = sorted({lim.flat_tol_deg / 2, lim.flat_tol_deg} - {0.0})
        for r in relax:
            for sgn in (-1.0, 1.0) if base[0] >= 0 else (1.0, -1.0):
                e = base.copy()
                e[0] = base[0] + sgn * r
                if not self.inside(e) or self.tilt(e, n) > lim.flat_tol_deg + 1e-6:
                    continue
                for lean in [0.0, *leans[-1:]]:  # with the torch upright or leaned the most
                    for d in dirs if lean else (0.0,):
                        if fresh(e, lean, d):
                            yield (
                                "tilt-relax",
                                e,
                                lean,
                                d,
                                f"tilt {sgn * r:+g}° off flat"
                                + (f", torch leaned {lean:g}° towards {d:g}°" if lean else ""),
                            )

    # ---- verification ----------------------------------------------------------------------
    def check(self, a: int, b: int, e, lean: float, d: float, q_seed, first=None):
        """IK + limits + singularities + collisions on points a..b (the layer's segments, its
        travel in included) at angles e ((axes,), or (b - a + 1, axes) per point) with the lean;
        first: (angles, lean, direction) of point a
        when it ends the previous layer's arc (the travel turns from there, as in the simulation).
        The samples, their IK seed and the collision spacing are the simulation's, so its verdict
        on the chosen angles is the same."""
        from .cell import coordinated_samples
        from .collide import check_path
        from .kinematics import REACH_TOL_MM, SINGULAR_SIGMA, CellFrames, solve_samples

        cell = self.cell
        e = np.asarray(e, float)
        if e.ndim == 2:  # per point (the follow-* stages: no lean)
            if lean:
                raise ValueError("a per-point positioner plan takes no torch lean")
            ax, ang = self.A[a : b + 1].copy(), e.copy()
        else:
            R = cell.work_pose(e)[0]
            ax = self.A[a : b + 1] @ (R.T @ _lean_rot(lean, d) @ R).T
            ang = np.tile(e, (b - a + 1, 1))
        if first is not None:
            e0, lean0, d0 = first
            R0 = cell.work_pose(e0)[0]
            ang[0] = e0
            ax[0] = (R0.T @ _lean_rot(lean0, d0) @ R0) @ self.A[a]
        s, xyz, axw, sg, angs = coordinated_samples(cell, self.P[a : b + 1], ax, ang, self.step_mm, self.step_deg)
        frames = CellFrames(base_xyz_mm=xyz3(cell.robot_base.xyz_mm), base_yaw_deg=cell.robot_base.yaw_deg)
        ks = solve_samples(self.arm, s, xyz, sg, axw, b - a, frames, q_seed=q_seed, stop_unreachable=True)
        unreach = int(np.count_nonzero(ks.reach_err > REACH_TOL_MM))
        limit = int(np.count_nonzero(np.any((ks.q < self.qlo) | (ks.q > self.qhi), axis=1)))
        sing = int(np.count_nonzero(ks.sigma_min < SINGULAR_SIGMA))
        ncol, hit = 0, None
        if self.collisions and unreach == 0 and limit == 0 and sing == 0:
            poses: dict = {}

            def work(i):
                key = tuple(np.round(angs[i], 9))
                if key not in poses:
                    poses[key] = (*cell.work_pose(np.asarray(key)), np.asarray(key))
                return poses[key]

            ncol, found, _ = check_path(
                self.arm,
                ks.q,
                ks.s,
                ks.seg + a,
                self.moves,
                cell,
                work,
                self.base_R,
                self.base_t,
                step_mm=self.col_step,
                layers=self.layer_boxes,
                margin_mm=PLAN_CLEARANCE_MM,
            )
            hit = found[0].bodies if found else None
        res: dict[str, int | str] = {
            "unreachable": unreach,
            "near_limit": limit,
            "near_singular": sing,
            "collisions": ncol,
        }
        if hit:
            res["collision"] = " / ".join(hit)
        return res, ks.q[-1]


def _axis_rot(w, deg) -> np.ndarray:
    th = math.radians(deg)
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    return np.eye(3) + math.sin(th) * K + (1 - math.cos(th)) * K @ K


def _why(res: dict) -> str:
    parts = [
        f"{res[k]} {k.replace('_', ' ')} samples" for k in ("unreachable", "near_limit", "near_singular") if res.get(k)
    ]
    if res.get("collisions"):
        parts.append(f"{res['collisions']} colliding samples ({res.get('collision', '')})")
    return ", ".join(parts) or "ok"


def _bad(res: dict) -> int:
    return res["unreachable"] * 4 + res["collisions"] * 4 + res["near_limit"] + res["near_singular"]


def plan_auto(
    cell: Cell,
    moves,
    arm,
    limits: AutoLimits = AutoLimits(),
    step_mm: float = 5.0,
    step_deg: float = 1.0,
    collision_step_mm: float = 20.0,
    collisions: bool = True,
    suggest: bool = True,
    only: int | None = None,
    quick: bool = False,
) -> AutoPlan:
    """The `auto` plan (see the module doc). A cell without a positioner keeps its fixed angles.
    only, quick: plan that one layer alone (from the fixed angles and the arm's home pose) with
    the gravity angles and the largest lean only — a first test of a cell change before the
    whole plan."""
    n = len(moves.points)
    fixed = cell.fixed_angles()
    m = len(fixed)
    if m == 0 or n < 2:
        return AutoPlan(np.tile(fixed, (n, 1)), np.asarray(moves.tool_axis, float).copy())
    pl = _Planner(cell, moves, arm, limits, step_mm, step_deg, collision_step_mm, collisions)
    seg_layer, arc = pl.seg_layer, pl.arc
    layers = sorted(set(seg_layer.tolist()))
    # every layer's normal first: a layer the positioner cannot bring within the flat tolerance
    # fails before any IK (the lean this cell cannot remove)
    info = _layer_normals(pl, layers, fixed)
    plan = AutoPlan(np.tile(fixed, (n, 1)), pl.A.copy())
    steep = [L for L in layers if info[L][2] > limits.flat_tol_deg + 1e-6]
    if steep:
        plan.ok = False
        plan.failed = _flat_failure(steep, info, limits)
    else:
        chosen: dict[int, tuple] = {}
        prev, q_seed, last = fixed.copy(), arm.home.copy(), None
        for L in layers if only is None else [only]:
            own = np.flatnonzero(seg_layer == L)  # with the travel into the layer
            a, b = int(own.min()), int(own.max()) + 1
            before = int(seg_layer[a - 1]) if a > 0 and arc[a - 1] else None
            first = _at(chosen[before], a) if before in chosen else None
            best, tried, first_fail, along = _search(pl, a, b, info[L][1], prev, last, q_seed, first, quick)
            if best is None or best[6] is None:
                plan.ok = False
                plan.failed = _no_candidate(L, tried, best, along)
                break
            stage, e, lean, d, note, res, q_end = best
            chosen[L] = (e, lean, d, a if np.ndim(e) == 2 else None)
            why = note if tried == 1 else f"{note} ({tried - 1} cheaper choices failed, the first: {first_fail})"
            plan.layers.append(_row(pl, L, a, b, best, tried, why, info[L][1]))
            last = {
                "stage": stage,
                "note": note.removeprefix("as the previous layer: "),
                "lean_deg": lean,
                "lean_dir_deg": d,
                "relax_deg": float(e[0] - (pl.gravity(info[L][1], prev) or [e])[0][0])
                if stage == "tilt-relax"
                else 0.0,
            }
            prev, q_seed = (e[-1] if np.ndim(e) == 2 else e), q_end
        if plan.ok and only is None:
            _apply(plan, pl, chosen)
    if not plan.ok and suggest:
        plan.suggestions = suggest_changes(
            cell, moves, arm, limits, step_mm, step_deg, collision_step_mm, collisions, plan.failed
        )
    return plan


def _search(pl: _Planner, a: int, b: int, nrm, prev, last, q_seed, first, quick: bool):
    """The first candidate of the layer on points a..b that passes `check` (best: (stage, angles,
    lean, direction, note, result, arm pose at the end)), else the best compromise (its pose
    None); the number tried, the first failure's note and, on a failure, the best along-layer
    candidate's (None when none was tried)."""
    best, tried, first_fail, along = None, 0, None, None
    for stage, e, lean, d, note in _layer_candidates(pl, a, b, nrm, prev, last, quick):
        tried += 1
        res, q_end = pl.check(a, b, e, lean, d, q_seed, first)
        if _bad(res) == 0:
            return (stage, e, lean, d, note, res, q_end), tried, first_fail, None
        if first_fail is None:
            first_fail = f"{note}: {_why(res)}"
        if best is None or _bad(res) < _bad(best[5]):
            best = (stage, e, lean, d, note, res, None)
        if stage in follow.FOLLOW_STAGES and (along is None or _bad(res) < along[0]):
            along = (_bad(res), f"{stage}, {note}: {_why(res)}")
    return best, tried, first_fail, None if along is None else along[1]


def _layer_candidates(pl: _Planner, a: int, b: int, nrm, prev, last, quick: bool):
    """The layer's candidates cheapest first: the per-layer ones (`_Planner.candidates`; on a
    layer whose normals spread, only those that keep every point within the flat tolerance),
    then the along-layer ones (`cellfollow.candidates`); the previous layer's follow stage right
    after the gravity angles."""
    normals = follow.point_normals(pl, follow.arc_points(pl, a, b))
    spread = follow.spread_deg(normals)
    again = last["stage"] if last and last["stage"] in follow.FOLLOW_STAGES and not quick else None
    done: set = set()

    def along(stages, azimuths=follow.FOLLOW_AZIMUTHS_DEG):
        for c in follow.candidates(pl, a, b, nrm, prev, stages, spread, azimuths):
            if (c[0], c[3]) not in done:
                done.add((c[0], c[3]))
                yield c

    for c in pl.candidates(nrm, prev, last, quick=quick):
        if again and c[0] != "gravity":
            yield from along((again,), (last["lean_dir_deg"],))
            again = None
        if spread > SPREAD_EPS_DEG and follow.point_tilts(pl, c[1], normals).max() > pl.lim.flat_tol_deg + 1e-6:
            continue  # one set of angles leaves some point of this layer off flat
        yield c
    if again:
        yield from along((again,), (last["lean_dir_deg"],))
    if not quick:
        yield from along(follow.FOLLOW_STAGES)


def _at(entry: tuple, i: int) -> tuple:
    """(angles, lean, direction) of point i under a chosen layer entry (angles, lean, direction,
    first point index or None when the angles are the layer's)."""
    e, lean, d, a0 = entry
    return (e if a0 is None else e[i - a0]), lean, d


def _row(pl: _Planner, L: int, a: int, b: int, best: tuple, tried: int, why: str, nrm) -> dict:
    """The plan report's row of layer L (points a..b) for the chosen candidate."""
    stage, e, lean, d, _, _, _ = best
    if np.ndim(e) == 1:
        return {
            "layer": int(L),
            "stage": stage,
            "e_deg": [round(float(v), 4) for v in e],
            "lean_deg": lean,
            "lean_dir_deg": d if lean else 0.0,
            "tilt_deg": round(pl.tilt(e, nrm), 3),
            "tried": tried,
            "why": why,
        }
    return follow.row(pl, L, a, b, stage, e, tried, why)


def _layer_normals(pl: _Planner, layers: list, fixed: np.ndarray) -> dict:
    """Per layer (in build order): its welding segments (all its segments when it has none), its
    mean normal and the lean from flat (deg) the best positioner angles leave it, each layer's
    angles sought from the previous layer's. On a layer whose point normals spread, the lean is
    the smaller of the mean's and the worst point's at its own best angles (what follow-normal
    leaves)."""
    seg_layer, arc = pl.seg_layer, pl.arc
    info, prev = {}, fixed.copy()
    for L in layers:
        segs = np.flatnonzero((seg_layer == L) & arc)
        if len(segs) == 0:
            segs = np.flatnonzero(seg_layer == L)
        nrm = -pl.A[segs].mean(axis=0)
        nrm /= max(np.linalg.norm(nrm), 1e-12)
        e, tilt = pl.best_tilt(nrm, prev)
        if tilt > 1e-6:
            normals = follow.point_normals(pl, np.unique(np.concatenate([segs, segs + 1])))
            if follow.spread_deg(normals) > SPREAD_EPS_DEG:
                cur, worst = prev, 0.0
                for v in normals:
                    cur, t = pl.best_tilt(v, cur)
                    worst = max(worst, t)
                tilt = min(tilt, worst)
        info[L] = (segs, nrm, tilt)
        prev = e
    return info


def _flat_failure(steep: list, info: dict, limits: AutoLimits) -> dict:
    """The plan's `failed` entry for the layers no positioner angle brings within the flat tolerance."""
    worst = max(steep, key=lambda L: info[L][2])
    return {
        "layer": int(steep[0]),
        "reason": "flat",
        "layers": _ranges(steep),
        "lean_deg": round(info[worst][2], 2),
        "worst_layer": int(worst),
        "message": (
            f"this cell's positioner cannot turn layers {_ranges(steep)} within "
            f"{limits.flat_tol_deg:g}° of flat: they keep up to {info[worst][2]:.1f}° of lean "
            f"(layer {worst})"
        ),
    }


def _no_candidate(L, tried: int, best: tuple | None, along: str | None = None) -> dict:
    """The plan's `failed` entry for layer L when none of its `tried` candidates passes, with the
    best compromise (stage, angles — at the layer's first point when they vary along it —, lean,
    lean direction, note, check result), if any; along: the best along-layer candidate's note."""
    why = _why(best[5]) if best else "no angles inside the axis limits"
    return {
        "layer": int(L),
        "reason": "no candidate",
        "tried": tried,
        "best": None
        if best is None
        else {
            "stage": best[0],
            "e_deg": [round(float(v), 3) for v in np.atleast_2d(best[1])[0]],
            "lean_deg": best[2],
            "lean_dir_deg": best[3],
            "note": best[4],
            **best[5],
        },
        "message": f"layer {L}: none of {tried} positioner/torch choices passes; best compromise: "
        + (f"{best[4]} at E = {', '.join(f'{v:.1f}' for v in np.atleast_2d(best[1])[0])}° ({why})" if best else why)
        + (f"; along the layer: {along}" if along else ""),
    }


def _apply(plan: AutoPlan, pl: _Planner, chosen: dict) -> None:
    """Per point: the angles and leaned torch axis of the segment it ends (arc ON), else starts."""
    n = len(pl.P)
    lay = pl.seg_layer
    for i in range(n):
        s = i - 1 if i > 0 and pl.arc[i - 1] else min(i, n - 2)
        e, lean, d = _at(chosen[int(lay[s])], i)
        plan.angles[i] = e
        if lean:
            R = pl.cell.work_pose(e)[0]
            plan.tool_axis[i] = (R.T @ _lean_rot(lean, d) @ R) @ pl.A[i]


def _ranges(v: list[int]) -> str:
    out, i = [], 0
    while i < len(v):
        j = i
        while j + 1 < len(v) and v[j + 1] == v[j] + 1:
            j += 1
        out.append(f"{v[i]}" if i == j else f"{v[i]}..{v[j]}")
        i = j + 1
    return ", ".join(out)
