// The pure rules behind the editor's hooks (#27: App.tsx split): saving, uploads, drafts, opening,
// the end of a run, adding a node, a new mask from a layer, where a problem leads.
import { describe, expect, it } from "vitest";
import type { Artifact, FileInfo, NodeSpec, Recipe } from "../src/api/types";
import { ADD_STEP, newMaskPlan, placeNew, problemTarget } from "../src/app/actions";
import { openedRecipe } from "../src/app/useOpen";
import { draftAction, draftToOffer } from "../src/document/useDraftOffer";
import { saveAsInstead, storesXml } from "../src/document/useSave";
import { uploadQuestion } from "../src/document/useUpload";
import { writeDraft } from "../src/graph/drafts";
import { catalogMap, emptyRecipe, positionsOf } from "../src/graph/recipe";
import { endOfRun, mergedXmlArtifact } from "../src/run/useRunView";
import { idleRun, type RunState } from "../src/run/status";

const port = (name: string, type: string) => ({ name, type, description: "", optional: false, color: "#000" });
const spec = (type: string, inputs: [string, string][], outputs: [string, string][]): NodeSpec => ({
  type, title: type, category: "c", description: "", version: "1", per_layer: false,
  inputs: inputs.map(([n, t]) => port(n, t)), outputs: outputs.map(([n, t]) => port(n, t)), params_schema: { type: "object", properties: {} },
});
const cat = catalogMap([spec("mesh", [], [["mesh", "mesh"]]), spec("slice", [["mesh", "mesh"]], [["layers", "layers"]])]);

class MemStore implements Storage {
  m = new Map<string, string>();
  get length() { return this.m.size; }
  clear() { this.m.clear(); }
  getItem(k: string) { return this.m.get(k) ?? null; }
  key(i: number) { return [...this.m.keys()][i] ?? null; }
  removeItem(k: string) { this.m.delete(k); }
  setItem(k: string, v: string) { this.m.set(k, v); }
}

describe("saving", () => {
  it("asks for a name when there is none or the recipe is a shipped example saved under its own name", () => {
    expect(saveAsInstead(null, { graphName: null, isExample: false, recipeName: "" })).toEqual({ proposal: "untitled", message: null });
    expect(saveAsInstead(null, { graphName: null, isExample: false, recipeName: "cross" })?.proposal).toBe("cross");
    expect(saveAsInstead("cross", { graphName: "cross", isExample: true, recipeName: "cross" })).toEqual({
      proposal: "cross-copy", message: "cross is a shipped example (read-only): save as a new name",
    });
    expect(saveAsInstead("mine", { graphName: "cross", isExample: true, recipeName: "cross" })).toBeNull();
    expect(saveAsInstead("mine", { graphName: "mine", isExample: false, recipeName: "mine" })).toBeNull();
  });
  it("stores the XML when there is one and it is unsaved or goes to a new name", () => {
    expect(storesXml(null, { xmlDirty: true, name: "a", graphName: "a" })).toBe(false);
    expect(storesXml("<p/>", { xmlDirty: false, name: "a", graphName: "a" })).toBe(false);
    expect(storesXml("<p/>", { xmlDirty: true, name: "a", graphName: "a" })).toBe(true);
    expect(storesXml("<p/>", { xmlDirty: false, name: "b", graphName: "a" })).toBe(true);
  });
});

describe("uploads", () => {
  const stored = [{ name: "part.stl", size: 10, updated: 1, sha256: "aa" }, { name: "part-2.stl", size: 3, updated: 1, sha256: "bb" }] as FileInfo[];
  it("asks only when a stored file of that name has other content; 'keep both' gets a free name", () => {
    expect(uploadQuestion({ name: "new.stl", size: 5 }, "cc", stored)).toBeNull();
    expect(uploadQuestion({ name: "part.stl", size: 5 }, "aa", stored)).toBeNull();
    const ask = uploadQuestion({ name: "part.stl", size: 5 }, "cc", stored)!;
    expect(ask).toEqual({ name: "part.stl", size: 5, have: { size: 10, updated: 1, sha256: "aa" }, other: ask.other });
    expect(["part.stl", "part-2.stl"]).not.toContain(ask.other);
    expect(ask.other).toMatch(/^part.*\.stl$/);
  });
});

