/**
 * The 2D canvas's arithmetic, without React or the DOM: screen ↔ layer transforms of the SVG view
 * (fit, wheel zoom about the cursor, pan, pixel size), hit-testing of what a click lands on (the
 * data-* attributes the drawing carries; the nearest section path), and the edits a drag makes to
 * a mask curve (a vertex moved, the curve translated), rounded to µm.
 * Layer mm: x right, y up; SVG user units: x right, y down (= −layer y).
 */
import type { PreviewPath } from "../api/types";
import { closestOnPolyline, translate, type Pt } from "./geom";
import type { Mask } from "./edits";
import { sectionKey } from "./edits";

/** The visible window in SVG user units (x right, y down = −layer y), mm. */
export interface View {
  x: number;
  y: number;
  w: number;
  h: number;
}

/** The element's box on screen (px). */
export interface Rect {
  left: number;
  top: number;
  width: number;
  height: number;
}

/** A 2D affine map (DOMMatrix's a–f: x' = a x + c y + e, y' = b x + d y + f). */
export interface Affine {
  a: number;
  b: number;
  c: number;
  d: number;
  e: number;
  f: number;
}

export const round3 = (v: number) => Math.round(v * 1000) / 1000;
export const roundPt = (q: readonly number[]): Pt => [round3(q[0]), round3(q[1])];

/** Layer point (mm) under screen point (x, y), given the SVG's screen CTM (user units → px). */
export function screenToLayer(m: Affine, x: number, y: number): Pt {
  const det = m.a * m.d - m.b * m.c;
  if (!det) return [0, 0];
  const dx = x - m.e, dy = y - m.f;
  const ux = (m.d * dx - m.c * dy) / det, uy = (-m.b * dx + m.a * dy) / det;
  return [ux, -uy];
}

/** Screen point (px) of layer point q (mm): the inverse of screenToLayer. */
export function layerToScreen(m: Affine, q: readonly number[]): [number, number] {
  const ux = q[0], uy = -q[1];
  return [m.a * ux + m.c * uy + m.e, m.b * ux + m.d * uy + m.f];
}

/** Size of one screen pixel in mm (the larger of the two axes: the view is letter-boxed). */
export const pixelSize = (view: View, rect: Rect) => Math.max(view.w / Math.max(rect.width, 1), view.h / Math.max(rect.height, 1));

/** The view framing points (layer mm) with an 8 % margin + 1 mm, at the element's aspect (w / h). */
export function fitView(b: { minX: number; minY: number; maxX: number; maxY: number }, aspect: number | null): View {
  const pad = Math.max(b.maxX - b.minX, b.maxY - b.minY) * 0.08 + 1;
  let w = b.maxX - b.minX + 2 * pad, h = b.maxY - b.minY + 2 * pad;
  const a = aspect ?? w / h;
  const cx = (b.minX + b.maxX) / 2, cy = -(b.minY + b.maxY) / 2;
  if (w / h < a) w = h * a;
  else h = w / a;
  return { x: cx - w / 2, y: cy - h / 2, w, h };
}

/** Wheel zoom by exp(deltaY · 0.0015) about the screen point (x, y): the point under it stays put. */
export function zoomAbout(view: View, rect: Rect, x: number, y: number, deltaY: number): View {
  const k = Math.exp(deltaY * 0.0015);
  const fx = (x - rect.left) / rect.width, fy = (y - rect.top) / rect.height;
  const w = view.w * k, h = view.h * k;
  return { x: view.x + (view.w - w) * fx, y: view.y + (view.h - h) * fy, w, h };
}

/** The view dragged from screen point `start` to `now` (the drawing follows the pointer). */
export function panView(from: View, start: readonly number[], now: readonly number[], rectWidth: number): View {
  const k = from.w / rectWidth;
  return { ...from, x: from.x - (now[0] - start[0]) * k, y: from.y - (now[1] - start[1]) * k };
}

/** What a pointer event's target is, from the attributes the drawing puts on its elements. */
export interface Hit {
  vertex: string | null;
  curve: string | null;
  split: string | null;
  section: string | null;
}

