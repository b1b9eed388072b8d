/**
 * 2D geometry helpers for the mask canvas. Plain functions on plain arrays, all in layer
 * millimetres (x right, y up, as in the recipe and the contract JSON).
 *
 * A point is `[x, y]`; a ring is `Pt[]` (closing vertex optional); a polygon is an exterior ring
 * plus hole rings, exactly the contract's `{"exterior": [...], "holes": [[...]]}`.
 */

export type Pt = [number, number];
export interface PolygonJson {
  exterior: number[][];
  holes: number[][][];
}

export const pt = (p: readonly number[]): Pt => [p[0], p[1]];

export function dist(a: readonly number[], b: readonly number[]): number {
  return Math.hypot(a[0] - b[0], a[1] - b[1]);
}

/** Ring without a repeated closing vertex. */
export function openRing(ring: readonly number[][]): Pt[] {
  const r = ring.map(pt);
  if (r.length > 1 && dist(r[0], r[r.length - 1]) < 1e-12) r.pop();
  return r;
}

/** Signed area (mm², counter-clockwise positive) of a ring (shoelace formula). */
export function ringArea(ring: readonly number[][]): number {
  const r = openRing(ring);
  let a = 0;
  for (let i = 0; i < r.length; i++) {
    const [x1, y1] = r[i];
    const [x2, y2] = r[(i + 1) % r.length];
    a += x1 * y2 - x2 * y1;
  }
  return a / 2;
}

/** Area (mm²) of a polygon with holes. */
export function polygonArea(p: PolygonJson): number {
  return Math.abs(ringArea(p.exterior)) - p.holes.reduce((s, h) => s + Math.abs(ringArea(h)), 0);
}

/** Even-odd point-in-ring test (ray casting). Points on the boundary may go either way. */
export function pointInRing(p: readonly number[], ring: readonly number[][]): boolean {
  const r = openRing(ring);
  let inside = false;
  for (let i = 0, j = r.length - 1; i < r.length; j = i++) {
    const [xi, yi] = r[i];
    const [xj, yj] = r[j];
    if (yi > p[1] !== yj > p[1] && p[0] < ((xj - xi) * (p[1] - yi)) / (yj - yi) + xi) inside = !inside;
  }
  return inside;
}

export function pointInPolygon(p: readonly number[], poly: PolygonJson): boolean {
  return pointInRing(p, poly.exterior) && !poly.holes.some((h) => pointInRing(p, h));
}

/** Intersection point of segments ab and cd, or null (parallel or disjoint). */
export function segmentIntersection(a: Pt, b: Pt, c: Pt, d: Pt): Pt | null {
  const rx = b[0] - a[0], ry = b[1] - a[1];
  const sx = d[0] - c[0], sy = d[1] - c[1];
  const den = rx * sy - ry * sx;
  if (Math.abs(den) < 1e-15) return null;
  const qx = c[0] - a[0], qy = c[1] - a[1];
  const t = (qx * sy - qy * sx) / den;
  const u = (qx * ry - qy * rx) / den;
  if (t < 0 || t > 1 || u < 0 || u > 1) return null;
  return [a[0] + t * rx, a[1] + t * ry];
}

/** Segments of all rings of a polygon (exterior and holes), each ring closed. */
export function polygonSegments(poly: PolygonJson): [Pt, Pt][] {
  const segs: [Pt, Pt][] = [];
  for (const ring of [poly.exterior, ...poly.holes]) {
    const r = openRing(ring);
    for (let i = 0; i < r.length; i++) segs.push([r[i], r[(i + 1) % r.length]]);
  }
  return segs;
}

/**
 * Points where an open polyline crosses a polygon's boundary (exterior and holes), in order along
 * the polyline. A guide is valid when this returns exactly two points (contract: guide params).
 * Crossings closer than `eps` mm (a polyline vertex lying on the boundary) count once.
 */
export function boundaryCrossings(line: readonly number[][], poly: PolygonJson, eps = 1e-9): Pt[] {
  const segs = polygonSegments(poly);
  const out: Pt[] = [];
  for (let i = 0; i + 1 < line.length; i++) {
    const a = pt(line[i]), b = pt(line[i + 1]);
    const hits: Pt[] = [];
    for (const [c, d] of segs) {
      const x = segmentIntersection(a, b, c, d);
      if (x) hits.push(x);
    }
    hits.sort((p, q) => dist(a, p) - dist(a, q));
    for (const h of hits) if (!out.length || dist(out[out.length - 1], h) > eps) out.push(h);
  }
  return out;
}

/** Cumulative arc length (mm) at each vertex of a polyline: shape (n,), first 0. */
export function cumulativeLengths(line: readonly number[][]): number[] {
  const s = [0];
  for (let i = 1; i < line.length; i++) s.push(s[i - 1] + dist(line[i - 1], line[i]));
  return s;
}

/** Point at arc length `s` mm along a polyline (clamped to its ends). */
export function pointAtLength(line: readonly number[][], s: number): Pt {
  const cum = cumulativeLengths(line);
  if (s <= 0 || line.length < 2) return pt(line[0]);
  for (let i = 1; i < line.length; i++) {
    if (cum[i] >= s) {
      const seg = cum[i] - cum[i - 1];
      const t = seg > 0 ? (s - cum[i - 1]) / seg : 0;
      return [line[i - 1][0] + t * (line[i][0] - line[i - 1][0]), line[i - 1][1] + t * (line[i][1] - line[i - 1][1])];
    }
  }
  return pt(line[line.length - 1]);
}