describe("drafts", () => {
  it("waits while an offer is open, writes unsaved work, clears only a draft this page wrote", () => {
    expect(draftAction({ offer: true, dirty: true, key: "a", wrote: null })).toBe("wait");
    expect(draftAction({ offer: false, dirty: true, key: "a", wrote: null })).toBe("write");
    expect(draftAction({ offer: false, dirty: false, key: "a", wrote: "a" })).toBe("clear");
    expect(draftAction({ offer: false, dirty: false, key: "a", wrote: null })).toBe("none");
    expect(draftAction({ offer: false, dirty: false, key: "a", wrote: "b" })).toBe("none");
  });
  it("offers a stored draft only when it differs from the recipe opened", () => {
    const store = new MemStore();
    const r = { ...emptyRecipe("a"), description: "saved" };
    expect(draftToOffer(store, "a", { recipe: r, xml: null })).toBeNull();
    writeDraft(store, "a", { recipe: r, xml: null, tab: "mask", savedAt: 5 });
    expect(draftToOffer(store, "a", { recipe: r, xml: null })).toBeNull();
    writeDraft(store, "a", { recipe: { ...r, description: "edited" }, xml: null, tab: "mask", savedAt: 6 });
    expect(draftToOffer(store, "a", { recipe: r, xml: null })?.savedAt).toBe(6);
    expect(draftToOffer(store, "b", { recipe: r, xml: null })).toBeNull();
  });
});

describe("opening", () => {
  it("the stored recipe over an empty one, its stored files pinned unless the recipe pins them", () => {
    const files = [{ name: "a.stl", size: 1, updated: 0, sha256: "s1" }, { name: "b.stl", size: 1, updated: 0, sha256: "s2" }] as FileInfo[];
    const r = openedRecipe("x", { nodes: [], edges: [], files: { "a.stl": "old" } } as Partial<Recipe>, files);
    expect(r.name).toBe("x");
    expect(r.format).toBe("waamflow/1");
    expect(r.files).toEqual({ "a.stl": "old", "b.stl": "s2" });
  });
});

describe("end of a run", () => {
  const failed: RunState = { ...idleRun, id: "r", phase: "failed", error: { message: "no region", layer: 3 } };
  it("a failure on a layer brings the mask tab and a toast; replayed quietly only the failure", () => {
    expect(endOfRun(failed, false)).toEqual({ failure: failed.error, toMask: true, message: "run failed: no region" });
    expect(endOfRun(failed, true)).toEqual({ failure: failed.error, toMask: false, message: null });
    expect(endOfRun({ ...failed, error: { message: "x" } }, false).toMask).toBe(false);
    expect(endOfRun({ ...idleRun, phase: "done" }, false)).toEqual({ failure: null, toMask: false, message: "run finished" });
    expect(endOfRun({ ...idleRun, phase: "done" }, true).message).toBeNull();
    expect(endOfRun({ ...idleRun, phase: "cancelled" }, false).message).toBeNull();
  });
  it("the merged parameter XML is the .params.xml artifact", () => {
    const arts = [{ name: "zone.toolpath.json" }, { name: "zone.params.xml" }] as Artifact[];
    expect(mergedXmlArtifact(arts)?.name).toBe("zone.params.xml");
    expect(mergedXmlArtifact(arts.slice(0, 1))).toBeNull();
  });
});

