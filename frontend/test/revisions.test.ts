import { describe, expect, it } from "vitest";
import type { Recipe } from "../src/api/types";
import { clip, newestFirst, revisionSummary, whenOf, whoOf } from "../src/document/revisions";

const recipe = (layerHeight: number, extra: Partial<Recipe> = {}): Recipe => ({
  format: "waamflow/1",
  name: "r",
  description: "",
  inputs: {},
  nodes: [
    { id: "part", type: "mesh", params: { path: "a.stl" } },
    { id: "layers", type: "slice", params: { layer_height: layerHeight } },
  ],
  edges: [{ from: "part.mesh", to: "layers.mesh" }],
  ...extra,
});

describe("revision history helpers", () => {
  it("lists newest first without changing the input", () => {
    const rows = [{ revision: 1, time: 0 }, { revision: 3, time: 0 }, { revision: 2, time: 0 }];
    expect(newestFirst(rows).map((r) => r.revision)).toEqual([3, 2, 1]);
    expect(rows.map((r) => r.revision)).toEqual([1, 3, 2]);
  });

  it("shows the save time in local time (epoch seconds) and who saved it", () => {
    expect(whenOf(1_700_000_000, "en-US")).toBe(new Date(1_700_000_000_000).toLocaleString("en-US"));
    expect(whoOf("alice")).toBe("alice");
    expect(whoOf(null)).toBe("—");
    expect(whoOf(undefined)).toBe("—");
  });

  it("says which nodes' settings differ, with counts", () => {
    expect(revisionSummary(recipe(1.5), recipe(1.1))).toBe("settings of layers differ (vs. the open recipe) · 2 nodes · 1 edge");
    expect(revisionSummary(recipe(1.5), recipe(1.5))).toBe("same graph as the open recipe · 2 nodes · 1 edge");
  });

  it("names added and removed nodes and changed connections", () => {
    const cur = recipe(1.5);
    const rev: Recipe = { ...cur, nodes: [cur.nodes[0], { id: "post", type: "post", params: {} }], edges: [] };
    expect(revisionSummary(rev, cur)).toBe("has post (not in the open recipe); lacks layers; connections differ (vs. the open recipe) · 2 nodes · 0 edges");
  });

  it("quotes the description, cut at a word; a description change alone is named", () => {
    const long = "Modular path planning of the cross-shaped test piece of Michel et al. (RCIM 2019): 6 mm bead, 1.5 mm layers";
    const s = revisionSummary(recipe(1.5, { description: long }), recipe(1.5));
    expect(s).toMatch(/^description differs \(vs\. the open recipe\) · 2 nodes · 1 edge · “Modular path planning .*…”$/);
    expect(clip(long, 40).length).toBeLessThanOrEqual(40);
    expect(clip(long, 40)).toBe("Modular path planning of the…");
    expect(clip("short", 40)).toBe("short");
  });
});
