import { describe, expect, it } from "vitest";
import {
  beadWidthOf, canMaskHere, figureRows, isStale, layerStarts, recipeSignature, parsePreflight, preflightBadge, sortedProblems, stackedStarts, type Preflight, type PreflightProblem,
} from "../src/preflight/preflight";

const problem = (over: Partial<PreflightProblem> = {}): PreflightProblem => ({
  check: "uncovered", severity: "warn", node: "post", layer: 3, section: "bs1/A", message: "layer 3, bs1/A: 12 mm² (4 %) gets no bead", value: 0.04, limit: 0.02, point: [10, 2, 6], ...over,
});

const report = (over: Partial<Preflight> = {}): Preflight => ({
  verdict: "ok", accepted: false, top_gap_mm: 0, uncovered_share: 0.004, wire_part_volume_ratio: 1.03, min_arc_run_mm: 18.2, start_spread_mm: 12,
  weld_data_missing: 0, programs: [], layers: [], problems: [], ...over,
});

describe("preflight badge: verdict → label, tone, figures", () => {
  it("ok is green and says so in words", () => {
    const b = preflightBadge({ phase: "done", report: report(), stale: false })!;
    expect(b.tone).toBe("ok");
    expect(b.label).toBe("preflight ok");
    expect(b.aria).toBe("preflight ok: preflight passed, 0 problems; open the list");
    expect(b.count).toBe(0);
    expect(b.clickable).toBe(true);
  });
  it("warn is amber with the problem count", () => {
    const b = preflightBadge({ phase: "done", report: report({ verdict: "warn", problems: [problem(), problem({ check: "arc_run", layer: 5 }), problem({ check: "stacked_starts" })] }), stale: false })!;
    expect(b.tone).toBe("warn");
    expect(b.label).toBe("preflight ⚠ 3");
    expect(b.count).toBe(3);
    expect(b.aria).toBe("preflight ⚠ 3: preflight warnings, 3 problems; open the list");
  });
  it("fail is red, counts the failing ones in its label for screen readers, and marks an accepted run", () => {
    const ps = [problem({ check: "top_gap", severity: "fail", layer: null, section: null }), problem()];
    const b = preflightBadge({ phase: "done", report: report({ verdict: "fail", problems: ps }), stale: false })!;
    expect(b.tone).toBe("fail");
    expect(b.label).toBe("preflight ✗ 2");
    expect(b.aria).toBe("preflight ✗ 2: preflight failed, 2 problems (1 failing); open the list");
    const acc = preflightBadge({ phase: "done", report: report({ verdict: "fail", accepted: true, problems: ps }), stale: false })!;
    expect(acc.label).toBe("preflight ✗ 2 (accepted)");
    expect(acc.aria).toMatch(/^preflight ✗ 2 \(accepted\): preflight failed, 2 problems/);
  });
  it("a failed run that still wrote its report shows the report", () => {
    expect(preflightBadge({ phase: "failed", report: report({ verdict: "fail", problems: [problem({ severity: "fail" })] }), stale: false })!.label).toBe("preflight ✗ 1");
  });
  it("tooltip lists the seven key figures with units; missing ones read n/a", () => {
    const b = preflightBadge({ phase: "done", report: report({ wire_part_volume_ratio: null, weld_data_missing: 2, bottom_gap_mm: 3 }), stale: false })!;
    expect(b.tooltip.split("\n")).toEqual([
      "preflight ok: 0 problems", "top gap: 0.00 mm", "bottom gap: 3.00 mm", "uncovered: 0.4 %", "wire/part volume: n/a", "min arc run: 18.2 mm", "start spread: 12.0 mm", "weld data missing: 2",
    ]);
    expect(figureRows({}).every(([, v]) => v === "n/a")).toBe(true);
  });
  it("a program written for a cell adds how far its least flat layer lies off flat", () => {
    const rows = figureRows({ weld_position_max_deg: 89.04 });
    expect(rows.length).toBe(8);
    expect(rows[7]).toEqual(["off flat", "89.0°"]);
    expect(figureRows({ weld_position_max_deg: null }).length).toBe(7);
  });
});

describe("preflight badge: never stale, never early", () => {
  it("greys out once the recipe changed after the run, keeping the old verdict only in its tooltip", () => {
    const b = preflightBadge({ phase: "done", report: report({ verdict: "warn", problems: [problem()] }), stale: true })!;
    expect(b.tone).toBe("stale");
    expect(b.label).toBe("preflight: re-run");
    expect(b.label).not.toMatch(/ok|⚠|✗/);
    expect(b.aria).toMatch(/^preflight: re-run, out of date/);
    expect(b.tooltip).toMatch(/last run \(warn\)/);
  });
  it("shows progress while running, even with an old report", () => {
    expect(preflightBadge({ phase: "running", report: report(), stale: false })!.tone).toBe("pending");
  });
  it("nothing before any run; a finished run without report says so", () => {
    expect(preflightBadge({ phase: "idle", report: null, stale: false })).toBeNull();
    expect(preflightBadge({ phase: "failed", report: null, stale: false })).toBeNull();
    const none = preflightBadge({ phase: "done", report: null, stale: false })!;
    expect(none.tone).toBe("none");
    expect(none.clickable).toBe(false);
  });
});

