// @vitest-environment jsdom
// Pure logic of the GUI core: free-space placement, auto-wiring, one-step deletes, drafts and URL
// state, problems per node, node search ranking.
import { describe, expect, it } from "vitest";
import type { NodeSpec, Recipe } from "../src/api/types";
import { clearDraft, draftDiffers, draftKey, parsePlace, placeSearch, readDraft, writeDraft } from "../src/graph/drafts";
import { searchNodes } from "../src/graph/NodeSearch";
import {
  NODE_BOX, addFrame, autoWire, catalogMap, framesOf, freeSpot, moveFrame, nodesInFrame, removeEdges, removeFrames, removeNodes, type XY,
} from "../src/graph/recipe";
import { collectProblems, problemsByNode } from "../src/problems/problems";

const port = (name: string, type: string) => ({ name, type, description: "", optional: false, color: "#000" });
const spec = (type: string, inputs: [string, string][], outputs: [string, string][], title = type): NodeSpec => ({
  type, title, category: "c", description: "", version: "1", per_layer: false,
  inputs: inputs.map(([n, t]) => port(n, t)), outputs: outputs.map(([n, t]) => port(n, t)),
  params_schema: { type: "object", properties: {} },
});
const cat = catalogMap([
  spec("mesh", [], [["mesh", "mesh"]], "Mesh"),
  spec("slice", [["mesh", "mesh"]], [["layers", "layers"]], "Slice"),
  spec("fan-slice", [["mesh", "mesh"]], [["layers", "layers"]], "Fan slice (curved parts)"),
  spec("mask", [["layers", "layers"]], [["sections", "sections"]], "Mask"),
  spec("guide", [["sections", "sections"]], [["sections", "sections"]], "Guide"),
]);
const recipe = (): Recipe => ({
  format: "waamflow/1", name: "t", description: "", inputs: {},
  nodes: [
    { id: "part", type: "mesh", params: {} },
    { id: "layers", type: "slice", params: {} },
    { id: "mask", type: "mask", params: {} },
  ],
  edges: [{ from: "part.mesh", to: "layers.mesh" }, { from: "layers.layers", to: "mask.layers" }],
  ui: { positions: { part: [0, 0], layers: [230, 0], mask: [460, 0] } },
});

describe("freeSpot", () => {
  const overlaps = (a: XY, b: XY) => Math.abs(a[0] - b[0]) < NODE_BOX[0] && Math.abs(a[1] - b[1]) < NODE_BOX[1];
  it("keeps the wanted spot when it is free", () => {
    expect(freeSpot([[0, 0]], [500, 0])).toEqual([500, 0]);
  });
  it("never lands on another node, and stays near the wanted spot", () => {
    const taken: XY[] = [[0, 0], [220, 0], [0, 140], [220, 140]];
    const p = freeSpot(taken, [0, 0]);
    expect(taken.some((t) => overlaps(t, p))).toBe(false);
    expect(Math.hypot(p[0], p[1])).toBeLessThanOrEqual(Math.hypot(440, 280) + 1e-9);
    // a dense 5×5 block: the spot found is outside it
    const block: XY[] = [];
    for (let i = 0; i < 5; i++) for (let j = 0; j < 5; j++) block.push([i * 220, j * 140]);
    const q = freeSpot(block, [440, 280]);
    expect(block.some((t) => overlaps(t, q))).toBe(false);
  });
  it("places repeated adds side by side without overlap", () => {
    const taken: XY[] = [[0, 0]];
    for (let k = 0; k < 12; k++) taken.push(freeSpot(taken, [0, 0]));
    for (let a = 0; a < taken.length; a++) for (let b = a + 1; b < taken.length; b++) expect(overlaps(taken[a], taken[b])).toBe(false);
  });
});

describe("autoWire", () => {
  it("wires the first compatible output into a free input", () => {
    const r = recipe();
    r.nodes.push({ id: "guide", type: "guide", params: {} });
    const { recipe: w, edge } = autoWire(cat, r, "mask", "guide");
    expect(edge).toEqual({ from: "mask.sections", to: "guide.sections" });
    expect(w.edges).toHaveLength(3);
  });
  it("leaves the recipe alone when no port fits or the input is taken", () => {
    const r = recipe();
    r.nodes.push({ id: "m2", type: "mesh", params: {} });
    expect(autoWire(cat, r, "mask", "m2").edge).toBeNull(); // mesh has no input
    expect(autoWire(cat, r, "part", "layers").edge).toBeNull(); // layers.mesh is already wired
    expect(autoWire(cat, r, "mask", "part").recipe).toBe(r);
  });
});

describe("deleting is one step", () => {
  it("removeEdges returns the same recipe when nothing is removed", () => {
    const r = recipe();
    const without = removeNodes(r, new Set(["layers"]));
    expect(without.edges).toEqual([]);
    expect(removeEdges(without, new Set(["part.mesh->layers.mesh"]))).toBe(without);
    expect(removeEdges(r, new Set(["part.mesh->layers.mesh"])).edges).toHaveLength(1);
  });
});

