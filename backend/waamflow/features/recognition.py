"""Feature recognition of thin-wall midsurface curves by valence (Venturini et al. 2018, §3).

Input: the midsurface curves of one layer, each an (k, 2) float polyline in mm (a closed curve
repeats its first point). Every curve end point and every curve–curve intersection point is
collected; points within `merge_tol` mm are one point (the study merges within 1e-6 mm). At each
such junction we count the entities (curves) through it, how many of them *end* there and how many
*pass through*; the number of wall branches leaving the junction is ends + 2·throughs. That
reproduces the study's taxonomy (its Table of intersection/end-point valences), extended to any
number of branches:

    entities  ends  branches  kind                     study valences (intersections, ends)
    1         1     1         free_end                 (0, 1)
    2         2     2         corner | continuous      (2, 2)  by the angle between the walls
    2         1     3         t_crossing               (2, 1)
    2         0     4         direct_crossing          (1, 0)
    3         3     3         odd_t_crossing           (6, 3)
    3         2     4         odd_direct_crossing      (6, 2)
    4         4     4         four_direct_crossing     (12, 4)

A drawn entity split where another wall passes (an X whose crossing arm is two collinear curves)
stays two entities even when the sketch reader joined it into one polyline: a sketch joint on a
pass-through counts as two entity ends there, so that X is an odd direct crossing as in the study.
Curves that continue each other across a small gap are joined first (`join_collinear`).

T sub-types (study: straight / open / closed T-crossing), for every three-branch crossing, by the
largest angle θ between neighbouring branches and the flat-corner threshold c = corner_angle_deg:
straight when 180° − c < θ < 180° + c (a flat side, bridged straight across), open when
θ ≥ 180° + c (a reflex side: the stem stands inside a bent wall's corner), closed when
θ ≤ 180° − c (every side a fillet corner). Reported as "subtype" on t_crossing and
odd_t_crossing (a straight odd_t_crossing is a straight wall split at the stem). The study's
summary names the sub-types without defining them; reading them by the largest angle is ours,
chosen so the sub-type says what the crossing construction does (bridge, reflex side, three
fillets).

Other combinations map by branch count: 3 branches → t_crossing (2 entities) or odd_t_crossing
(≥ 3); ≥ 4 branches → direct_crossing / odd_direct_crossing / four_direct_crossing by entities.
A sharp vertex inside one polyline (turning by at least `corner_angle_deg`) is a corner too, and
an isolated shallow kink (turning by `continuous_min_deg` up to `corner_angle_deg`, neighbours not
turning alike, i.e. not a discretised arc) is a continuous junction: curves joined end to end by the
sketch reader stay listed as the junction of two walls.

Closed loops (a closed curve, or open curves chained end to end through corner/continuous
junctions) that touch nothing else are tubulars; a tubular is *isolated* when the band between its
inward and outward offsets by half the torch encumbrance touches no other curve (the torch cannot
collide, so it may be built on its own, helically).

The junction points, their incidences and branch directions and the valence → kind table are
computed in `junctions`; this module joins the curves first, adds the vertex junctions, finds the
tubulars and writes the features.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from shapely.geometry import LineString, Polygon

from ..core.tolerances import TOL
from .junctions import (
    Junction,
    _corner_angles,
    _intersection_points,
    _unit,
    classify,
    find_junctions,
    is_closed,
    t_subtype,
)

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

FEATURE_KINDS = (
    "free_end",
    "corner",
    "continuous",
    "t_crossing",
    "direct_crossing",
    "odd_t_crossing",
    "odd_direct_crossing",
    "four_direct_crossing",
    "tubular",
)
CROSSING_KINDS = frozenset(
    {"t_crossing", "direct_crossing", "odd_t_crossing", "odd_direct_crossing", "four_direct_crossing"}
)
JUNCTION_KINDS = frozenset({"corner", "continuous"})

# The study's valences (intersection list count, end-point list count) per kind, reported as-is.
STUDY_VALENCE = {
    "free_end": (0, 1),
    "corner": (2, 2),
    "continuous": (2, 2),
    "t_crossing": (2, 1),
    "direct_crossing": (1, 0),
    "odd_t_crossing": (6, 3),
    "odd_direct_crossing": (6, 2),
    "four_direct_crossing": (12, 4),
}


@dataclass(frozen=True)
class RecognitionSpec:
    """merge_tol: mm, points closer than this are one point. corner_angle_deg: a junction whose walls
    turn by at least this angle (0 = straight on) is a corner, else continuous. encumbrance: mm,
    the torch's maximum encumbrance (diameter), for the isolated-tubular test. continuous_min_deg:
    a vertex inside one polyline whose walls turn by at least this angle (and less than
    corner_angle_deg, without a run of similar turns around it) is a continuous junction.
    join_gap (mm), join_angle_deg: two open curve ends at most join_gap apart whose curves continue
    each other (end directions opposite, and the gap along them, within join_angle_deg) are joined
    before classifying (`join_collinear`): a crossing arm drawn as two collinear curves that stop
    short of the other wall meets it."""

    merge_tol: float = TOL.merge
    corner_angle_deg: float = 30.0
    encumbrance: float = 30.0
    continuous_min_deg: float = 2.0
    join_gap: float = 0.05
    join_angle_deg: float = 1.0


@dataclass(frozen=True, eq=False)
class FeatureSet:
    """Recognised features.

    features: tuple of JSON-ready dicts {"kind", "point": [x, y], "layer", "z", "entities": [curve
    indices], ...} (crossings add "branches" and "directions" (unit [dx, dy] per branch, CCW),
    junctions "angle_deg", tubulars "isolated", "length_mm"). spec: the recognition settings.
    layers: layer index → digest of the curves recognised on it (so a consumer can reuse the
    features on an identical layer of an extrusion, or recognise a different one afresh).
    """

    features: tuple[dict, ...]
    spec: RecognitionSpec = field(default_factory=RecognitionSpec)
    layers: dict[int, str] = field(default_factory=dict)

    def to_json(self) -> dict:
        return {"features": [dict(f) for f in self.features]}

    def counts(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for f in self.features:
            out[f["kind"]] = out.get(f["kind"], 0) + 1
        return out

    def of_layer(self, index: int) -> list[dict]:
        return [f for f in self.features if f.get("layer") == index]


def curves_digest(curves) -> str:
    """Content digest of a layer's curves (rounded to 1e-6 mm)."""
    h = hashlib.sha1()
    for c in curves:
        h.update(np.round(np.asarray(c, float), 6).tobytes())
        h.update(b"|")
    return h.hexdigest()