/** Closest point on a polyline to `p`: the point, its distance (mm), arc length s (mm), segment index. */
export function closestOnPolyline(p: readonly number[], line: readonly number[][]) {
  let best = { point: pt(line[0]), distance: dist(p, line[0]), s: 0, segment: 0 };
  let acc = 0;
  for (let i = 0; i + 1 < line.length; i++) {
    const a = line[i], b = line[i + 1];
    const dx = b[0] - a[0], dy = b[1] - a[1];
    const len2 = dx * dx + dy * dy;
    const t = len2 > 0 ? Math.max(0, Math.min(1, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2)) : 0;
    const q: Pt = [a[0] + t * dx, a[1] + t * dy];
    const d = dist(p, q);
    if (d < best.distance) best = { point: q, distance: d, s: acc + t * Math.sqrt(len2), segment: i };
    acc += Math.sqrt(len2);
  }
  return best;
}

export interface SnapOptions {
  /** Candidate vertices (mm), e.g. every vertex of the active layer's polygons. */
  vertices: readonly number[][];
  /** Snap radius for vertices, mm. */
  radius: number;
  /** Grid pitch, mm (0 = no grid snapping). */
  grid: number;
}

/** Snap a point to the nearest vertex within `radius`, else to the grid, else leave it. */
export function snapPoint(p: readonly number[], o: SnapOptions): { point: Pt; kind: "vertex" | "grid" | "none" } {
  let best: Pt | null = null;
  let bestD = o.radius;
  for (const v of o.vertices) {
    const d = dist(p, v);
    if (d <= bestD) {
      bestD = d;
      best = pt(v);
    }
  }
  if (best) return { point: best, kind: "vertex" };
  if (o.grid > 0) return { point: [Math.round(p[0] / o.grid) * o.grid, Math.round(p[1] / o.grid) * o.grid], kind: "grid" };
  return { point: pt(p), kind: "none" };
}

/** All vertices of a set of polygons (exteriors and holes), for snapping. */
export function polygonVertices(polys: readonly PolygonJson[]): Pt[] {
  return polys.flatMap((p) => [p.exterior, ...p.holes].flatMap((r) => openRing(r)));
}

export function translate(line: readonly number[][], dx: number, dy: number): Pt[] {
  return line.map((p) => [p[0] + dx, p[1] + dy] as Pt);
}

export interface BBox {
  minX: number;
  minY: number;
  maxX: number;
  maxY: number;
}

export function bbox(points: readonly number[][], pad = 0): BBox | null {
  if (!points.length) return null;
  let minX = Infinity, minY = Infinity, maxX = -Infinity, maxY = -Infinity;
  for (const p of points) {
    minX = Math.min(minX, p[0]); maxX = Math.max(maxX, p[0]);
    minY = Math.min(minY, p[1]); maxY = Math.max(maxY, p[1]);
  }
  return { minX: minX - pad, minY: minY - pad, maxX: maxX + pad, maxY: maxY + pad };
}

/** SVG path data of a polygon with holes (use fill-rule="evenodd"). Y is negated: SVG y points down. */
export function polygonPathD(poly: PolygonJson): string {
  return [poly.exterior, ...poly.holes].map((r) => ringPathD(r, true)).join(" ");
}

export function ringPathD(ring: readonly number[][], closed: boolean): string {
  const r = closed ? openRing(ring) : ring.map(pt);
  if (!r.length) return "";
  const body = r.map((p, i) => `${i ? "L" : "M"}${fmt(p[0])} ${fmt(-p[1])}`).join(" ");
  return closed ? body + " Z" : body;
}

const fmt = (v: number) => (Math.round(v * 1000) / 1000).toString();

/** Self-intersection check for a closed curve: true when two non-adjacent edges cross. */
export function ringSelfIntersects(ring: readonly number[][]): boolean {
  const r = openRing(ring);
  const n = r.length;
  for (let i = 0; i < n; i++) {
    for (let j = i + 1; j < n; j++) {
      if (j === i + 1 || (i === 0 && j === n - 1)) continue;
      if (segmentIntersection(r[i], r[(i + 1) % n], r[j], r[(j + 1) % n])) return true;
    }
  }
  return false;
}

/**
 * World points (n, 3) mm → layer-local (n, 3) for a layer with a frame (4×4, layer-local
 * (x, y, 0) → world, rigid: fan slicing). local = Rᵀ (p − t); the third coordinate is the height
 * above the layer plane. Without a frame, world x, y are layer x, y already.
 */
export function worldToLayer(points: readonly number[][], frame?: readonly number[][] | null): number[][] {
  if (!frame) return points as number[][];
  const R = [0, 1, 2].map((i) => [frame[i][0], frame[i][1], frame[i][2]]);
  const t = [frame[0][3], frame[1][3], frame[2][3]];
  return points.map((p) => {
    const d = [p[0] - t[0], p[1] - t[1], (p[2] ?? 0) - t[2]];
    return [0, 1, 2].map((j) => R[0][j] * d[0] + R[1][j] * d[1] + R[2][j] * d[2]);
  });
}
