"""Layer scans in: point clouds and per-path heights, checked, registered and measured against the
planned crests of the layer they claim to be.

Readers (all return a `Scan`):

- PLY (binary or ASCII, vertices only; read by trimesh), XYZ/CSV/TXT point lists (`x y z` or
  `x,y,z` per line, an optional header line, `#` comments) — the export of most line scanners
  after the profiles are placed with the robot's encoder positions;
- per-path heights, CSV with a header `layer,s,height[,width]`: s = arc length (mm) along the
  layer's arc-ON path in deposition order, height = measured crest height along the build
  direction (mm, the same frame as the plan), width = measured bead width (mm).

`measure(track, scan)` gives the measured crest height at every planned sample: the 90th
percentile, along the build direction, of the scan points within `radius` mm of the sample's
axis (robust to a few spikes, and at the crest: a bead's cap is flat within a sixth of its width).
Samples with fewer than `min_points` points are unmeasured (NaN) and counted.

Checks (a `ScanError` says which and what to do): an empty scan; NaN/inf coordinates; a scan that
covers too few samples of the layer (`min_coverage`, default 50 %); a scan whose median deviation
from what was expected (the plan, or the predicted top) is more than `max_layer_offset` layers
(default 0.75): the scan of another layer or a
frame that is not the part's. Registration (`register`) fits a rigid correction of the scan's
frame to the planned crests by point-to-plane least squares; only the directions the planned top
can observe are corrected (a flat top fixes offset along the build direction and the tilts; x, y
and the turn about the vertical are held by damping). Note: a best fit also removes a *uniform*
height error of the part — use it when the scanner frame is not calibrated to the part, and
compare the residual it reports.

Units: mm.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..core.errors import WaamflowError
from .track import Track


class ScanError(WaamflowError):
    """A scan that cannot be used, with the layer and the reason."""


@dataclass(frozen=True, eq=False)
class Scan:
    """A point cloud (`points`, (m, 3) mm) or per-path heights (`s`, `height`, `width`: (m,) mm)
    for one layer."""

    layer: int
    points: np.ndarray | None = None
    s: np.ndarray | None = None
    height: np.ndarray | None = None
    width: np.ndarray | None = None
    source: str = "scan"

    @property
    def kind(self) -> str:
        return "cloud" if self.points is not None else "heights"


def _check_finite(a: np.ndarray, layer: int, source: str) -> None:
    bad = ~np.isfinite(a).all(axis=-1) if a.ndim > 1 else ~np.isfinite(a)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ScanError(
            f"{source}: layer {layer}: {int(bad.sum())} points are NaN or infinite (first at row {i + 1}); "
            "remove them from the scan export"
        )


def read_points(data: bytes, layer: int, source: str = "scan") -> Scan:
    """A point cloud from PLY bytes or an XYZ/CSV text (see module doc)."""
    if data[:3] == b"ply":
        import trimesh

        cloud = trimesh.load(io.BytesIO(data), file_type="ply", process=False)
        pts = np.asarray(getattr(cloud, "vertices", np.zeros((0, 3))), float)
    else:
        rows = []
        for k, line in enumerate(data.decode("utf-8", "replace").splitlines()):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            parts = line.replace(",", " ").replace(";", " ").split()
            try:
                rows.append([float(v) for v in parts[:3]])
            except ValueError:
                if rows:  # text after data: not a header
                    raise ScanError(f"{source}: layer {layer}: line {k + 1} is not 'x y z': {line[:60]!r}") from None
                continue
            if len(rows[-1]) < 3:
                raise ScanError(f"{source}: layer {layer}: line {k + 1} has {len(rows[-1])} values, need x y z")
        pts = np.asarray(rows, float).reshape(-1, 3)
    if len(pts) == 0:
        raise ScanError(f"{source}: layer {layer}: the scan has no points")
    _check_finite(pts, layer, source)
    return Scan(layer, points=pts, source=source)


def read_heights(text: str, layer: int | None = None, source: str = "scan") -> dict[int, Scan]:
    """Per-path heights CSV `layer,s,height[,width]` → {layer: Scan}; with `layer` only that one
    (an error if the file has none of it)."""
    rd = csv.DictReader(io.StringIO(text))
    cols = {c.strip().lower(): c for c in (rd.fieldnames or [])}
    for need in ("layer", "s", "height"):
        if need not in cols:
            raise ScanError(
                f"{source}: per-path heights need the columns layer, s, height[, width]; "
                f"missing {need!r} (header: {', '.join(rd.fieldnames or []) or 'none'})"
            )
    by: dict[int, list[tuple[float, float, float]]] = {}
    for k, row in enumerate(rd):
        try:
            lay = int(float(row[cols["layer"]]))
            s, h = float(row[cols["s"]]), float(row[cols["height"]])
            w = float(row[cols["width"]]) if "width" in cols and row[cols["width"]] not in ("", None) else math.nan
        except (TypeError, ValueError):
            raise ScanError(f"{source}: row {k + 2} is not numbers: {dict(row)}") from None
        if not (math.isfinite(s) and math.isfinite(h)):
            raise ScanError(f"{source}: layer {lay}: row {k + 2} has a NaN or infinite s or height")
        by.setdefault(lay, []).append((s, h, w))
    if layer is not None:
        if layer not in by:
            raise ScanError(
                f"{source}: no rows for layer {layer} (the file has layers {', '.join(map(str, sorted(by))) or 'none'})"
            )
        by = {layer: by[layer]}
    out = {}
    for lay, rows in by.items():
        a = np.asarray(sorted(rows), float)
        out[lay] = Scan(lay, s=a[:, 0], height=a[:, 1], width=a[:, 2], source=source)
    return out


@dataclass(frozen=True)
class Registration:
    """The rigid correction applied to the scan (rotation vector rad, translation mm) and the RMS
    point-to-plane residual before and after (mm)."""

    rotation: tuple[float, float, float]
    translation: tuple[float, float, float]
    rms_before: float
    rms_after: float
    points_used: int

    def to_dict(self) -> dict:
        return {
            "rotation_deg": [round(math.degrees(v), 4) for v in self.rotation],
            "translation_mm": [round(v, 4) for v in self.translation],
            "rms_before_mm": round(self.rms_before, 4),
            "rms_after_mm": round(self.rms_after, 4),
            "points_used": self.points_used,
        }


def _rotation(w: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(w))
    if th < 1e-15:
        return np.eye(3)
    k = w / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(th) * K + (1 - math.cos(th)) * K @ K


def _near_axis(track: Track, ref: np.ndarray, P: np.ndarray, radius: float, reach: float):
    """Each scan point paired with its four nearest samples (by distance to ref[i], at most
    `reach`), a pair kept when it lies within `radius` of that sample's axis (the line through ref[i] along its
    build direction), with its offset along that direction from the planned crest:
    (i, j, along), sorted by i then along."""
    k = min(4, len(ref))
    d, i = cKDTree(ref).query(P, k=k, distance_upper_bound=reach)
    d, i = d.reshape(len(P), k), i.reshape(len(P), k)
    hit = np.isfinite(d)
    j = np.repeat(np.arange(len(P)), k).reshape(len(P), k)[hit]
    i = i[hit].astype(np.int64)
    n = track.normal[i]
    off = P[j] - ref[i]
    dn = np.einsum("ij,ij->i", off, n)
    lateral = np.linalg.norm(off - dn[:, None] * n, axis=1)
    ok = lateral <= radius
    i, j = i[ok], j[ok]
    along = np.einsum("ij,ij->i", P[j] - track.points[i], track.normal[i])
    order = np.lexsort((along, i))
    return i[order], j[order], along[order]


def _group_percentile(i: np.ndarray, values: np.ndarray, n: int, q: float, min_count: int):
    """Per group (i sorted, values sorted within a group): the q-quantile (linear, as
    numpy.percentile) and the index into the pairs of the element at or below it; NaN / -1 for
    groups with fewer than `min_count` values."""
    counts = np.bincount(i, minlength=n)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    ok = counts >= max(min_count, 1)
    pos = (counts - 1) * q
    lo = np.floor(pos).astype(np.int64)
    frac = pos - lo
    hi = np.minimum(lo + 1, counts - 1)
    out = np.full(n, np.nan)
    pick = np.full(n, -1, dtype=np.int64)
    if ok.any():
        a = start[ok] + lo[ok]
        b = start[ok] + hi[ok]
        out[ok] = values[a] * (1 - frac[ok]) + values[b] * frac[ok]
        pick[ok] = start[ok] + np.round(pos[ok]).astype(np.int64)
    return out, pick


def _crest_points(track: Track, P: np.ndarray, radius: float, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Per planned sample, the scan point at the crest over it (90th percentile along the build
    direction of the points within `radius` of its axis): (sample indices, point indices)."""
    i, j, along = _near_axis(track, track.points, P, radius, reach)
    _, pick = _group_percentile(i, along, track.n, 0.9, 3)
    si = np.flatnonzero(pick >= 0)
    return si, j[pick[si]]


