/**
 * Legend content for the 3D view, computed from the state the API returns: which entries the
 * current colour modes draw (zone swatches, a colour-map bar with its range and unit, arc on/off).
 */
import type { LegendEntry } from "./api";

export interface Swatch { label: string; color: string }
export interface Bar { label: string; gradient: string; lo: string; hi: string; unit: string }
export interface LegendBlock { title: string; swatches: Swatch[]; bar: Bar | null; note?: string }

/** CSS linear-gradient through evenly spaced stops (low → high, left → right). */
export function gradientCss(stops: readonly string[]): string {
  if (!stops.length) return "none";
  if (stops.length === 1) return stops[0];
  return `linear-gradient(to right, ${stops.map((c, i) => `${c} ${((100 * i) / (stops.length - 1)).toFixed(1)}%`).join(", ")})`;
}

/** A number for a legend end: 3 significant digits, no exponent for everyday magnitudes. */
export function fmt(v: number): string {
  if (!Number.isFinite(v)) return "–";
  if (v === 0) return "0";
  const a = Math.abs(v);
  if (a >= 1e5 || a < 1e-3) return v.toExponential(2);
  return String(Number(v.toPrecision(3)));
}

const LABELS: Record<string, string> = { speed: "speed", deviation: "deviation", deposit: "deposit per mm" };

/** Legend blocks for the drawn outputs: the toolpath by its mode, the simulation by its mode. */
export function legendBlocks(entries: readonly LegendEntry[], colormap: readonly string[]): LegendBlock[] {
  const grad = gradientCss(colormap);
  return entries.map((e) => {
    const title = `${e.node} — ${e.kind === "toolpath" ? "toolpath" : "simulated path"} by ${LABELS[e.mode] ?? e.mode}`;
    const swatches: Swatch[] = [];
    let bar: Bar | null = null;
    let note: string | undefined;
    const range = e.ranges[e.mode];
    if (range) {
      // robust limits: values beyond are drawn in the end colours; the ends say so (≤ / ≥)
      const tol = 0.01 * Math.max(range.hi - range.lo, 1e-12); // beyond an end by more than 1 % of the span
      const below = !!range.clamped && range.min !== undefined && range.min < range.lo - tol;
      const above = !!range.clamped && range.max !== undefined && range.max > range.hi + tol;
      bar = { label: LABELS[e.mode] ?? e.mode, gradient: grad, lo: `${below ? "≤ " : ""}${fmt(range.lo)}`, hi: `${above ? "≥ " : ""}${fmt(range.hi)}`, unit: range.unit };
      if (below || above) note = `outliers clamped to the ends (2nd–98th percentile); data ${fmt(range.min ?? range.lo)}–${fmt(range.max ?? range.hi)} ${range.unit}`;
    }
    if (e.kind === "toolpath") {
      if (e.mode === "zone") {
        swatches.push(...(e.zones ?? []).map((z) => ({ label: z.zone, color: z.color })));
        if (!e.zones?.length) note = "not zoned: drawn by section";
      } else if (e.mode === "arc" && e.arc) {
        swatches.push({ label: "arc on", color: e.arc.on }, { label: "arc off", color: e.arc.off });
      } else if (e.mode === "section") note = "one colour per section";
      if (e.mode !== "arc" && e.travel) swatches.push({ label: "travel", color: e.travel });
    } else {
      if (e.programmed) swatches.push({ label: "programmed", color: e.programmed });
      if (e.travel) swatches.push({ label: "arc off", color: e.travel });
      if (!range) note = `no ${LABELS[e.mode] ?? e.mode} data in this simulation`;
      const robot = e.robot ? `robot ${e.robot}` : e.robot_note;
      if (robot) note = note ? `${note}; ${robot}` : robot;
    }
    return { title, swatches, bar, note };
  });
}

/** The layer range the 3D view shows: the canvas layer when synced, else the chosen range, clipped to the part. */
export function layerRange(sync: boolean, canvasLayer: number, chosen: [number, number], extent: { lo: number; hi: number } | null): [number, number] {
  const lo0 = extent?.lo ?? 0;
  const hi0 = extent?.hi ?? Math.max(chosen[1], canvasLayer);
  const clip = (v: number) => Math.min(Math.max(v, lo0), hi0);
  if (sync) return [clip(canvasLayer), clip(canvasLayer)];
  const a = clip(Math.min(chosen[0], chosen[1]));
  const b = clip(Math.max(chosen[0], chosen[1]));
  return [a, b];
}