describe("adding a node", () => {
  const r: Recipe = { ...emptyRecipe("r"), nodes: [{ id: "mesh", type: "mesh", params: {} }, { id: "far", type: "mesh", params: {} }], ui: { positions: { mesh: [0, 0], far: [0, 500] } } };
  it("goes right of the one selected node, wired from its first compatible output", () => {
    const made = placeNew(cat, r, new Set(["mesh"]), cat.get("slice")!);
    expect(positionsOf(made.recipe)[made.id]).toEqual([ADD_STEP, 0]);
    expect(made.edge).toEqual({ from: "mesh.mesh", to: `${made.id}.mesh` });
  });
  it("without a selection: right of the rightmost node, unwired; at a drop point on free space", () => {
    const a = placeNew(cat, r, new Set(), cat.get("slice")!);
    expect(positionsOf(a.recipe)[a.id][0]).toBe(ADD_STEP);
    expect(a.edge).toBeNull();
    const b = placeNew(cat, r, new Set(), cat.get("slice")!, [0, 0]); // on top of "mesh": moved off it
    const p = positionsOf(b.recipe)[b.id];
    expect(p).not.toEqual([0, 0]);
    expect(Math.abs(p[0]) >= 220 || Math.abs(p[1]) >= 140).toBe(true);
    const empty = placeNew(cat, emptyRecipe(), new Set(), cat.get("mesh")!);
    expect(positionsOf(empty.recipe)[empty.id]).toEqual([0, 0]);
  });
});

describe("a new mask from a layer", () => {
  const sq = (x0: number, x1: number) => [[x0, 0], [x1, 0], [x1, 10], [x0, 10], [x0, 0]];
  const recipe: Recipe = {
    ...emptyRecipe("m"),
    nodes: [
      { id: "mask", type: "mask", params: {} },
      { id: "strategy", type: "strategy", params: { sections: { "bs1/A": { pattern: "raster" } } } },
    ],
  };
  const params = {
    masks: [
      { id: "bs1", from_layer: 0, sections: [{ id: "A", curve: sq(0, 50) }, { id: "B", curve: sq(50, 100) }] },
      { id: "bs2", from_layer: 4, sections: [{ id: "A", curve: sq(0, 60) }] },
    ],
  };
  const regions = [{ key: "bs1/A", polygon: { exterior: sq(0, 50), holes: [] } }, { key: "bs1/B", polygon: { exterior: sq(50, 100), holes: [] } }];
  it("carries the settings of the section it continues and lists what it cannot", () => {
    const made = newMaskPlan({ maskNode: "mask", params, newId: "bs2", layer: 4, regions }, recipe, null)!;
    expect(made.plan.recipe.nodes[1].params).toEqual({ sections: { "bs1/A": { pattern: "raster" }, "bs2/A": { pattern: "raster" } } });
    expect(made.plan.recipe.nodes[0].params).toBe(params);
    expect(made.text.startsWith("New mask bs2 from layer 4.\n\nCarried over:\n  strategy · sections: bs1/A → bs2/A")).toBe(true);
    expect(made.plan.lost.length).toBe(1);
    expect(made.summary).toBe("mask bs2 from layer 4: 1 setting(s) carried, 1 not");
  });
  it("no mask of that id: nothing to do", () => {
    expect(newMaskPlan({ maskNode: "mask", params, newId: "bs9", layer: 4, regions }, recipe, null)).toBeNull();
  });
});

describe("where a problem leads", () => {
  const r: Recipe = { ...emptyRecipe("p"), nodes: [{ id: "zone", type: "zone", params: {} }] };
  it("a layer or section: the mask canvas; a node only: the graph; a node not in the recipe is not selected", () => {
    expect(problemTarget({ node: "zone", layer: 3 }, r)).toEqual({ select: "zone", layer: 3, tab: "mask" });
    expect(problemTarget({ node: "zone", section: "bs1/A" }, r)).toEqual({ select: "zone", layer: null, tab: "mask" });
    expect(problemTarget({ node: "zone", section: "bs1/A" }, r, false)).toEqual({ select: "zone", layer: null, tab: "graph" });
    expect(problemTarget({ node: "gone" }, r)).toEqual({ select: null, layer: null, tab: "graph" });
    expect(problemTarget({}, r)).toEqual({ select: null, layer: null, tab: null });
  });
});
