import { describe, expect, it } from "vitest";
import type { NodeSpec, Recipe } from "../src/api/types";
import {
  addNode, amend, autoLayout, catalogMap, changeSignature, commit, setNodeParams, connect, connectionError, connectionRefusal, copySelection, defaultParams, history,
  paste, redo, removeNodes, renameNode, undo, uniqueId,
} from "../src/graph/recipe";

const port = (name: string, type: string) => ({ name, type, description: "", optional: false, color: "#000" });
const spec = (type: string, inputs: [string, string][], outputs: [string, string][], props = {}): NodeSpec => ({
  type, title: type, category: "c", description: "", version: "1", per_layer: false,
  inputs: inputs.map(([n, t]) => port(n, t)), outputs: outputs.map(([n, t]) => port(n, t)),
  params_schema: { type: "object", properties: props },
});
const cat = catalogMap([
  spec("mesh", [], [["mesh", "mesh"]], { path: { type: "string", default: "a.stl" } }),
  spec("slice", [["mesh", "mesh"]], [["layers", "layers"]], { layer_height: { type: "number", default: 1.5 } }),
  spec("mask", [["layers", "layers"]], [["sections", "sections"]]),
  spec("loop", [["sections", "sections"]], [["layers", "layers"]]),
]);
const recipe: Recipe = {
  format: "waamflow/1", name: "t", description: "", inputs: {},
  nodes: [
    { id: "part", type: "mesh", params: {} },
    { id: "layers", type: "slice", params: {} },
    { id: "mask", type: "mask", params: {} },
    { id: "loop", type: "loop", params: {} },
  ],
  edges: [{ from: "part.mesh", to: "layers.mesh" }, { from: "layers.layers", to: "mask.layers" }],
};
const c = (source: string, sourceHandle: string, target: string, targetHandle: string) => ({ source, sourceHandle, target, targetHandle });

describe("connection validation", () => {
  it("accepts matching port types", () => {
    expect(connectionError(cat, recipe, c("mask", "sections", "loop", "sections"))).toBeNull();
  });
  it("rejects a type mismatch, unknown ports and self-loops", () => {
    expect(connectionError(cat, recipe, c("part", "mesh", "mask", "layers"))).toBe("type mismatch: mesh → layers");
    expect(connectionError(cat, recipe, c("part", "nope", "layers", "mesh"))).toMatch(/no output port/);
    expect(connectionError(cat, recipe, c("loop", "layers", "loop", "sections"))).toMatch(/itself/);
  });
  it("rejects a cycle", () => {
    const r = connect(recipe, c("mask", "sections", "loop", "sections"));
    expect(connectionError(cat, r, c("loop", "layers", "mask", "layers"))).toMatch(/cycle/);
  });
  it("gives the short reason drawn on a refused handle", () => {
    expect(connectionRefusal(cat, recipe, c("part", "mesh", "mask", "layers"))).toEqual({ text: "type mismatch: mesh → layers", short: "type mesh ≠ layers" });
    const r = connect(recipe, c("mask", "sections", "loop", "sections"));
    expect(connectionRefusal(cat, r, c("loop", "layers", "mask", "layers"))?.short).toBe("would create a cycle");
    expect(connectionRefusal(cat, recipe, c("part", "mesh", "layers", "mesh"))).toBeNull();
  });
  it("replaces the edge into an input that is already connected", () => {
    const r = connect(recipe, c("part", "mesh", "layers", "mesh"));
    expect(r.edges.filter((e) => e.to === "layers.mesh")).toHaveLength(1);
    expect(r.edges).toHaveLength(2);
  });
});