describe("drafts", () => {
  const store = () => {
    const m = new Map<string, string>();
    return {
      getItem: (k: string) => m.get(k) ?? null, setItem: (k: string, v: string) => void m.set(k, v), removeItem: (k: string) => void m.delete(k),
      clear: () => m.clear(), key: () => null, get length() { return m.size; },
    } as Storage;
  };
  it("round-trips recipe, XML draft and tab per recipe; the unsaved recipe has its own key", () => {
    const s = store();
    const r = recipe();
    expect(writeDraft(s, "a", { recipe: r, xml: "<parameters/>", tab: "params", savedAt: 1000 })).toBeNull();
    writeDraft(s, null, { recipe: { ...r, name: "new" }, xml: null, tab: "graph", savedAt: 2000 });
    expect(readDraft(s, "a")).toEqual({ recipe: r, xml: "<parameters/>", tab: "params", savedAt: 1000 });
    expect(readDraft(s, null)?.recipe.name).toBe("new");
    expect(readDraft(s, "b")).toBeNull();
    expect(draftKey("a")).not.toBe(draftKey(null));
    clearDraft(s, "a");
    expect(readDraft(s, "a")).toBeNull();
    expect(readDraft(s, null)).not.toBeNull();
  });
  it("ignores what is not a draft", () => {
    const s = store();
    s.setItem(draftKey("x"), "{not json");
    s.setItem(draftKey("y"), JSON.stringify({ recipe: { nodes: "no" }, savedAt: 1 }));
    expect(readDraft(s, "x")).toBeNull();
    expect(readDraft(s, "y")).toBeNull();
  });
  it("reports a full storage instead of throwing", () => {
    const s = store();
    s.setItem = () => {
      throw new Error("QuotaExceededError");
    };
    expect(writeDraft(s, "a", { recipe: recipe(), xml: null, tab: "graph", savedAt: 1 })).toMatch(/could not be kept.*QuotaExceeded.*save/);
  });
  it("differs only when recipe or XML differ from the saved state", () => {
    const r = recipe();
    expect(draftDiffers({ recipe: r, xml: null, tab: "graph", savedAt: 1 }, recipe(), "<x/>")).toBe(false);
    expect(draftDiffers({ recipe: r, xml: "<x/>", tab: "graph", savedAt: 1 }, recipe(), "<x/>")).toBe(false);
    expect(draftDiffers({ recipe: r, xml: "<y/>", tab: "graph", savedAt: 1 }, recipe(), "<x/>")).toBe(true);
    expect(draftDiffers({ recipe: { ...r, nodes: [] }, xml: null, tab: "graph", savedAt: 1 }, recipe(), null)).toBe(true);
  });
  it("URL: graph and tab round-trip; the graph tab is the default", () => {
    expect(placeSearch({ graph: "mpp cross", tab: "mask" })).toBe("?graph=mpp+cross&tab=mask");
    expect(parsePlace("?graph=mpp+cross&tab=mask")).toEqual({ graph: "mpp cross", tab: "mask" });
    expect(placeSearch({ graph: "g", tab: "graph" })).toBe("?graph=g");
    expect(placeSearch({ graph: null, tab: "graph" })).toBe("");
    expect(parsePlace("")).toEqual({ graph: null, tab: null });
  });
});

describe("problems", () => {
  const w = (seq: number, node: string | null, message: string, layer: number | null = null, section: string | null = null) =>
    ({ seq, kind: "warning", node, message, layer, section, run_id: "r", t: 0 }) as never;
  it("collects errors first, drops repeats, counts per node with the messages", () => {
    const ps = collectProblems([w(1, "zone", "no values for bs2/A", 4, "bs2/A"), w(2, "zone", "no values for bs2/A", 4, "bs2/A"), w(3, "mask", "tiny region", 5)], [
      { message: "type mismatch", node: "strategy" }, null,
    ]);
    expect(ps.map((p) => [p.severity, p.node, p.layer])).toEqual([["error", "strategy", null], ["warning", "zone", 4], ["warning", "mask", 5]]);
    const by = problemsByNode(ps);
    expect(by.get("zone")).toEqual({ errors: 0, warnings: 1, text: "warning · layer 4 · bs2/A: no values for bs2/A" });
    expect(by.get("strategy")?.errors).toBe(1);
    expect(by.has("post")).toBe(false);
  });
});

describe("node search", () => {
  it("ranks title/type prefixes before substrings and descriptions", () => {
    expect(searchNodes([...cat.values()], "slice").map((s) => s.type)).toEqual(["slice", "fan-slice"]);
    expect(searchNodes([...cat.values()], "MAS").map((s) => s.type)).toEqual(["mask"]);
    expect(searchNodes([...cat.values()], "zzz")).toEqual([]);
    expect(searchNodes([...cat.values()], "")).toHaveLength(5);
  });
});

describe("frames", () => {
  it("frame the selection, move it with its nodes, remove it", () => {
    const { recipe: r, id } = addFrame(recipe(), new Set(["layers", "mask"]), "slicing");
    const f = framesOf(r)[0];
    expect(id).toBe("f1");
    expect(f.x).toBeLessThanOrEqual(230);
    expect(f.x + f.w).toBeGreaterThanOrEqual(460 + NODE_BOX[0]);
    expect(nodesInFrame(r, f)).toEqual(["layers", "mask"]);
    const m = moveFrame(r, id, [f.x + 100, f.y - 40]);
    expect(m.ui!.positions).toEqual({ part: [0, 0], layers: [330, -40], mask: [560, -40] });
    expect(framesOf(m)[0]).toMatchObject({ x: f.x + 100, y: f.y - 40, w: f.w, h: f.h });
    expect(moveFrame(m, id, [f.x + 100, f.y - 40])).toBe(m);
    expect(framesOf(removeFrames(m, new Set([id])))).toEqual([]);
    expect(addFrame(r, new Set(), "empty", [10, 20]).id).toBe("f2");
  });
});