def register(
    track: Track,
    scan: Scan,
    radius: float = 0.75,
    iterations: int = 20,
    reach: float | None = None,
    damping: float = 1e-3,
) -> tuple[Scan, Registration]:
    """Best-fit the scan's frame to the planned crests (see module doc): the scan's crest point over
    each planned sample (`radius` mm of its axis, searched within `reach` mm) pairs with that
    sample's crest plane; point-to-plane Gauss-Newton, damped so unobservable directions stay."""
    if scan.points is None:
        raise ScanError(f"{scan.source}: layer {scan.layer}: per-path heights have no frame to register")
    reach = reach if reach is not None else radius + 2.0 * max(track.thickness, 1.0) + 1.0
    P = scan.points.copy()
    R_tot, t_tot = np.eye(3), np.zeros(3)
    c0 = track.points.mean(axis=0)
    rms0 = None
    used = 0
    for _ in range(iterations):
        si, pi = _crest_points(track, P, radius, reach)
        used = len(si)
        if used < 6:
            raise ScanError(
                f"{scan.source}: layer {scan.layer}: only {used} planned samples have scan points over them: "
                "the scan is not of this layer or not in the part frame"
            )
        p, qq, nn = P[pi] - c0, track.points[si] - c0, track.normal[si]
        r = np.einsum("ij,ij->i", p - qq, nn)
        if rms0 is None:
            rms0 = float(np.sqrt(np.mean(r * r)))
        J = np.hstack([np.cross(p, nn), nn])  # d r / d(ω, t)
        H = J.T @ J
        H += damping * np.trace(H) / 6 * np.eye(6)
        x = -np.linalg.solve(H, J.T @ r)
        R = _rotation(x[:3])
        P = (P - c0) @ R.T + c0 + x[3:]
        R_tot = R @ R_tot
        t_tot = R @ (t_tot - c0) + c0 + x[3:]
        if np.linalg.norm(x) < 1e-9:
            break
    si, pi = _crest_points(track, P, radius, reach)
    r = np.einsum("ij,ij->i", P[pi] - track.points[si], track.normal[si])
    rms1 = float(np.sqrt(np.mean(r * r))) if len(r) else math.nan
    ang = math.acos(max(-1.0, min(1.0, (np.trace(R_tot) - 1) / 2)))
    if ang < 1e-12:
        rv = np.zeros(3)
    else:
        rv = (
            ang
            / (2 * math.sin(ang))
            * np.array([R_tot[2, 1] - R_tot[1, 2], R_tot[0, 2] - R_tot[2, 0], R_tot[1, 0] - R_tot[0, 1]])
        )
    reg = Registration(
        (float(rv[0]), float(rv[1]), float(rv[2])),
        (float(t_tot[0]), float(t_tot[1]), float(t_tot[2])),
        float(rms0 or 0.0),
        rms1,
        used,
    )
    return Scan(scan.layer, points=P, source=scan.source), reg