# ------------------------------------------------------------------------------------------
# Joining collinear curves
# ------------------------------------------------------------------------------------------
def _end_direction(c: np.ndarray, at_start: bool, tol: float) -> np.ndarray:
    """Unit direction pointing out of the curve beyond its start (or end)."""
    seq = c if at_start else c[::-1]
    nxt = next((q for q in seq[1:] if np.hypot(*(q - seq[0])) > tol), seq[-1])
    return _unit(seq[0] - nxt)


def join_collinear(
    curves: list[np.ndarray], gap: float, angle_deg: float, tol: float
) -> tuple[list[np.ndarray], list[tuple[float, float]]]:
    """Join open curves that continue each other across a gap of at most `gap` mm.

    Two ends of different open curves are joined when they are within `gap` of each other, the
    curves leave them in opposite directions (within `angle_deg`) and the gap runs along them
    (within `angle_deg`): the same wall drawn as two collinear pieces, e.g. an X's crossing arm that
    stops short of the other wall on both sides. Both ends move to one point: where another curve
    crosses the gap, else its midpoint. The pieces stay separate curves (the study counts drawn
    entities: that X is an odd direct crossing), now meeting. Ends already within `tol` are left as
    they are. Each end joins at most once (its nearest partner). Returns (curves, join points).
    """
    curves = [np.array(c, float) for c in curves]
    if gap <= tol:
        return curves, []
    cos_a = math.cos(math.radians(angle_deg))
    ends = [
        (ci, at_start)
        for ci, c in enumerate(curves)
        if len(c) >= 2 and not is_closed(c, tol)
        for at_start in (True, False)
    ]
    if len(ends) < 2:
        return curves, []
    from scipy.spatial import cKDTree  # lazy: keeps start-up light

    pts = np.array([curves[ci][0] if a else curves[ci][-1] for ci, a in ends])
    dirs = np.array([_end_direction(curves[ci], a, tol) for ci, a in ends])
    pairs = []
    for i, j in cKDTree(pts).query_pairs(gap):
        if ends[i][0] == ends[j][0]:
            continue
        d = pts[j] - pts[i]
        dist = float(np.hypot(*d))
        if dist <= tol or float(dirs[i] @ dirs[j]) > -cos_a:
            continue
        if float(d @ dirs[i]) < dist * cos_a or float(-d @ dirs[j]) < dist * cos_a:
            continue
        pairs.append((dist, i, j))
    used: set[int] = set()
    lines = [LineString(c) for c in curves]
    joins: list[tuple[float, float]] = []
    for dist, i, j in sorted(pairs):
        if i in used or j in used:
            continue
        used.update((i, j))
        seg = LineString([pts[i], pts[j]])
        mid = (pts[i] + pts[j]) / 2.0
        target = mid
        hits = [
            q
            for k, line in enumerate(lines)
            if k not in (ends[i][0], ends[j][0])
            for q in _intersection_points(seg.intersection(line))
        ]
        if hits:
            target = np.asarray(min(hits, key=lambda q: float(np.hypot(*(np.asarray(q) - mid)))), float)
        for k in (i, j):
            ci, at_start = ends[k]
            curves[ci][0 if at_start else -1] = target
        joins.append((float(target[0]), float(target[1])))
    return curves, joins


