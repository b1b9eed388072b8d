import { describe, expect, it } from "vitest";
import type { NodeSpec, PreviewPath } from "../src/api/types";
import { ARC_OFF, ARC_ON, beadWidth, canvasLegend, dropVertex, measure, mm, nudge, nudgeStep, pathRuns, speedRange, strategyChoices, viridis, VIRIDIS } from "../src/mask/canvasTools";

const path = (over: Partial<PreviewPath> = {}): PreviewPath =>
  ({
    key: "bs1/A", strategy: "raster",
    points: [[0, 0], [10, 0], [10, 5], [0, 5]],
    zone: ["start", "z1", "end"], arc: [true, false, true], inside: [true, true, true],
    speed: [8, 12, 16], length_mm: 25, zone_colors: { start: "#2ec4b6", z1: "#4e79a7", end: "#e76f51" },
    ...over,
  }) as PreviewPath;

describe("canvas colour modes", () => {
  it("viridis ends and clipping", () => {
    expect(viridis(0, 0, 1)).toBe(VIRIDIS[0]);
    expect(viridis(1, 0, 1)).toBe(VIRIDIS[8]);
    expect(viridis(5, 0, 1)).toBe(VIRIDIS[8]);
    expect(viridis(0.5, 0, 1)).toBe(VIRIDIS[4]);
    expect(viridis(3, 3, 3)).toBe(VIRIDIS[4]); // flat range → middle
  });
  it("speed range over arc-on segments only", () => {
    expect(speedRange([path()])).toEqual({ lo: 8, hi: 16 });
    expect(speedRange([path({ speed: [null, null, null] })])).toBeNull();
  });
  it("runs by zone, speed and arc", () => {
    const z = pathRuns(path(), "zone", null);
    expect(z.map((r) => [r.color, r.arc])).toEqual([["#2ec4b6", true], ["#4e79a7", false], ["#e76f51", true]]);
    expect(z[0].d).toBe("M0 0L10 0");
    const s = pathRuns(path(), "speed", { lo: 8, hi: 16 });
    expect(s.map((r) => r.color)).toEqual([VIRIDIS[0], VIRIDIS[4], VIRIDIS[8]]);
    const a = pathRuns(path({ zone: ["z1", "z1", "z1"] }), "arc", null);
    expect(a.map((r) => r.color)).toEqual([ARC_ON, ARC_OFF, ARC_ON]);
    // one zone, arc on throughout: a single run with every point
    expect(pathRuns(path({ zone: ["z1", "z1", "z1"], arc: [true, true, true] }), "zone", null)).toHaveLength(1);
  });
  it("legends say what the colours mean", () => {
    expect(canvasLegend([path()], "zone").swatches.map((s) => s.label)).toEqual(["start", "z1", "end", "arc off"]);
    expect(canvasLegend([path()], "speed").gradient).toMatchObject({ lo: 8, hi: 16, unit: "mm/s" });
    expect(canvasLegend([path()], "arc").swatches).toEqual([{ label: "arc on", color: ARC_ON }, { label: "arc off", color: ARC_OFF }]);
  });
});

describe("bead width", () => {
  it("section override, then default, then schema default", () => {
    expect(beadWidth({ default: { bead_width: 5 }, sections: { "bs1/A": { bead_width: 7.5 } } }, "bs1/A", 6)).toBe(7.5);
    expect(beadWidth({ default: { bead_width: 5 }, sections: {} }, "bs1/B", 6)).toBe(5);
    expect(beadWidth({}, "bs1/B", 6)).toBe(6);
    expect(beadWidth({}, "bs1/B", undefined)).toBeNull();
  });
});

describe("measure tool geometry", () => {
  it("distance and angle counter-clockwise from +x", () => {
    expect(measure([0, 0], [3, 4])).toMatchObject({ distance: 5, dx: 3, dy: 4 });
    expect(measure([0, 0], [3, 4]).angleDeg).toBeCloseTo(53.1301, 4);
    expect(measure([1, 1], [1, 6]).angleDeg).toBeCloseTo(90, 9);
    expect(measure([0, 0], [-2, 0]).angleDeg).toBe(180);
    expect(measure([0, 0], [0, -2]).angleDeg).toBe(-90);
    expect(measure([2, 2], [2, 2])).toMatchObject({ distance: 0, angleDeg: 0 });
  });
  it("nudges and drops vertices", () => {
    const c: [number, number][] = [[0, 0], [10, 0], [10, 10], [0, 10]];
    expect(nudge(c, 1, 0.1, -0.2)).toEqual([[0, 0], [10.1, -0.2], [10, 10], [0, 10]]);
    expect(dropVertex(c, 2)).toEqual([[0, 0], [10, 0], [0, 10]]);
    expect(dropVertex(c.slice(0, 3), 0)).toBeNull();
    expect([nudgeStep(0.5, false), nudgeStep(0, false), nudgeStep(2, true)]).toEqual([0.5, 1, 20]);
    expect([mm(-0.001), mm(12.345)]).toEqual(["0.00", "12.35"]);
  });
});

// #27: the patterns and defaults a section is offered come from the node catalog, no list of our own
describe("strategyChoices: from the strategy node's catalog entry", () => {
  // the shape GET /api/nodes serves for `strategy` (trimmed): the fields live in $defs
  const strategySpec = {
    type: "strategy", title: "Strategy", category: "paths", description: "", version: "1", per_layer: true, inputs: [], outputs: [],
    params_schema: {
      type: "object",
      properties: {
        default: { $ref: "#/$defs/SectionStrategy" },
        sections: { type: "object", additionalProperties: { $ref: "#/$defs/SectionStrategyOverride" } },
      },
      $defs: {
        SectionStrategy: {
          type: "object",
          properties: {
            pattern: { type: "string", default: "oscillate", enum: ["contour", "oscillate", "parallel", "raster", "rectangular", "semicircular", "spiral", "swiping", "triangular"] },
            bead_width: { type: "number", default: 6.5, unit: "mm" },
          },
        },
        SectionStrategyOverride: {
          type: "object",
          properties: { pattern: { anyOf: [{ type: "string" }, { type: "null" }], default: null }, bead_width: { anyOf: [{ type: "number" }, { type: "null" }], default: null } },
        },
      },
    },
  } as unknown as NodeSpec;
  it("lists the catalog's patterns (contour included), its default pattern and bead width", () => {
    const c = strategyChoices(strategySpec);
    expect(c.patterns.length).toBe(9);
    expect(c.patterns).toContain("contour");
    expect(c.patternDefault).toBe("oscillate");
    expect(c.beadDefault).toBe(6.5);
  });
  it("without the node's spec (catalog not loaded) there is no list and no default", () => {
    expect(strategyChoices(undefined)).toEqual({ patterns: [] });
  });
});
