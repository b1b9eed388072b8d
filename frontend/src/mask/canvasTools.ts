/**
 * Pure helpers of the 2D canvas's CAM views: path colouring by zone / speed / arc state with the
 * legend that explains it, bead width per section, the measure tool's geometry, vertex nudging.
 */
import type { NodeSpec, PreviewPath } from "../api/types";
import { findProperty } from "../forms/schema";
import type { Pt } from "./geom";

export type ColorBy = "zone" | "speed" | "arc";
export const COLOR_BY: [ColorBy, string][] = [["zone", "zone"], ["speed", "speed"], ["arc", "arc on/off"]];

/** Viridis at 9 stops (the 3D view uses the same map): dark blue = slow, yellow = fast. */
export const VIRIDIS = ["#440154", "#472c7a", "#3b518b", "#2c718e", "#21908d", "#27ad81", "#5cc863", "#aadc32", "#fde725"];
export const ARC_ON = "#c62828";
export const ARC_OFF = "#8d99a6";
export const ZONE_FALLBACK = "#1d3557";

const hex = (c: string) => [1, 3, 5].map((i) => parseInt(c.slice(i, i + 2), 16));
const toHex = (v: number[]) => `#${v.map((x) => Math.round(x).toString(16).padStart(2, "0")).join("")}`;

/** Colour of `v` on viridis over lo..hi (clipped; a flat range maps to the middle). */
export function viridis(v: number, lo: number, hi: number): string {
  if (!Number.isFinite(v)) return "#969696";
  const u = hi > lo ? Math.min(Math.max((v - lo) / (hi - lo), 0), 1) : 0.5;
  const x = u * (VIRIDIS.length - 1);
  const i = Math.min(Math.floor(x), VIRIDIS.length - 2);
  const f = x - i;
  const a = hex(VIRIDIS[i]), b = hex(VIRIDIS[i + 1]);
  return toHex(a.map((c, k) => c * (1 - f) + b[k] * f));
}

/** Programmed speed range (mm/s) over the arc-on segments of the shown paths. */
export function speedRange(paths: readonly PreviewPath[]): { lo: number; hi: number } | null {
  let lo = Infinity, hi = -Infinity;
  for (const p of paths)
    p.speed.forEach((s, i) => {
      if (s === null || !Number.isFinite(s) || p.arc[i] === false) return;
      lo = Math.min(lo, s);
      hi = Math.max(hi, s);
    });
  return lo <= hi ? { lo, hi } : null;
}

export interface Run { d: string; color: string; arc: boolean; zone: string }

/** A path as runs of consecutive segments that share colour and arc state (one SVG path each). */
export function pathRuns(path: PreviewPath, mode: ColorBy, speed: { lo: number; hi: number } | null): Run[] {
  const runs: Run[] = [];
  const pts = path.points;
  for (let i = 0; i + 1 < pts.length; i++) {
    const zone = path.zone[i] ?? "";
    const arc = path.arc[i] ?? true;
    const color =
      mode === "arc" ? (arc ? ARC_ON : ARC_OFF)
      : mode === "speed" ? viridis(path.speed[i] ?? NaN, speed?.lo ?? 0, speed?.hi ?? 1)
      : path.zone_colors?.[zone] ?? ZONE_FALLBACK;
    const last = runs[runs.length - 1];
    const seg = `L${pts[i + 1][0]} ${-pts[i + 1][1]}`;
    if (last && last.color === color && last.arc === arc && last.zone === zone) last.d += seg;
    else runs.push({ d: `M${pts[i][0]} ${-pts[i][1]}${seg}`, color, arc, zone });
  }
  return runs;
}

export interface Legend { swatches: { label: string; color: string }[]; gradient?: { stops: string[]; lo: number; hi: number; unit: string } }