@dataclass(frozen=True, eq=False)
class Measured:
    """Measured crest heights at a track's samples (NaN = not seen) and widths (NaN = unknown)."""

    height: np.ndarray
    width: np.ndarray

    @property
    def coverage(self) -> float:
        return float(np.isfinite(self.height).mean()) if len(self.height) else 0.0


def measure(
    track: Track,
    scan: Scan,
    radius: float = 1.0,
    min_points: int = 3,
    min_coverage: float = 0.5,
    max_layer_offset: float = 0.75,
    expected: np.ndarray | None = None,
) -> Measured:
    """Measured crest height (and width where the scan gives it) at every sample of `track`;
    refuses a scan of another layer or frame (see module doc). `expected`: the crest heights the
    scan should show (default: the plan; a build that has drifted passes what it predicts)."""
    if scan.layer != track.layer:
        raise ScanError(f"{scan.source}: the scan is of layer {scan.layer}, expected layer {track.layer}")
    n = track.n
    if n == 0:
        raise ScanError(f"{scan.source}: layer {track.layer} has no arc-ON path to compare with")
    if scan.points is None:  # heights along the path
        if scan.s is None or scan.height is None:
            raise ScanError(f"{scan.source}: layer {scan.layer}: the scan has neither points nor heights (s, height)")
        ss = scan.s
        s = np.cumsum(track.length) - track.length / 2
        if ss[0] > s[-1] or ss[-1] < s[0]:
            raise ScanError(
                f"{scan.source}: layer {track.layer}: the heights run over s = {ss[0]:g}..{ss[-1]:g} mm, "
                f"the layer's path over 0..{s[-1] + track.length[-1] / 2:g} mm"
            )
        inside = (s >= ss[0]) & (s <= ss[-1])
        h = np.where(inside, np.interp(s, ss, scan.height), np.nan)
        w = (
            np.where(inside, np.interp(s, ss, np.nan_to_num(scan.width, nan=np.nan)), np.nan)
            if scan.width is not None and np.isfinite(scan.width).any()
            else np.full(n, np.nan)
        )
    else:
        P = scan.points
        # the points near each sample's axis, searched around where the crest is expected
        ref0 = (
            track.points
            if expected is None
            else track.points + (np.asarray(expected, float) - track.planned_height())[:, None] * track.normal
        )
        reach = (
            radius + max(max_layer_offset, 0.75) * max(track.thickness, 1.0) + 1.0
            if np.isfinite(max_layer_offset)
            else radius + 2.0 * max(track.thickness, 1.0) + 1.0
        )
        i, _, along = _near_axis(track, ref0, P, radius, reach)
        q, _ = _group_percentile(i, along, n, 0.9, min_points)
        h = track.planned_height() + q
        w = np.full(n, np.nan)
    m = Measured(h, w)
    if m.coverage < min_coverage:
        raise ScanError(
            f"{scan.source}: layer {track.layer}: the scan covers {m.coverage:.0%} of the layer's path "
            f"(need {min_coverage:.0%}): is it of layer {track.layer}, in the part frame?"
        )
    ref = track.planned_height() if expected is None else np.asarray(expected, float)
    med = float(np.nanmedian(h - ref))
    if abs(med) > max_layer_offset * track.thickness:
        raise ScanError(
            f"{scan.source}: layer {track.layer}: the scan lies {med:+.2f} mm from the expected top "
            f"({med / track.thickness:+.1f} layers): the scan of another layer or another frame "
            "(register it, or check the layer number)"
        )
    return m
