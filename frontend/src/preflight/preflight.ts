/**
 * The preflight report of a run (`preflight.json`, contract v3 "Preflight"): an independent check
 * of the emitted program against its part. Pure helpers for the toolbar badge (verdict → label,
 * tone, tooltip), the problems panel (sorted problems, "new mask here") and the 2D canvas (the
 * ignition points of a layer and of the layer below). Lengths in mm, shares 0..1.
 */

export type Verdict = "ok" | "warn" | "fail";
export type Check = "top_gap" | "bottom_gap" | "plate" | "layer_order" | "retrace" | "dwell_metal" | "travel_collision" | "torch_axis" | "weld_position" | "z_jump" | "local_deposit" | "unreadable" | "weld_speed" | "uncovered" | "volume_ratio" | "arc_run" | "stacked_starts" | "weld_data" | "program";
export type Point3 = [number, number, number];

/** Whole-part (or per-program) figures; any may be null when it does not apply. */
export interface PreflightFigures {
  top_gap_mm?: number | null;
  /** Lowest arc-ON point − (part bottom + one layer): > 0 where layers are missing below. */
  bottom_gap_mm?: number | null;
  uncovered_share?: number | null;
  wire_part_volume_ratio?: number | null;
  min_arc_run_mm?: number | null;
  start_spread_mm?: number | null;
  weld_data_missing?: number | null;
  /** Largest share of an arc-ON run's length welded over beads earlier runs of its layer laid (0..1). */
  retrace_share?: number | null;
  /** Robot programs: the largest angle between the torch and its layer's build direction, deg. */
  torch_angle_max_deg?: number | null;
  /** Programs written for a cell: the largest angle between a layer's build direction in the world (under the positioner angles the program states) and up, deg (0 = flat). */
  weld_position_max_deg?: number | null;
  /** Travel moves (arc off) found in metal welded before them (fan programs: along each layer's build direction). */
  travel_collisions?: number | null;
  /** Metal laid in dwells with the arc on, mm³ (counted in the wire balance). */
  dwell_mm3?: number | null;
  /** The arc-on dwell laying the most metal, in bead widths of the program's bead. */
  dwell_max_widths?: number | null;
}

export interface PreflightProgram extends PreflightFigures {
  node: string;
  format: string;
  files: string[];
  verdict: Verdict;
  /** This program's per-layer figures (when the report has no whole-run `layers`). */
  layers?: PreflightLayer[];
  bead_width_mm?: number | null;
  /** The spacing of the 3D coverage check's samples, mm (walls and fan layers only). */
  coverage_sample_mm?: number | null;
  /** The spacing asked (the settings' `sample_mm`, else the check's default), mm. */
  coverage_sample_asked_mm?: number | null;
  /** What the check could not judge or read, in words (a layer not judged, runs without angles, …). */
  notes?: string[];
}

export interface PreflightLayer {
  index: number;
  z?: number | null;
  part_area_mm2?: number | null;
  uncovered_mm2?: number | null;
  uncovered_share?: number | null;
  wire_mm3?: number | null;
  part_mm3?: number | null;
  volume_ratio?: number | null;
  /** Ignition points (arc on) of this layer, world mm. */
  starts?: number[][] | null;
  /** Extinction points (arc off) of this layer, world mm. */
  stops?: number[][] | null;
  min_arc_run_mm?: number | null;
}

export interface PreflightProblem {
  check: Check | string;
  severity: "fail" | "warn";
  node?: string | null;
  layer?: number | null;
  section?: string | null;
  message: string;
  value?: number | null;
  limit?: number | null;
  point?: number[] | null;
}

export interface Preflight extends PreflightFigures {
  verdict: Verdict;
  accepted?: boolean;
  programs?: PreflightProgram[];
  part?: { node?: string; kind?: string; volume_mm3?: number | null; top_mm?: number | null } | null;
  settings?: Record<string, unknown> | null;
  layers?: PreflightLayer[];
  problems?: PreflightProblem[];
}

/** Read a preflight.json text; null when it is not one (so a half-written or foreign file shows nothing). */
export function parsePreflight(text: string | null): Preflight | null {
  if (!text) return null;
  try {
    const v = JSON.parse(text) as Preflight;
    return v && (v.verdict === "ok" || v.verdict === "warn" || v.verdict === "fail") ? v : null;
  } catch {
    return null;
  }
}

// ---- the toolbar badge ----------------------------------------------------------------------------

export type BadgeTone = Verdict | "stale" | "pending" | "none";

export interface BadgeView {
  tone: BadgeTone;
  /** Visible text: "preflight ok", "preflight ⚠ 3", "preflight ✗ 2", "preflight: re-run". */
  label: string;
  /** The same in words for screen readers (the colour is never the only cue). */
  aria: string;
  /** The key figures, one per line. */
  tooltip: string;
  count: number;
  /** The panel can list problems (a report, fresh or stale). */
  clickable: boolean;
}

