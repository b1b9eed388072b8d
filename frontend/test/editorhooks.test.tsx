// @vitest-environment jsdom
// The hooks split out of MaskView, GraphEditor, Viewer3D and ParamsEditor (#27 item 6): which node
// the canvas shows, the preview in layer coordinates, the canvas's node edits, the wire colours
// and connection rules, the 3D panel's layer range and per-recipe choices, and where a server
// error points in the parameter table.
import { afterEach, describe, expect, it, vi } from "vitest";
import type { NodeSpec, Preview, Recipe } from "../src/api/types";
import { catalogMap } from "../src/graph/recipe";
import { useConnectionRules, useFlowEdges } from "../src/graph/useGraphEditor";
import { useCanvasEdits, useLayerCoords, useNodeEdit, usePreviewNodes, useReplanLatency, type EditsCtx } from "../src/mask/useMaskView";
import type { MaskParams } from "../src/mask/edits";
import { useLayerSync, usePanelChoices } from "../src/viewer/useViewer3D";
import type { ViewerState } from "../src/viewer/api";
import { errAt, serverCell, useParsedDoc, useTreeSelection } from "../src/xml/useParamsEditor";
import { act, renderHook } from "./renderHook";

const port = (name: string, type: string, color = "#000") => ({ name, type, description: "", optional: false, color });
const spec = (type: string, inputs: [string, string][], outputs: [string, string, string?][]): NodeSpec => ({
  type, title: type, category: "c", description: "", version: "1", per_layer: false,
  inputs: inputs.map(([n, t]) => port(n, t)), outputs: outputs.map(([n, t, c]) => port(n, t, c)),
  params_schema: { type: "object", properties: {} },
});
const cat = catalogMap([
  spec("mesh", [], [["mesh", "mesh", "#111111"]]),
  spec("slice", [["mesh", "mesh"]], [["layers", "layers", "#222222"]]),
  spec("mask", [["layers", "layers"]], [["sections", "sections", "#333333"]]),
  spec("guide", [["sections", "sections"]], [["sections", "sections"]]),
  spec("zone", [["sections", "sections"]], [["toolpath", "toolpath"]]),
]);
const recipe: Recipe = {
  format: "waamflow/1", name: "t", description: "", inputs: {},
  nodes: [
    { id: "part", type: "mesh", params: {} },
    { id: "layers", type: "slice", params: {} },
    { id: "mask", type: "mask", params: { masks: [{ id: "bs1", from_layer: 0, sections: [{ id: "A", curve: [[0, 0], [9, 0], [9, 9]] }] }] } },
    { id: "guide", type: "guide", params: { guides: { "bs1/A": [[0, 1], [9, 1]] } } },
    { id: "zone", type: "zone", params: { sections: { "bs1/A": { end_length: 4, split_points: [[1, 1], [2, 2]] } } } },
  ],
  edges: [
    { from: "part.mesh", to: "layers.mesh" }, { from: "layers.layers", to: "mask.layers" },
    { from: "mask.sections", to: "guide.sections" }, { from: "guide.sections", to: "zone.sections" },
  ],
};

afterEach(() => vi.restoreAllMocks());

