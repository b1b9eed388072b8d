/**
 * The builds page's data shaping (#29): a build's detail (GET /api/builds/{id}) → per-layer rows
 * (as-built vs planned top, deviation, cumulative and per-layer error, the adaptation and dwell of
 * the program that built it), chart series, the timeline, and the colours of the as-built
 * deviation overlay. Pure functions: unit-tested in test/builds.test.ts. Units: mm, s, °C.
 */
import type { components } from "../api/schema";

type S = components["schemas"];
export type BuildInfo = S["BuildInfo"];
export type BuildDetail = S["BuildDetail"];
export type LayerProgram = S["LayerProgram"];
export type Surface = S["Surface"];
export type SurfaceLayer = S["SurfaceLayer"];

type Obj = Record<string, unknown>;
const num = (v: unknown): number | null => (typeof v === "number" && Number.isFinite(v) ? v : null);

/** One planned layer as the page shows it (null fields: not known yet). */
export interface LayerRow {
  layer: number;
  /** 1, or 2… for a layer laid again (its top was more than half a layer low). */
  pass: number;
  /** scanned: measured; next: the layer the cell builds now; planned: not yet; dropped: left out
   * (the layer below came out more than half a layer high). */
  state: "scanned" | "next" | "planned" | "dropped";
  /** what the loop decided after this scan (a layer laid again or left out), else null. */
  then: string | null;
  plannedTop: number | null;
  asBuiltTop: number | null;
  /** mean top error vs plan (mm): the error accumulated up to this layer. */
  meanError: number | null;
  rmsError: number | null;
  maxError: number | null;
  /** what this layer itself added to the mean error (mm): meanError − the layer below's. */
  addedError: number | null;
  coverage: number | null;
  /** speed factors of this layer's program (× plan), samples clamped to the window. */
  speedMin: number | null;
  speedMax: number | null;
  clampedSlow: number | null;
  clampedFast: number | null;
  adapted: boolean | null;
  /** interpass: temperature measured after this layer (°C); dwell before this layer (s). */
  measuredC: number | null;
  dwellS: number | null;
  dwellClamped: boolean;
}

/** Every layer of a build in build order: each scan (a layer laid again has a row per pass),
 * the layers left out, the next layer and the ones still planned (`plan_layers`). */
export function layerRows(d: BuildDetail): LayerRow[] {
  const scanned = (d.layers ?? []) as Obj[];
  const programs = new Map<string, Obj>();
  for (const p of (d.programs ?? []) as Obj[]) if (num(p.layer) !== null) programs.set(`${p.layer}:${num(p.pass) ?? 1}`, p);
  const plan = d.plan_layers?.length ? d.plan_layers : Array.from({ length: d.layers_planned }, (_, i) => i);
  const skipped = new Set(d.skipped ?? []);
  // build order: the scans as they came, the layers left out where they belong, then the rest
  const items: { layer: number; pass: number; r: Obj | null; state: LayerRow["state"] }[] = scanned.map((r) => ({
    layer: r.layer as number, pass: num(r.pass) ?? 1, r, state: "scanned" as const,
  }));
  const seen = new Set(items.map((x) => x.layer));
  const nextAt = d.next_layer === null || d.next_layer === undefined ? plan.length : plan.indexOf(d.next_layer);
  const passesOf = (l: number) => items.filter((x) => x.layer === l).length;
  plan.forEach((layer, i) => {
    if (skipped.has(layer)) items.push({ layer, pass: 1, r: null, state: "dropped" });
    else if (layer === d.next_layer) items.push({ layer, pass: passesOf(layer) + 1, r: null, state: "next" });
    else if (!seen.has(layer) && i > nextAt) items.push({ layer, pass: 1, r: null, state: "planned" });
  });
  items.sort((a, b) => a.layer - b.layer || a.pass - b.pass);
  const rows: LayerRow[] = [];
  let prevMean: number | null = null;
  items.forEach(({ layer, pass, r, state }) => {
    const p = state === "dropped" ? null : programs.get(`${layer}:${pass}`) ?? null;
    const mean = r ? num(r.mean_error_mm) : null;
    rows.push({
      layer,
      pass,
      state,
      then: r && typeof r.then === "string" ? r.then : null,
      plannedTop: r ? num(r.planned_top_mm) : null,
      asBuiltTop: r ? num(r.asbuilt_top_mm) : null,
      meanError: mean,
      rmsError: r ? num(r.rms_error_mm) : null,
      maxError: r ? num(r.max_error_mm) : null,
      addedError: mean === null ? null : prevMean === null ? mean : mean - prevMean,
      coverage: r ? num(r.coverage) : null,
      speedMin: p ? num(p.speed_factor_min) : null,
      speedMax: p ? num(p.speed_factor_max) : null,
      clampedSlow: p ? num(p.clamped_slow) : null,
      clampedFast: p ? num(p.clamped_fast) : null,
      adapted: p ? Boolean(p.adapted) : null,
      measuredC: r ? num(r.interpass_measured_c) : null,
      dwellS: p ? num(p.dwell_s) : null,
      dwellClamped: Boolean(p?.dwell_clamped),
    });
    if (mean !== null) prevMean = mean;
  });
  return rows;
}