export interface BadgeInput {
  phase: "idle" | "running" | "done" | "failed" | "cancelled";
  report: Preflight | null;
  /** The recipe or parameter XML changed since the run that wrote the report. */
  stale: boolean;
}

const fix = (v: number | null | undefined, digits: number, unit = "") => (v == null || !Number.isFinite(v) ? "n/a" : `${v.toFixed(digits)}${unit}`);

/** The key figures of a report, as label/value pairs (null → "n/a"). */
export function figureRows(f: PreflightFigures): [string, string][] {
  return [
    ["top gap", fix(f.top_gap_mm, 2, " mm")],
    ["bottom gap", fix(f.bottom_gap_mm, 2, " mm")],
    ["uncovered", f.uncovered_share == null ? "n/a" : `${(100 * f.uncovered_share).toFixed(1)} %`],
    ["wire/part volume", fix(f.wire_part_volume_ratio, 2)],
    ["min arc run", fix(f.min_arc_run_mm, 1, " mm")],
    ["start spread", fix(f.start_spread_mm, 1, " mm")],
    ["weld data missing", f.weld_data_missing == null ? "n/a" : String(f.weld_data_missing)],
    // programs written for a cell only: how far the layer deposited least flat lies off flat
    ...(f.weld_position_max_deg == null ? [] : ([["off flat", fix(f.weld_position_max_deg, 1, "°")]] as [string, string][])),
  ];
}

/** What the toolbar shows for the last run's preflight; null = nothing (no run yet, or it failed). */
export function preflightBadge({ phase, report, stale }: BadgeInput): BadgeView | null {
  if (phase === "running")
    return { tone: "pending", label: "preflight …", aria: "preflight … runs when the run ends", tooltip: "preflight runs when the run ends", count: 0, clickable: false };
  if (!report) {
    if (phase !== "done") return null;
    return {
      tone: "none", label: "no preflight", aria: "no preflight: this run wrote no preflight report",
      tooltip: "this run wrote no preflight.json (no program, or a server without the preflight check)", count: 0, clickable: false,
    };
  }
  const count = report.problems?.length ?? 0;
  const figures = figureRows(report).map(([k, v]) => `${k}: ${v}`).join("\n");
  if (stale)
    return {
      tone: "stale", label: "preflight: re-run", aria: `preflight: re-run, out of date: the recipe changed since the run (it was ${report.verdict})`,
      tooltip: `out of date: the recipe or parameter XML changed since this run; run again.\nlast run (${report.verdict}):\n${figures}`, count, clickable: true,
    };
  const accepted = report.accepted ? " (accepted)" : "";
  const label = report.verdict === "ok" ? (count ? `preflight ok · ${count}` : "preflight ok") : report.verdict === "warn" ? `preflight ⚠ ${count}` : `preflight ✗ ${count}`;
  const words = report.verdict === "ok" ? "passed" : report.verdict === "warn" ? "warnings" : "failed";
  const fails = (report.problems ?? []).filter((p) => p.severity === "fail").length;
  // The accessible name starts with the visible text (WCAG 2.5.3), then says it in words.
  const aria = `${label}${accepted}: preflight ${words}, ${count} problem${count === 1 ? "" : "s"}${fails ? ` (${fails} failing)` : ""}; open the list`;
  return {
    tone: report.verdict, label: label + accepted, aria,
    tooltip: `preflight ${report.verdict}${accepted}: ${count} problem${count === 1 ? "" : "s"}\n${figures}`, count, clickable: true,
  };
}

// ---- the problems panel -------------------------------------------------------------------------

/** Problems in reading order: failures first, then by layer (whole-part ones first), then check. */
export function sortedProblems(report: Preflight | null): PreflightProblem[] {
  const ps = [...(report?.problems ?? [])];
  const sev = (p: PreflightProblem) => (p.severity === "fail" ? 0 : 1);
  return ps.sort((a, b) => sev(a) - sev(b) || (a.layer ?? -1) - (b.layer ?? -1) || String(a.check).localeCompare(String(b.check)));
}

/** Human name of a check. */
export const CHECK_LABEL: Record<string, string> = {
  top_gap: "top not reached", bottom_gap: "bottom not built", plate: "below or above the plate", weld_speed: "welding without a speed", layer_order: "layers out of order", retrace: "welded twice", dwell_metal: "metal laid standing", travel_collision: "travel into the part", torch_axis: "torch turned away", weld_position: "layer not deposited flat", z_jump: "move off the layer's plane", local_deposit: "too little or too much metal", unreadable: "motion not readable", uncovered: "uncovered area", volume_ratio: "wire/part volume", arc_run: "short arc run",
  stacked_starts: "stacked starts", weld_data: "weld data missing", program: "program", hole: "a place with no bead",
  layer_volume_ratio: "layer's metal off", skipped_layers: "skipped layers", outside: "welding off the part", wire_feed: "welding without wire",
  deposit_changed: "deposit changed by the sequence", preflight: "preflight itself",
};
export const checkLabel = (c: string) => CHECK_LABEL[c] ?? c;