# ------------------------------------------------------------------------------------------
# Loops (tubulars)
# ------------------------------------------------------------------------------------------
def find_loops(
    curves: list[np.ndarray], junctions: list[Junction], kinds: list[str | None], tol: float
) -> list[list[int]]:
    """Curve index groups forming closed loops that touch nothing else: a closed curve with no
    junction on it, or open curves chained end to end through corner/continuous junctions only."""
    touched: dict[int, list[int]] = {}
    for k, j in enumerate(junctions):
        for inc in j.incidences:
            touched.setdefault(inc.curve, []).append(k)
    parent = list(range(len(curves)))

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for j, kind in zip(junctions, kinds):
        if kind in JUNCTION_KINDS and len(j.incidences) == 2:
            a, b = (inc.curve for inc in j.incidences)
            parent[find(a)] = find(b)
    groups: dict[int, list[int]] = {}
    for c in range(len(curves)):
        groups.setdefault(find(c), []).append(c)
    loops: list[list[int]] = []
    for members in groups.values():
        if len(members) == 1 and is_closed(curves[members[0]], tol):
            if not touched.get(members[0]):
                loops.append(members)
            continue
        js = {k for c in members for k in touched.get(c, [])}
        if (
            js
            and all(kinds[k] in JUNCTION_KINDS for k in js)
            and len(js) == len(members)
            and all(not is_closed(curves[c], tol) for c in members)
        ):
            loops.append(sorted(members))
    return loops


def chain_loop(curves: list[np.ndarray], members: list[int], tol: float) -> np.ndarray:
    """(k, 2) closed polyline (first point repeated) through the loop's curves, end to end."""
    if len(members) == 1:
        return np.asarray(curves[members[0]], float)
    left = [np.asarray(curves[c], float) for c in members[1:]]
    out = [np.asarray(curves[members[0]], float)]
    while left:
        tail = out[-1][-1]
        for k, c in enumerate(left):
            if np.hypot(*(c[0] - tail)) <= tol:
                out.append(c[1:])
                break
            if np.hypot(*(c[-1] - tail)) <= tol:
                out.append(c[::-1][1:])
                break
        else:
            raise ValueError("loop curves do not chain end to end")
        left.pop(k)
    ring = np.vstack(out)
    ring[-1] = ring[0]
    return ring


def is_isolated(ring: np.ndarray, others: list[LineString], encumbrance: float) -> bool:
    """True when no other curve touches the band between the ring's inward and outward offsets by
    encumbrance/2 (mm): the torch, centred on the ring, cannot collide with another wall."""
    poly = Polygon(ring)
    if not poly.is_valid:
        poly = poly.buffer(0)
    half = encumbrance / 2.0
    band = poly.buffer(half).difference(poly.buffer(-half))
    return not any(band.intersects(o) for o in others)


# ------------------------------------------------------------------------------------------
# Entry point
# ------------------------------------------------------------------------------------------
def _vertex_junctions(
    c: np.ndarray, tol: float, corner_angle_deg: float, continuous_min_deg: float, skip: cKDTree | None
) -> list[tuple[np.ndarray, float, str]]:
    """Junctions at interior vertices of one polyline: (point, angle between the walls, kind).

    A vertex turning by ≥ corner_angle_deg is a corner. One turning by less, but by at least
    continuous_min_deg, is a continuous junction of two walls when its turn is isolated: no
    neighbouring vertex turns the same way by a similar amount (within a factor 2.5) — a run of
    similar turns is one curved wall (a discretised arc, whose tangent ends turn by half a chord's
    turn), not a chain of junctions."""
    closed = is_closed(c, tol)
    pts = c[:-1] if closed else c
    n = len(pts)
    if n < 3:
        return []
    turn = np.zeros(n)  # signed turn (deg, + = left) per vertex
    between = np.full(n, 180.0)
    for k in range(n) if closed else range(1, n - 1):
        p, a, b = pts[k], pts[(k - 1) % n], pts[(k + 1) % n]
        u, v = _unit(p - a), _unit(b - p)
        if not (np.any(u) and np.any(v)):
            continue
        turn[k] = math.degrees(math.atan2(u[0] * v[1] - u[1] * v[0], float(u @ v)))
        between[k] = 180.0 - abs(turn[k])

    def similar(k: int, j: int) -> bool:
        if not closed and (j < 0 or j >= n):
            return False
        t, o = turn[k], turn[j % n]
        return t * o > 0 and 0.4 <= o / t <= 2.5

    skipped = _within(pts, skip, tol)
    out = []
    for k in range(n) if closed else range(1, n - 1):
        t = abs(turn[k])
        p = pts[k]
        if t < continuous_min_deg or skipped[k]:
            continue
        if t >= corner_angle_deg:
            out.append((p, float(between[k]), "corner"))
        elif not (similar(k, k - 1) or similar(k, k + 1)):
            out.append((p, float(between[k]), "continuous"))
    return out


