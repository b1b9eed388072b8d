import { describe, expect, it } from "vitest";
import type { Recipe } from "../src/api/types";
import {
  addSection, canvasNodes, governingMask, maskRanges, newMaskFromLayer, patchSection, removeSection, sectionValue, setCurve, setGuide,
} from "../src/mask/edits";

const sq = [[0, 0], [10, 0], [10, 10], [0, 10]];
const params = {
  masks: [
    { id: "bs2", from_layer: 4, sections: [{ id: "A", curve: sq }] },
    { id: "bs1", from_layer: 0, sections: [{ id: "A", curve: sq }, { id: "B", curve: sq }] },
  ],
};

describe("masks", () => {
  it("computes layer ranges sorted by first layer", () => {
    expect(maskRanges(params, 8)).toEqual([{ id: "bs1", from: 0, to: 3 }, { id: "bs2", from: 4, to: 7 }]);
    expect(maskRanges(params, null)[1].to).toBeNull();
  });
  it("finds the governing mask", () => {
    expect(governingMask(params, 3)?.id).toBe("bs1");
    expect(governingMask(params, 4)?.id).toBe("bs2");
    expect(governingMask({ masks: [{ id: "m", from_layer: 2, sections: [] }] }, 1)).toBeUndefined();
  });
  it("adds a section with the next letter, creating a mask when none governs", () => {
    const a = addSection(params, 1, sq);
    expect(a.key).toBe("bs1/C");
    const b = addSection({}, 5, sq);
    expect(b.key).toBe("bs1/A");
    expect(b.params.masks).toEqual([{ id: "bs1", from_layer: 0, sections: [{ id: "A", curve: sq }] }]);
  });
  it("moves and removes a section's curve", () => {
    const moved = setCurve(params, "bs1/B", [[1, 1], [2, 1], [2, 2]]);
    expect(moved.masks![1].sections[1].curve).toEqual([[1, 1], [2, 1], [2, 2]]);
    expect(moved.masks![1].sections[0].curve).toBe(sq);
    expect(removeSection(params, "bs1/A").masks![1].sections.map((s) => s.id)).toEqual(["B"]);
    expect(removeSection(params, "bs2/A").masks!.map((m) => m.id)).toEqual(["bs1"]);
  });
  it("starts a new mask at a failing layer prefilled from the governing one", () => {
    const r = newMaskFromLayer(params, 6);
    if ("error" in r) throw new Error(r.error);
    expect(r.id).toBe("bs3");
    const m = r.params.masks!.find((x) => x.id === "bs3")!;
    expect(m.from_layer).toBe(6);
    expect(m.sections.map((s) => s.id)).toEqual(["A"]);
    expect(maskRanges(r.params, 8).map((x) => [x.from, x.to])).toEqual([[0, 3], [4, 5], [6, 7]]);
    expect(newMaskFromLayer(params, 4)).toEqual({ error: "a mask already starts at layer 4" });
  });
});

describe("per-section params", () => {
  it("sets and clears guides", () => {
    const g = setGuide({}, "bs1/A", [[0, 5], [10, 5]]);
    expect(g.guides).toEqual({ "bs1/A": [[0, 5], [10, 5]] });
    expect(setGuide(g, "bs1/A", null).guides).toEqual({});
  });
  it("patches zone entries and falls back to the default", () => {
    const z = patchSection({ default: { start_length: 10 } }, "bs1/A", { end_length: 5 });
    expect(z.sections).toEqual({ "bs1/A": { start_length: 10, end_length: 5 } });
    expect(sectionValue(z, "bs1/A", "start_length")).toBe(10);
    expect(sectionValue(z, "bs1/A", "end_length")).toBe(5);
    expect(patchSection(z, "bs1/A", { end_length: undefined, start_length: undefined }).sections).toEqual({});
  });
});

it("finds the nodes the canvas edits upstream of the preview node", () => {
  const r: Recipe = {
    format: "waamflow/1", name: "x", description: "", inputs: {},
    nodes: ["slice", "mask", "guide", "strategy", "zone", "sequence"].map((t) => ({ id: "n_" + t, type: t, params: {} })),
    edges: [["slice", "layers", "mask", "layers"], ["mask", "sections", "guide", "sections"], ["guide", "sections", "strategy", "sections"],
      ["strategy", "toolpath", "zone", "toolpath"], ["zone", "toolpath", "sequence", "toolpath"]]
      .map(([a, p, b, q]) => ({ from: `n_${a}.${p}`, to: `n_${b}.${q}` })),
  };
  const c = canvasNodes(r);
  expect(c.preview?.id).toBe("n_zone");
  expect([c.slice?.id, c.mask?.id, c.guide?.id, c.strategy?.id, c.zone?.id]).toEqual(["n_slice", "n_mask", "n_guide", "n_strategy", "n_zone"]);
  expect(canvasNodes(r, "n_guide").zone).toBeUndefined();
});