describe("stale report: recipe or XML changed since the run", () => {
  const recipe = { name: "mpp-cross", inputs: {}, nodes: [{ id: "slice", type: "slice", params: { layer_height: 2 } }], edges: [], ui: { positions: { slice: [0, 0] } } };
  const ran = { recipe: recipeSignature(recipe), xml: "<p/>" };
  it("is fresh while nothing the engine runs changed (moving a node, a new name)", () => {
    const moved = { ...recipe, name: "copy", ui: { positions: { slice: [40, 10] } } };
    expect(isStale(report(), ran, { recipe: recipeSignature(moved), xml: "<p/>" })).toBe(false);
  });
  it("is stale after a parameter edit or an XML edit", () => {
    const edited = { ...recipe, nodes: [{ ...recipe.nodes[0], params: { layer_height: 1.8 } }] };
    expect(isStale(report(), ran, { recipe: recipeSignature(edited), xml: "<p/>" })).toBe(true);
    expect(isStale(report(), ran, { recipe: ran.recipe, xml: "<p a='1'/>" })).toBe(true);
  });
  it("without a report there is nothing to be stale", () => {
    expect(isStale(null, ran, { recipe: "x", xml: null })).toBe(false);
  });
});

describe("preflight report: parsing, problem order, starts", () => {
  it("parses a report and refuses anything without a verdict", () => {
    expect(parsePreflight(JSON.stringify(report({ verdict: "warn" })))!.verdict).toBe("warn");
    expect(parsePreflight("{}")).toBeNull();
    expect(parsePreflight("not json")).toBeNull();
    expect(parsePreflight(null)).toBeNull();
  });
  it("lists failures first, then by layer with whole-part problems first", () => {
    const ps = [problem({ layer: 7 }), problem({ severity: "fail", check: "weld_data", layer: 9 }), problem({ check: "volume_ratio", layer: null }), problem({ layer: 2 })];
    const got = sortedProblems(report({ problems: ps })).map((p) => `${p.severity}:${p.check}:${p.layer}`);
    expect(got).toEqual(["fail:weld_data:9", "warn:volume_ratio:null", "warn:uncovered:2", "warn:uncovered:7"]);
  });
  it("offers 'new mask here' only for an uncovered area or a hole on a known layer", () => {
    expect(canMaskHere(problem())).toBe(true);
    expect(canMaskHere(problem({ layer: null }))).toBe(false);
    expect(canMaskHere(problem({ check: "arc_run" }))).toBe(false);
    // a layer's place with no bead (hole) is an uncovered area too; a layer's metal is not
    expect(canMaskHere(problem({ check: "hole" }))).toBe(true);
    expect(canMaskHere(problem({ check: "layer_volume_ratio" }))).toBe(false);
  });
  it("finds a layer's ignition points and the layer below's; a start within the bead width of one below is stacked", () => {
    const r = report({
      layers: [
        { index: 2, starts: [[0, 0, 4], [50, 0, 4]] },
        { index: 3, starts: [[3, 4, 6], [50, 7, 6], [100, 0, 6]] },
      ],
    });
    const s = layerStarts(r, 3);
    expect(s.here).toHaveLength(3);
    expect(s.below).toHaveLength(2);
    // distances to the nearest start below: 5 mm, 7 mm, 50 mm; bead width 6 mm
    expect(stackedStarts(s.here, s.below, 6)).toEqual([true, false, false]);
    expect(layerStarts(r, 2).below).toEqual([]);
    expect(layerStarts(null, 0)).toEqual({ here: [], below: [], stops: [] });
  });
  it("gives the shown layer's arc stops beside its starts", () => {
    const r = report({ layers: [{ index: 4, starts: [[3, -60, 7.5]], stops: [[-3, 60, 7.5], [60, 3, 7.5]] }] });
    const s = layerStarts(r, 4);
    expect(s.stops).toEqual([[-3, 60, 7.5], [60, 3, 7.5]]);
    expect(layerStarts(r, 5).stops).toEqual([]);
  });
  it("reads the layers and bead width of the first program when the report has none of its own", () => {
    const r = report({
      layers: undefined, settings: { bead_width_mm: null },
      programs: [{ node: "post", format: "gcode", files: ["post.gcode"], verdict: "warn", bead_width_mm: 5, layers: [{ index: 0, starts: [[3, -60, 1.5]] }, { index: 1, starts: [[3, -60, 3]] }] }],
    });
    expect(layerStarts(r, 1)).toEqual({ here: [[3, -60, 3]], below: [[3, -60, 1.5]], stops: [] });
    expect(beadWidthOf(r)).toBe(5);
    // #27: the width is the backend's (it reports the one it used, its default included): no 6 mm of our own
    expect(beadWidthOf(report())).toBeNull();
    expect(stackedStarts([[0, 0, 3]], [[0.1, 0, 1.5]], null)).toEqual([false]);
    expect(stackedStarts([[0, 0, 3]], [[0.1, 0, 1.5]], 0.2)).toEqual([true]);
  });
});