/** "new mask here" applies: an uncovered area or a layer's place with no bead, on a known layer (and section). */
export const canMaskHere = (p: PreflightProblem) => (p.check === "uncovered" || p.check === "hole") && p.layer != null;

/** A stable key for a problem row. */
export const problemKey = (p: PreflightProblem, i: number) => `${p.check}|${p.node ?? ""}|${p.layer ?? ""}|${p.section ?? ""}|${i}`;

// ---- the 2D canvas --------------------------------------------------------------------------------

export interface LayerStarts {
  /** Ignition points of the shown layer (world mm). */
  here: Point3[];
  /** Ignition points of the layer below, to see stacking. */
  below: Point3[];
  /** Extinction points (arc off) of the shown layer (world mm). */
  stops: Point3[];
}

const asPoint = (q: number[]): Point3 => [q[0] ?? 0, q[1] ?? 0, q[2] ?? 0];

/** The report's per-layer figures: its own, else those of its first program that has some. */
export function reportLayers(report: Preflight | null): PreflightLayer[] {
  if (report?.layers?.length) return report.layers;
  return report?.programs?.find((p) => p.layers?.length)?.layers ?? [];
}

/** The ignition points of layer `index` and of the layer below it (empty when unknown). */
export function layerStarts(report: Preflight | null, index: number): LayerStarts {
  const byIndex = new Map(reportLayers(report).map((l) => [l.index, l]));
  return {
    here: (byIndex.get(index)?.starts ?? []).map(asPoint),
    below: (byIndex.get(index - 1)?.starts ?? []).map(asPoint),
    stops: (byIndex.get(index)?.stops ?? []).map(asPoint),
  };
}

/** Per start in `here`: does it lie within `radius` mm (in x, y) of a start in `below`? (null: the
 * radius is unknown, nothing is marked) */
export function stackedStarts(here: readonly number[][], below: readonly number[][], radius: number | null): boolean[] {
  return here.map((p) => radius !== null && below.some((q) => Math.hypot(p[0] - q[0], p[1] - q[1]) < radius));
}

/** The bead width the check used (its settings', else its first program's; mm). The backend
 * reports the width it used with every program (its default included): no default of our own, null
 * when the report names none. */
export function beadWidthOf(report: Preflight | null): number | null {
  for (const v of [report?.settings?.bead_width_mm, ...(report?.programs ?? []).map((p) => p.bead_width_mm)])
    if (typeof v === "number" && v > 0) return v;
  return null;
}

/** Programs whose 3D coverage was sampled coarser than asked (a large part: the check holds a
 * midsurface's grid to 1,000,000 samples, a mesh's to 200,000): [node, spacing used, spacing asked]
 * in mm, both as the report states them (`coverage_sample_mm`, `coverage_sample_asked_mm`: no rule
 * of our own; a report without the asked spacing claims nothing); coarser means by more than 5 % (a
 * mesh's even samples land a little apart anyway). */
export function coarseCoverage(report: Preflight | null): [string, number, number][] {
  const out: [string, number, number][] = [];
  for (const p of report?.programs ?? []) {
    const used = p.coverage_sample_mm;
    const asked = p.coverage_sample_asked_mm;
    if (typeof used !== "number" || typeof asked !== "number" || !(asked > 0)) continue;
    if (used > 1.05 * asked) out.push([p.node, used, asked]);
  }
  return out;
}

/** The notes of the report's programs, each once, as [program node, note]: what the check did not
 * judge (a layer neither flat nor laid on a bead, runs without positioner angles) or could not read. */
export function reportNotes(report: Preflight | null): [string, string][] {
  const out: [string, string][] = [];
  const seen = new Set<string>();
  for (const p of report?.programs ?? []) {
    for (const n of p.notes ?? []) {
      const key = JSON.stringify([p.node, n]);
      if (typeof n !== "string" || seen.has(key)) continue;
      seen.add(key);
      out.push([p.node, n]);
    }
  }
  return out;
}

// ---- stale reports --------------------------------------------------------------------------------

/** What a run ran: the recipe as the engine sees it (JSON, no editor state, no name) and the parameter XML. */
export interface RunInputs {
  recipe: string;
  xml: string | null;
}

/** The recipe without editor state (`ui`) or name: moving a node or saving under a new name changes nothing the engine runs. */
export const recipeSignature = (r: { ui?: unknown; name?: unknown }) => JSON.stringify({ ...r, ui: null, name: null });

/** A report no longer describes what is on screen once the recipe or the XML differ from what was run. */
export const isStale = (report: Preflight | null, ran: RunInputs | null, now: RunInputs) =>
  !!report && !!ran && (ran.recipe !== now.recipe || ran.xml !== now.xml);