export const readHit = (el: { getAttribute: (name: string) => string | null }): Hit => ({
  vertex: el.getAttribute("data-vertex"),
  curve: el.getAttribute("data-curve"),
  split: el.getAttribute("data-split"),
  section: el.getAttribute("data-section"),
});

/** "bs1/A:3" → { key: "bs1/A", index: 3 } (the key may contain ':'; the index is after the last). */
export function parseIndexed(s: string): { key: string; index: number } {
  const i = s.lastIndexOf(":");
  return { key: s.slice(0, i), index: Number(s.slice(i + 1)) };
}

/** The path nearest to w (paths of fewer than 2 points are not hit). */
export function nearestPath(paths: readonly PreviewPath[], w: Pt): PreviewPath | undefined {
  let best: PreviewPath | undefined, bd = Infinity;
  for (const q of paths) {
    if (q.points.length < 2) continue;
    const c = closestOnPolyline(w, q.points);
    if (c.distance < bd) {
      bd = c.distance;
      best = q;
    }
  }
  return best;
}

/**
 * Where a click of the split tool puts a zone split point: on the path clicked on (within
 * `tolerance` mm), else on the path of `fallback` (the selected or clicked section); null when
 * neither exists. The point is the closest on that path, rounded to µm.
 */
export function splitTarget(paths: readonly PreviewPath[], w: Pt, tolerance: number, fallback: string | null): { key: string; point: Pt } | null {
  const near = nearestPath(paths, w);
  const onNear = near && closestOnPolyline(w, near.points).distance <= tolerance;
  const path = onNear ? near : paths.find((q) => q.key === fallback);
  if (!path) return null;
  return { key: path.key, point: roundPt(closestOnPolyline(w, path.points).point) };
}

/** Section keys of a mask, in its order. */
export const maskKeys = (mask: Mask | undefined) => (mask?.sections ?? []).map((s) => sectionKey(mask!.id, s.id));

/** A section's curve (a copy), by its key. */
export function curveOf(mask: Mask | undefined, key: string): Pt[] | undefined {
  const s = mask?.sections.find((x) => sectionKey(mask.id, x.id) === key);
  return s ? s.curve.map((q) => [q[0], q[1]] as Pt) : undefined;
}

/** The curve with vertex `index` at the (snapped) point s, rounded to µm. */
export const moveVertex = (curve: readonly Pt[], index: number, s: Pt): Pt[] => curve.map((q, i) => (i === index ? roundPt(s) : q));

/**
 * The curve dragged from `start` to the pointer: by whole grid steps of the snapped point `s`
 * when there is a grid, else by the raw pointer `w`; rounded to µm.
 */
export function dragCurve(curve: readonly Pt[], start: Pt, s: Pt, w: Pt, grid: number): Pt[] {
  const dx = grid > 0 ? Math.round((s[0] - start[0]) / grid) * grid : w[0] - start[0];
  const dy = grid > 0 ? Math.round((s[1] - start[1]) / grid) * grid : w[1] - start[1];
  return translate(curve, dx, dy).map(roundPt);
}

/** The vertex `]` (dir +1) or `[` (−1) picks: after / before `current`, wrapping; from none, the first / last. */
export function stepVertex(count: number, current: number | null, dir: 1 | -1): number {
  const cur = current ?? (dir > 0 ? -1 : 0);
  return (cur + dir + count) % count;
}

/** The section `}` (dir +1) or `{` (−1) selects: after / before `selected`, wrapping; from none, the first / last. */
export function stepSection(keys: readonly string[], selected: string | null, dir: 1 | -1): string {
  const i = selected ? keys.indexOf(selected) : -1;
  return keys[(i + dir + keys.length + (i < 0 && dir < 0 ? 1 : 0)) % keys.length];
}

/** True when any vertex of b differs from a's. */
export const curveChanged = (a: readonly Pt[], b: readonly Pt[]) => b.some((q, i) => q[0] !== a[i][0] || q[1] !== a[i][1]);