describe("mask view hooks", () => {
  it("usePreviewNodes: the zone node by default, its upstream MPP nodes, ghosts from the slice", () => {
    const { result, rerender } = renderHook((pv: string | null) => usePreviewNodes(recipe, cat, pv), null as string | null);
    expect(result.current.previewable.map((n) => n.id)).toEqual(["layers", "mask", "guide", "zone"]);
    expect(result.current.nodes.preview?.id).toBe("zone");
    expect(result.current.nodes.mask?.id).toBe("mask");
    expect(result.current.layersSource).toBe("layers");
    rerender("mask"); // a guide downstream of the mask is not the mask's
    expect(result.current.nodes.guide).toBeUndefined();
    expect(result.current.nodes.mask?.id).toBe("mask");
  });
  it("useLayerCoords: toolpath and preflight points into a framed layer's coordinates; the mark only on its layer", () => {
    // frame (4×4, rows): origin (10, 0, 0), layer x axis = world y, layer y axis = −world x
    const frame = [[0, -1, 0, 10], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]];
    const data = { layer: { frame }, paths: [{ key: "k", points: [[10, 5, 0], [12, 5, 0]] }] } as unknown as Preview;
    const starts = { here: [[10, 3]], below: [[10, 3.5]], radius: 1 };
    const mark = { layer: 2, point: [11, 0], section: null, draw: false, message: "", seq: 1 };
    const { result, rerender } = renderHook((layer: number) => useLayerCoords(data, starts, mark, layer), 2 as number);
    const pts = result.current.shown!.paths[0].points.map((q) => [q[0], q[1]].map((v) => Math.round(v * 1e9) / 1e9 + 0));
    expect(pts).toEqual([[5, 0], [5, -2]]);
    expect(result.current.starts!.here[0].slice(0, 2).map((v) => Math.round(v * 1e9) / 1e9 + 0)).toEqual([3, 0]);
    expect(result.current.starts!.stacked).toEqual([true]); // 0.5 mm from one below, radius 1 mm
    expect(result.current.markPoint!.slice(0, 2).map((v) => Math.round(v * 1e9) / 1e9 + 0)).toEqual([0, -1]);
    rerender(3);
    expect(result.current.markPoint).toBeNull();
  });
  it("useCanvasEdits: a self-crossing curve is refused, a curve adds section B, removing A forgets it in guide and zone", () => {
    let r = recipe;
    const onEdit = vi.fn((f: (x: Recipe) => Recipe) => void (r = f(r)));
    const onMessage = vi.fn();
    const onCurveAdded = vi.fn();
    const editStarted = { current: null as number | null };
    const { result } = renderHook(() => {
      const edit = useNodeEdit(onEdit, onMessage, editStarted);
      const nodes = usePreviewNodes(recipe, cat, null).nodes;
      const ctx: EditsCtx = { nodes, maskParams: recipe.nodes[2].params as MaskParams, layer: 0, edit, onEdit, onMessage, editStarted, onCurveAdded };
      return useCanvasEdits(ctx);
    }, undefined);
    result.current.addCurve([[0, 0], [10, 10], [10, 0], [0, 10]]);
    expect(onMessage).toHaveBeenCalledWith("the curve crosses itself: draw a simple closed curve");
    expect(onEdit).not.toHaveBeenCalled();
    result.current.addCurve([[20, 0], [30, 0], [30, 10]]);
    expect(onCurveAdded).toHaveBeenCalledWith("bs1/B");
    expect(editStarted.current).not.toBeNull();
    const masks = (r.nodes[2].params as MaskParams).masks!;
    expect(masks[0].sections.map((s) => s.id)).toEqual(["A", "B"]);
    result.current.removeSplit("bs1/A", 0);
    expect((r.nodes[4].params.sections as Record<string, { split_points: number[][] }>)["bs1/A"].split_points).toEqual([[2, 2]]);
    result.current.removeSection("bs1/A");
    expect((r.nodes[2].params as MaskParams).masks![0].sections.map((s) => s.id)).toEqual(["B"]);
    expect(r.nodes[3].params.guides).toEqual({});
    expect(r.nodes[4].params.sections).toEqual({});
  });
  it("useReplanLatency: edit → the frame after the preview, pushed to window.__waamflowReplanMs", async () => {
    window.__waamflowReplanMs = [];
    const t0 = performance.now() - 40;
    const { result, unmount } = renderHook(() => useReplanLatency({ data: {} as Preview, editT0: t0 }), undefined);
    await act(() => new Promise((res) => requestAnimationFrame(() => setTimeout(res, 0))));
    expect(window.__waamflowReplanMs.length).toBe(1);
    expect(window.__waamflowReplanMs[0]).toBeGreaterThanOrEqual(40);
    expect(result.current).toBe(window.__waamflowReplanMs[0]);
    unmount();
  });
});

describe("graph editor hooks", () => {
  it("useFlowEdges: wires coloured by the source port, animated into a running node", () => {
    const { result } = renderHook(() => useFlowEdges(recipe, cat, { mask: { state: "running" } as never }), undefined);
    expect(result.current.length).toBe(4);
    expect(result.current[0].style).toEqual({ stroke: "#111111", strokeWidth: 2 });
    expect(result.current[1]).toMatchObject({ source: "layers", sourceHandle: "layers", target: "mask", targetHandle: "layers", animated: true });
    expect(result.current[3].style!.stroke).toBe("#000");
  });
  it("useConnectionRules: a type mismatch is refused with its reason; a valid wire is one edit", () => {
    const onChange = vi.fn();
    const onMessage = vi.fn();
    const { result } = renderHook(() => useConnectionRules(cat, recipe, onChange, onMessage), undefined);
    const bad = { source: "part", sourceHandle: "mesh", target: "zone", targetHandle: "sections" };
    expect(result.current.valid(bad)).toBe(false);
    expect(result.current.reasonOf(bad)).toBe("type mismatch: mesh → sections");
    result.current.onConnect(bad);
    expect(onMessage).toHaveBeenCalledWith("type mismatch: mesh → sections");
    expect(onChange).not.toHaveBeenCalled();
    result.current.onConnect({ source: "mask", sourceHandle: "sections", target: "zone", targetHandle: "sections" });
    expect(onChange).toHaveBeenCalledTimes(1);
  });
});