/** What the colours on the canvas mean for a mode, from the shown paths. */
export function canvasLegend(paths: readonly PreviewPath[], mode: ColorBy): Legend {
  if (mode === "arc") return { swatches: [{ label: "arc on", color: ARC_ON }, { label: "arc off", color: ARC_OFF }] };
  if (mode === "speed") {
    const r = speedRange(paths);
    return { swatches: [{ label: "arc off", color: ARC_OFF }], gradient: r ? { stops: VIRIDIS, lo: r.lo, hi: r.hi, unit: "mm/s" } : undefined };
  }
  const seen = new Map<string, string>();
  for (const p of paths) for (const z of p.zone) if (z && !seen.has(z)) seen.set(z, p.zone_colors?.[z] ?? ZONE_FALLBACK);
  const order = (z: string) => (z === "start" ? -1 : z === "end" ? 1e9 : Number(z.replace(/\D/g, "")) || 0);
  return { swatches: [...seen].sort((a, b) => order(a[0]) - order(b[0])).map(([label, color]) => ({ label, color })).concat([{ label: "arc off", color: ARC_OFF }]) };
}

/**
 * What a strategy node offers a section, from the node catalog (one source with the backend): the
 * fill patterns (its schema's enum), the pattern a section gets when nothing names one, and the
 * bead width default. Nothing of our own: without the node's spec there is no list.
 */
export function strategyChoices(spec: NodeSpec | undefined): { patterns: string[]; patternDefault?: string; beadDefault?: number } {
  if (!spec) return { patterns: [] };
  const pattern = findProperty(spec.params_schema, "pattern");
  const bead = findProperty(spec.params_schema, "bead_width")?.default;
  return {
    patterns: Array.isArray(pattern?.enum) ? pattern.enum.map(String) : [],
    patternDefault: typeof pattern?.default === "string" ? pattern.default : undefined,
    beadDefault: typeof bead === "number" ? bead : undefined,
  };
}

/** Bead width (mm) of a section: its override, else the strategy's default, else the schema default. */
export function beadWidth(strategy: { default?: Record<string, unknown>; sections?: Record<string, Record<string, unknown>> }, key: string, schemaDefault: number | undefined): number | null {
  const v = strategy.sections?.[key]?.bead_width ?? strategy.default?.bead_width ?? schemaDefault;
  return typeof v === "number" && v > 0 ? v : null;
}

/** Distance (mm) and direction (deg, counter-clockwise from +x, in (−180, 180]) from a to b. */
export function measure(a: Pt, b: Pt): { distance: number; angleDeg: number; dx: number; dy: number } {
  const dx = b[0] - a[0], dy = b[1] - a[1];
  let angleDeg = (Math.atan2(dy, dx) * 180) / Math.PI;
  if (angleDeg <= -180) angleDeg += 360;
  return { distance: Math.hypot(dx, dy), angleDeg: Object.is(angleDeg, -0) ? 0 : angleDeg, dx, dy };
}

/** The curve with vertex `index` moved by (dx, dy), rounded to µm. */
export function nudge(curve: readonly Pt[], index: number, dx: number, dy: number): Pt[] {
  const r = (v: number) => Math.round(v * 1000) / 1000;
  return curve.map((q, i) => (i === index ? ([r(q[0] + dx), r(q[1] + dy)] as Pt) : ([q[0], q[1]] as Pt)));
}

/** The curve without vertex `index`, or null when it would have fewer than 3 vertices. */
export function dropVertex(curve: readonly Pt[], index: number): Pt[] | null {
  if (curve.length <= 3) return null;
  return curve.filter((_, i) => i !== index).map((q) => [q[0], q[1]] as Pt);
}

/** Arrow-key step: the grid pitch (1 mm without a grid), ×10 with Shift. */
export const nudgeStep = (grid: number, shift: boolean) => (grid > 0 ? grid : 1) * (shift ? 10 : 1);

/** "12.35" for a mm readout: 2 decimals, no "-0.00". */
export const mm = (v: number) => (Math.abs(v) < 0.005 ? "0.00" : v.toFixed(2));