def _tree(points) -> cKDTree | None:
    from scipy.spatial import cKDTree  # here: scipy.spatial costs ~0.3 s to import, most runs need none

    pts = np.asarray(points, float).reshape(-1, 2)
    return cKDTree(pts) if len(pts) else None


def _within(points: np.ndarray, others: cKDTree | None, tol: float) -> np.ndarray:
    """Per point of `points` (n, 2): is one of the `others` (a k-d tree of them, built once) within
    tol (mm)? Not a scan of them per point: a floor plan's thousands of vertices and junctions took
    minutes so."""
    pts = np.asarray(points, float).reshape(-1, 2)
    if others is None or not len(pts):
        return np.zeros(len(pts), bool)
    d, _ = others.query(pts, k=1)
    return d <= tol


def _joint_vertices(
    curves: list[np.ndarray], joints, tol: float, skip: cKDTree | None
) -> list[tuple[np.ndarray, float, int]]:
    """Joints (points where the sketch joined two walls end to end into one polyline) that are a
    vertex inside a curve and not already reported: (point, angle between the walls (deg), curve).
    A joint belongs to the first curve (in order) whose nearest vertex lies within tol of it, if
    that vertex is not an open curve's end; the vertices near a joint come from one k-d tree of
    every curve's vertices."""
    joints = np.asarray(joints, float).reshape(-1, 2)
    if not len(joints) or not curves:
        return []
    verts, owner, index = [], [], []
    for ci, c in enumerate(curves):
        pts = c[:-1] if is_closed(c, tol) else c
        verts.append(pts)
        owner.append(np.full(len(pts), ci))
        index.append(np.arange(len(pts)))
    all_pts, all_owner, all_index = np.vstack(verts), np.concatenate(owner), np.concatenate(index)
    tree = _tree(all_pts)
    assert tree is not None
    reported = _within(joints, skip, tol)
    out = []
    for q, done in zip(joints, reported):
        if done:
            continue
        near = np.asarray(tree.query_ball_point(q, tol * (1 + 1e-9) + 1e-12), int)
        if not len(near):
            continue
        d = np.hypot(*(all_pts[near] - q).T)
        near, d = near[d <= tol], d[d <= tol]
        # per curve in order: its nearest vertex (the first of equals, as argmin over it would)
        for ci in np.unique(all_owner[near]):
            mine = all_owner[near] == ci
            k = int(all_index[near[mine]][np.lexsort((all_index[near[mine]], d[mine]))[0]])
            pts = verts[ci]
            closed = len(pts) != len(curves[ci])
            if not closed and k in (0, len(pts) - 1):
                continue
            n = len(pts)
            u, v = _unit(pts[(k - 1) % n] - pts[k]), _unit(pts[(k + 1) % n] - pts[k])
            if np.any(u) and np.any(v):
                out.append((pts[k], math.degrees(math.acos(float(np.clip(u @ v, -1.0, 1.0)))), int(ci)))
            break
    return out