describe("ids, add, remove, rename", () => {
  it("derives unique ids", () => {
    expect(uniqueId(new Set(["slice", "slice2"]), "slice")).toBe("slice3");
    expect(uniqueId(new Set(), "simulate-robot")).toBe("simulate-robot");
    expect(uniqueId(new Set(), "3d")).toBe("n3d");
  });
  it("adds a node with a position and removes it with its edges", () => {
    const { recipe: r, id } = addNode(recipe, cat.get("slice")!, [10, 20]);
    expect(id).toBe("slice");
    expect(r.ui?.positions?.slice).toEqual([10, 20]);
    const r2 = removeNodes(r, new Set(["layers"]));
    expect(r2.nodes.map((n) => n.id)).toEqual(["part", "mask", "loop", "slice"]);
    expect(r2.edges).toHaveLength(0);
  });
  it("renames a node in edges and positions, refusing taken or invalid ids", () => {
    const r = renameNode({ ...recipe, ui: { positions: { layers: [1, 2] } } }, "layers", "sl") as Recipe;
    expect(r.edges.map((e) => e.from + ">" + e.to)).toEqual(["part.mesh>sl.mesh", "sl.layers>mask.layers"]);
    expect(r.ui?.positions).toEqual({ sl: [1, 2] });
    expect(renameNode(recipe, "layers", "part")).toMatch(/taken/);
    expect(renameNode(recipe, "layers", "9x")).toMatch(/letters/);
  });
  it("takes parameter defaults from the schema", () => {
    expect(defaultParams(cat.get("slice")!)).toEqual({ layer_height: 1.5 });
  });
  it("lays out columns by depth and wraps long chains into bands", () => {
    const pos = autoLayout(recipe);
    expect(pos.part[0]).toBe(0);
    expect(pos.layers[0]).toBe(250);
    expect(pos.mask[0]).toBe(500);
    const w = autoLayout(recipe, 250, 100, 2);
    // "loop" is unconnected (depth 0, second row): columns hold ≤ 2 rows, so a band is 2.6 × 100.
    expect(w.loop).toEqual([0, 100]);
    expect(w.mask).toEqual([0, 260]); // depth 2 → column 0 of the second band
  });
});

describe("copy/paste and history", () => {
  it("pastes a selection with fresh ids and internal edges only", () => {
    const clip = copySelection(recipe, new Set(["layers", "mask"]));
    expect(clip.edges).toEqual([{ from: "layers.layers", to: "mask.layers" }]);
    const { recipe: r, ids } = paste(recipe, clip, [40, 40]);
    expect(ids).toEqual(["layers2", "mask2"]);
    expect(r.edges).toContainEqual({ from: "layers2.layers", to: "mask2.layers" });
    expect(r.edges).toHaveLength(3);
    expect(r.ui!.positions!.mask2[0] - clip.positions.mask[0]).toBe(40);
  });
  it("undoes and redoes commits, and a new commit clears redo", () => {
    let h = history(1);
    h = commit(h, 2);
    h = commit(h, 3);
    h = undo(h);
    expect(h.present).toBe(2);
    h = redo(h);
    expect(h.present).toBe(3);
    h = undo(undo(h));
    expect(h.present).toBe(1);
    h = commit(h, 9);
    expect(h.future).toHaveLength(0);
    expect(redo(h).present).toBe(9);
  });
});

describe("undo steps while typing", () => {
  it("signs a params edit by node, and structural edits uniquely", () => {
    const a = setNodeParams(recipe, "layers", { layer_height: 1 });
    const b = setNodeParams(a, "layers", { layer_height: 1.2 });
    expect(changeSignature(a, b)).toBe("node:layers");
    expect(changeSignature(recipe, { ...recipe, description: "x" })).toBe("description");
    const s1 = changeSignature(recipe, removeNodes(recipe, new Set(["loop"])));
    expect(s1).toMatch(/^structure:/);
    expect(s1).not.toBe(changeSignature(recipe, removeNodes(recipe, new Set(["loop"]))));
  });
  it("amends the present without a new step", () => {
    const h = amend(commit(history(1), 2), 3);
    expect(h.present).toBe(3);
    expect(undo(h).present).toBe(1);
  });
});