/** Layers done vs planned, the error of the last scanned layer, the total dwell the programs hold. */
export function progress(d: BuildDetail) {
  const rows = layerRows(d);
  const scans = rows.filter((r) => r.state === "scanned");
  const done = scans.filter((r) => r.pass === 1);
  const last = scans[scans.length - 1] ?? null;
  return {
    done: done.length,
    planned: d.layers_planned,
    share: d.layers_planned ? done.length / d.layers_planned : 0,
    lastMean: last?.meanError ?? null,
    lastMax: last?.maxError ?? null,
    dwellTotal: rows.reduce((a, r) => a + (r.dwellS ?? 0), 0),
    clampedLayers: rows.filter((r) => (r.clampedSlow ?? 0) + (r.clampedFast ?? 0) > 0).length,
    added: d.layers_added ?? 0,
    dropped: d.layers_dropped ?? 0,
  };
}

/** Chart series over the scanned layers (x = layer number). */
export function chartSeries(rows: LayerRow[]) {
  // a layer laid again: its last pass (what the next layer is laid on)
  const s = rows.filter((r, i) => r.state === "scanned" && !rows.slice(i + 1).some((q) => q.state === "scanned" && q.layer === r.layer));
  const x = s.map((r) => r.layer);
  const col = (f: (r: LayerRow) => number | null) => s.map((r) => f(r) ?? NaN);
  return {
    heights: [
      { label: "planned top", x, y: col((r) => r.plannedTop), color: "#555555", dashed: true },
      { label: "as-built top (mean)", x, y: col((r) => r.asBuiltTop), color: "#1f6fb2" },
    ],
    errors: [
      { label: "mean error (cumulative)", x, y: col((r) => r.meanError), color: "#1f6fb2" },
      { label: "max |error|", x, y: col((r) => r.maxError), color: "#c0392b" },
      { label: "added by the layer", x, y: col((r) => r.addedError), color: "#6a994e", dashed: true },
    ],
  };
}

export interface TimelineEvent {
  time: string;
  /** seconds since the build started */
  t: number;
  who: string;
  action: string;
  layer: number | null;
  text: string;
}

