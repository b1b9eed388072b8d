import { describe, expect, it } from "vitest";
import type { Recipe } from "../src/api/types";
import { carryOver, matchByOverlap, oldRegionsForCarry, overlapArea } from "../src/graph/carry";

const rect = (x0: number, y0: number, x1: number, y1: number) => ({ exterior: [[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]], holes: [] as number[][][] });

describe("overlap", () => {
  it("estimates the intersection area within 2 %", () => {
    expect(Math.abs(overlapArea(rect(0, 0, 10, 10), rect(5, 0, 20, 10)) - 50)).toBeLessThan(1);
    expect(overlapArea(rect(0, 0, 10, 10), rect(11, 0, 20, 10))).toBe(0);
    const ring = { exterior: rect(0, 0, 10, 10).exterior, holes: [rect(2, 2, 8, 8).exterior] };
    expect(Math.abs(overlapArea(ring, rect(0, 0, 10, 10)) - 64)).toBeLessThan(1.5);
  });
  it("matches each new section to the old region it overlaps most", () => {
    // old: left arm A, right arm B; new: a curve mostly over B, one over A, one over nothing
    const old = [{ key: "bs1/A", polygon: rect(0, 0, 50, 10) }, { key: "bs1/B", polygon: rect(50, 0, 100, 10) }];
    const next = [
      { key: "bs2/X", polygon: rect(40, -5, 105, 15) },
      { key: "bs2/Y", polygon: rect(-5, -5, 45, 15) },
      { key: "bs2/Z", polygon: rect(200, 0, 210, 10) },
    ];
    expect([...matchByOverlap(old, next)]).toEqual([["bs2/X", "bs1/B"], ["bs2/Y", "bs1/A"]]);
  });
});

describe("carryOver", () => {
  const recipe: Recipe = {
    format: "waamflow/1", name: "t", description: "", inputs: {}, edges: [],
    nodes: [
      { id: "guide", type: "guide", params: { guides: { "bs1/A": [[0, 0], [1, 0]], "bs1/B": [[2, 0], [3, 0]] } } },
      { id: "strategy", type: "strategy", params: { default: { pattern: "zigzag" }, sections: { "bs1/B": { pattern: "raster" } } } },
      { id: "zone", type: "zone", params: { sections: { "bs1/A": { start_length: 12, split_points: [[5, 0]] } } } },
      { id: "post", type: "post-process", params: {} },
    ],
  };
  const xml = [0, 1, 2, 3, 4].map((i) => `<layer index="${i}" z="${i}"><section id="bs1/A"><zone id="start"><current unit="A">${200 + i}</current></zone></section><section id="bs1/B"><zone id="start"><current unit="A">1${i}0</current></zone></section></layer>`).join("");
  it("copies per-section params and moves the XML values of the governed layers", () => {
    const plan = carryOver(recipe, {
      matches: new Map([["bs2/A", "bs1/A"], ["bs2/B", "bs1/B"]]), oldKeys: ["bs1/A", "bs1/B", "bs1/C"], oldRegions: ["bs1/A", "bs1/B"], from: 2, to: 4, xml,
    });
    const p = (id: string) => plan.recipe.nodes.find((n) => n.id === id)!.params as Record<string, Record<string, unknown>>;
    expect(p("guide").guides["bs2/A"]).toEqual([[0, 0], [1, 0]]);
    expect(p("guide").guides["bs1/A"]).toEqual([[0, 0], [1, 0]]); // the old mask keeps governing layers 0–1
    expect(p("strategy").sections["bs2/B"]).toEqual({ pattern: "raster" });
    expect(p("zone").sections["bs2/A"]).toEqual({ start_length: 12, split_points: [[5, 0]] });
    expect(p("zone").sections["bs2/B"]).toBeUndefined(); // nothing set for bs1/B: nothing to carry
    expect(plan.recipe.nodes[3]).toBe(recipe.nodes[3]);
    // layers 2 and 3 move to bs2, 0–1 and 4 (another mask from 4) stay
    expect(plan.xml!.match(/<layer index="(\d)"[^>]*><section id="([^"]+)"/g)).toEqual([
      '<layer index="0" z="0"><section id="bs1/A"', '<layer index="1" z="1"><section id="bs1/A"', '<layer index="2" z="2"><section id="bs2/A"',
      '<layer index="3" z="3"><section id="bs2/A"', '<layer index="4" z="4"><section id="bs1/A"',
    ]);
    expect(plan.xml).toContain('<section id="bs2/B"><zone id="start"><current unit="A">130</current>');
    expect(plan.carried).toContain("XML values: bs1/A → bs2/A on 2 layer(s)");
    expect(plan.carried).toContain("strategy · sections: bs1/B → bs2/B");
    expect(plan.lost).toEqual(["bs1/C: no region on layer 2"]);
  });
  it("lists an old region no new section continues", () => {
    const plan = carryOver(recipe, { matches: new Map([["bs2/A", "bs1/A"]]), oldKeys: ["bs1/A", "bs1/B"], oldRegions: ["bs1/A", "bs1/B"], from: 1, to: null, xml: null });
    expect(plan.lost).toEqual(["bs1/B: no new section overlaps its region on layer 1"]);
    expect(plan.xml).toBeNull();
  });
});

describe("after a failed run (#25 fault 7)", () => {
  it("matches by the old curves when the layer has no regions, by the regions where it has them", () => {
    const sections = [{ id: "A", curve: rect(0, 0, 50, 10).exterior }, { id: "B", curve: rect(50, 0, 100, 10).exterior }];
    // the failed layer: the preview gave no regions at all
    const none = oldRegionsForCarry("bs1", sections, []);
    expect(none.map((r) => r.key)).toEqual(["bs1/A", "bs1/B"]);
    expect(Math.round(overlapArea(none[0].polygon, rect(0, 0, 50, 10)))).toBe(500);
    const next = [{ key: "bs2/A", polygon: rect(0, 0, 50, 10) }, { key: "bs2/B", polygon: rect(50, 0, 100, 10) }];
    expect([...matchByOverlap(none, next)]).toEqual([["bs2/A", "bs1/A"], ["bs2/B", "bs1/B"]]);
    // a region the preview has wins over the curve (here: only the left 20 mm of A's curve)
    const some = oldRegionsForCarry("bs1", sections, [{ key: "bs1/A", polygon: rect(0, 0, 20, 10) }]);
    expect(Math.round(overlapArea(some[0].polygon, rect(0, 0, 50, 10)))).toBe(200);
    expect(some[1].polygon.exterior).toEqual(sections[1].curve);
  });
});