describe("3D panel hooks", () => {
  const st = (lo: number, hi: number, view: { layer_lo: number; layer_hi: number }) => ({ layers: { lo, hi }, view } as unknown as ViewerState);
  it("useLayerSync: all, up to and only the canvas layer, a clamped custom range; sends only a changed range", () => {
    const send = vi.fn(() => Promise.resolve());
    const s = st(0, 299, { layer_lo: 0, layer_hi: 299 });
    const { result, rerender } = renderHook((a: { mode: "all" | "upto" | "only" | "custom"; custom: [number, number] }) => useLayerSync(s, a.mode, 150, a.custom, send), { mode: "all", custom: [0, 0] });
    expect([result.current.lo, result.current.hi]).toEqual([0, 299]);
    expect(send).not.toHaveBeenCalled(); // the viewer already shows 0–299
    rerender({ mode: "upto", custom: [0, 0] });
    expect([result.current.lo, result.current.hi]).toEqual([0, 150]);
    expect(send).toHaveBeenLastCalledWith({ layer_lo: 0, layer_hi: 150 });
    rerender({ mode: "only", custom: [0, 0] });
    expect([result.current.lo, result.current.hi]).toEqual([150, 150]);
    rerender({ mode: "custom", custom: [280, 400] });
    expect([result.current.lo, result.current.hi]).toEqual([280, 299]);
  });
  it("usePanelChoices: each recipe keeps its own range choice across unmounts", () => {
    const a = renderHook((k: string) => usePanelChoices(k), "rec-a" as string);
    act(() => a.result.current.setRangeMode("only"));
    act(() => a.result.current.setCustom([3, 9]));
    a.rerender("rec-b");
    expect(a.result.current.rangeMode).toBe("all");
    a.unmount();
    const b = renderHook((k: string) => usePanelChoices(k), "rec-a");
    expect(b.result.current.rangeMode).toBe("only");
    expect(b.result.current.custom).toEqual([3, 9]);
  });
});

describe("parameter editor hooks", () => {
  const XML = `<?xml version="1.0"?><parameters version="1"><layer index="0" z="1.5"><section id="bs1/A"><zone id="start" color="#f00"><current unit="A">200</current></zone></section><section id="bs1/B"/></layer><layer index="1" z="3"/></parameters>`;
  it("useParsedDoc / useTreeSelection: the first layer's first section is shown; a parse error is kept", () => {
    const { result, rerender } = renderHook((t: string | null) => {
      const parsed = useParsedDoc(t);
      const [sel] = useTreeSelection(parsed.doc);
      return { parsed, sel };
    }, XML as string | null);
    expect(result.current.parsed.doc!.layers.length).toBe(2);
    expect(result.current.sel).toEqual({ layer: 0, section: "bs1/A" });
    rerender("<parameters><layer");
    expect(result.current.parsed.doc).toBeNull();
    expect(result.current.parsed.error).toBeTruthy();
    rerender(null);
    expect(result.current.parsed).toEqual({ doc: null, error: null });
  });
  it("serverCell / errAt: layer and section must match; zone and parameter from the field or the message", () => {
    const err = { message: "zone 'start': current 2000 A above 1000", layer: 0, section: "bs1/A" };
    expect(serverCell(err, 0, "bs1/A", "start", "current")).toBe(true);
    expect(serverCell(err, 0, "bs1/A", "end", "current")).toBe(false);
    expect(serverCell(err, 0, "bs1/A", "start", "travel_speed")).toBe(false);
    expect(serverCell(err, 1, "bs1/A", "start", "current")).toBe(false);
    expect(serverCell({ ...err, message: "bad", field: "travel_speed", zone: "end" }, 0, "bs1/A", "end", "travel_speed")).toBe(true);
    expect(serverCell(null, 0, "bs1/A", "start", "current")).toBe(false);
    expect(errAt(err, 0)).toBe(true);
    expect(errAt(err, 0, "bs1/B")).toBe(false);
    expect(errAt({ message: "m", layer: 0 }, 0, "bs1/B")).toBe(true); // no section named: the whole layer
    expect(errAt(err, 1)).toBe(false);
  });
});