/** The build's log as a timeline: one line per step saying who did what, with which scan or program. */
export function timeline(d: BuildDetail): TimelineEvent[] {
  const log = (d.log ?? []) as Obj[];
  const t0 = log.length ? Date.parse(String(log[0].time)) : 0;
  return log.map((e) => {
    const layer = num(e.layer);
    const a = String(e.action);
    let text: string;
    if (a === "start") text = `build started: ${e.layers} layers planned`;
    else if (a === "scan") {
      const file = e.scan_file ? ` — ${e.scan_file}${num(e.scan_bytes) !== null ? `, ${kB(e.scan_bytes as number)}` : ""}${e.scan_sha256 ? `, sha256 ${e.scan_sha256}…` : ""}` : "";
      text = `scan of layer ${layer} measured: mean ${fmt(num(e.mean_error_mm))} mm, max ${fmt(num(e.max_error_mm))} mm, coverage ${pct(num(e.coverage))}${file}`;
    }
    else if (a === "scan_refused") text = `scan of layer ${layer} refused: ${e.reason}`;
    else if (a === "layer_added" || a === "layer_dropped") text = String(e.reason);
    else if (a === "program") {
      const sha = (e.sha256 ?? {}) as Record<string, string>;
      const files = Array.isArray(e.files) && e.files.length ? ` (${(e.files as string[]).map((f) => (sha[f] ? `${f} sha256 ${sha[f]}…` : f)).join(", ")})` : "";
      const sp = num(e.speed_factor_min) !== null ? `, speed ×${fmt(num(e.speed_factor_min), 2)}…×${fmt(num(e.speed_factor_max), 2)}` : "";
      const dw = num(e.dwell_s) !== null ? `, wait ${fmt(num(e.dwell_s), 1)} s (part ${e.interpass_measured_c} °C)` : "";
      text = `program of layer ${layer} issued${e.adapted ? " (adapted)" : " (as planned)"}${sp}${dw}${files}`;
    } else text = `${a}${layer !== null ? ` layer ${layer}` : ""}`;
    const t = Date.parse(String(e.time));
    return { time: String(e.time), t: Number.isFinite(t) && Number.isFinite(t0) ? (t - t0) / 1000 : 0, who: e.who ? String(e.who) : "—", action: a, layer, text };
  });
}

const kB = (b: number) => (b >= 1024 ? `${(b / 1024).toFixed(1)} kB` : `${b} B`);

export function fmt(v: number | null | undefined, digits = 3): string {
  return v === null || v === undefined || !Number.isFinite(v) ? "—" : v.toFixed(digits);
}

export function pct(v: number | null | undefined): string {
  return v === null || v === undefined || !Number.isFinite(v) ? "—" : `${(100 * v).toFixed(1)} %`;
}

// ---- deviation colours (the 3D view's map: viewer/asbuilt.py) ---------------------------------
const STOPS: [number, number, number][] = [
  [33, 102, 172],
  [247, 247, 247],
  [178, 24, 43],
];
export const STOP_HEX = ["#2166ac", "#f7f7f7", "#b2182b"];

/** Deviation (mm) → colour: −limit blue, 0 white, +limit red (clipped). */
export function deviationColor(dev: number, limit: number): string {
  const u = Math.max(-1, Math.min(1, dev / Math.max(limit, 1e-12)));
  const end = u < 0 ? STOPS[0] : STOPS[2];
  const t = Math.abs(u);
  const c = STOPS[1].map((w, i) => Math.round(w * (1 - t) + end[i] * t));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

/** The deviation overlay of one scanned layer: segments between neighbouring path samples (a
 * gap where samples are further apart than `gap` mm or one was not seen), coloured over ±limit
 * (limit = max |deviation| of the layer, at least 0.05 mm). */
export function overlaySegments(l: SurfaceLayer, gap = 2.5) {
  const devs = l.deviation.filter((v): v is number => v !== null && Number.isFinite(v));
  const lo = devs.length ? Math.min(...devs) : 0;
  const hi = devs.length ? Math.max(...devs) : 0;
  const limit = Math.max(Math.abs(lo), Math.abs(hi), 0.05);
  const segs: { x1: number; y1: number; x2: number; y2: number; dev: number; color: string }[] = [];
  for (let i = 0; i + 1 < l.x.length; i++) {
    const a = l.deviation[i], b = l.deviation[i + 1];
    if (a === null || b === null) continue;
    const dx = l.x[i + 1] - l.x[i], dy = l.y[i + 1] - l.y[i];
    if (Math.hypot(dx, dy) > gap) continue;
    const dev = (a + b) / 2;
    segs.push({ x1: l.x[i], y1: l.y[i], x2: l.x[i + 1], y2: l.y[i + 1], dev, color: deviationColor(dev, limit) });
  }
  return { segs, lo, hi, limit, seen: devs.length, samples: l.x.length };
}

/** `#/builds` → list, `#/builds/<id>` → one build, anything else → null (the editor). */
export function parseRoute(hash: string): { id: string | null } | null {
  const m = /^#\/builds(?:\/([0-9a-f]{12}))?\/?$/.exec(hash);
  return m ? { id: m[1] ?? null } : null;
}