def recognise(
    curves, spec: RecognitionSpec = RecognitionSpec(), *, layer: int = 0, z: float = 0.0, joints=()
) -> list[dict]:
    """Features of one layer's curves ((k, 2) arrays or LineStrings, mm) as JSON-ready dicts.

    joints: (x, y) points where the sketch joined two walls end to end into one polyline; each
    is listed as a `corner` or `continuous` junction with its angle unless already found."""
    curves = [np.asarray(c.coords if hasattr(c, "coords") else c, float)[:, :2] for c in curves]
    curves = [c for c in curves if len(c) >= 2]
    tol = spec.merge_tol
    curves, _ = join_collinear(curves, spec.join_gap, spec.join_angle_deg, tol)
    junctions = find_junctions(curves, tol, joints, spec.join_gap)
    kinds = [classify(j, spec.corner_angle_deg) for j in junctions]
    feats: list[dict] = []

    def base(kind: str, point, entities) -> dict:
        return {
            "kind": kind,
            "point": [round(float(point[0]), 6), round(float(point[1]), 6)],
            "layer": layer,
            "z": round(float(z), 6),
            "entities": sorted({int(e) for e in entities}),
        }

    for j, kind in zip(junctions, kinds):
        if kind is None:
            continue
        f = base(kind, j.point, [i.curve for i in j.incidences])
        br = j.branches
        f["branches"] = len(br)
        f["study_valence"] = list(STUDY_VALENCE[kind])
        if kind in JUNCTION_KINDS:
            f["angle_deg"] = round(math.degrees(math.acos(float(np.clip(br[0] @ br[1], -1, 1)))), 3)
        if kind in CROSSING_KINDS:
            f["directions"] = [[round(float(d[0]), 9), round(float(d[1]), 9)] for d in br]
            f["corner_angles_deg"] = [round(a, 3) for a in _corner_angles(br)]
            if len(br) == 3:
                f["subtype"] = t_subtype(br, spec.corner_angle_deg)
        feats.append(f)
    jpts = [np.array(j.point) for j in junctions]
    jtree = _tree(jpts)
    for ci, c in enumerate(curves):
        for p, between, kind in _vertex_junctions(c, tol, spec.corner_angle_deg, spec.continuous_min_deg, jtree):
            f = base(kind, p, [ci])
            f.update(branches=2, angle_deg=round(between, 3), study_valence=list(STUDY_VALENCE[kind]))
            feats.append(f)
    # junctions the sketch joined away that the vertex test above missed (e.g. a regular polygon
    # of walls, whose equal turns look like a discretised arc): listed by where they were joined
    reported = jpts + [np.array(f["point"]) for f in feats if f["kind"] in JUNCTION_KINDS]
    for p, between, ci in _joint_vertices(curves, joints, tol, _tree(reported)):
        kind = "corner" if 180.0 - between >= spec.corner_angle_deg else "continuous"
        f = base(kind, p, [ci])
        f.update(branches=2, angle_deg=round(between, 3), study_valence=list(STUDY_VALENCE[kind]))
        feats.append(f)
    lines = [LineString(c) for c in curves]
    for members in find_loops(curves, junctions, kinds, tol):
        ring = chain_loop(curves, members, tol)
        others = [lines[k] for k in range(len(curves)) if k not in members]
        poly = Polygon(ring)
        cen = poly.centroid if poly.is_valid and poly.area > 0 else LineString(ring).centroid
        f = base("tubular", (cen.x, cen.y), members)
        f["isolated"] = bool(is_isolated(ring, others, spec.encumbrance))
        f["length_mm"] = round(float(LineString(ring).length), 6)
        f["start"] = [round(float(ring[0][0]), 6), round(float(ring[0][1]), 6)]
        feats.append(f)
    return feats


def recognise_layers(layers, spec: RecognitionSpec = RecognitionSpec(), *, every_layer: bool = False) -> FeatureSet:
    """FeatureSet of a layer stack: the first layer with curves (extrusions repeat it), or every
    layer whose curves differ from an already recognised one when `every_layer`."""
    feats: list[dict] = []
    digests: dict[int, str] = {}
    seen: set[str] = set()
    for layer in layers:
        if layer is None or not layer.curves:
            continue
        dg = curves_digest([c.coords for c in layer.curves])
        if dg in seen:
            continue
        feats.extend(recognise(layer.curves, spec, layer=layer.index, z=layer.z, joints=layer.joints))
        digests[layer.index] = dg
        seen.add(dg)
        if not every_layer:
            break
    return FeatureSet(tuple(feats), spec, digests)


def features_for_layer(fs: FeatureSet, layer) -> list[dict]:
    """The features that apply to `layer`: its own, those of an identical recognised layer, or a
    fresh recognition with the set's settings when its curves differ from all recognised ones."""
    own = fs.of_layer(layer.index)
    if own:
        return own
    dg = curves_digest([c.coords for c in layer.curves])
    for idx, d in fs.layers.items():
        if d == dg:
            return [dict(f, layer=layer.index, z=round(float(layer.z), 6)) for f in fs.of_layer(idx)]
    return recognise(layer.curves, fs.spec, layer=layer.index, z=layer.z, joints=layer.joints)
