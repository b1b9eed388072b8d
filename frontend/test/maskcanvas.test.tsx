// @vitest-environment jsdom
// The 2D mask canvas's hooks and arithmetic (#27: MaskCanvas / MaskView had no unit test): screen
// px ↔ layer mm, fit / zoom / pan of the view, hit-testing of paths and split points, drawing a
// mask polygon (snapped, closed on its first point), dragging a vertex or a curve, and the keys
// (nudge, drop a vertex, pick vertices / sections, Esc / Enter).
import { afterEach, describe, expect, it, vi, type Mock } from "vitest";
import type { PreviewPath } from "../src/api/types";
import type { Mask } from "../src/mask/edits";
import type { Pt } from "../src/mask/geom";
import {
  curveOf, dragCurve, fitView, layerToScreen, moveVertex, nearestPath, panView, parseIndexed, pixelSize, readHit, screenToLayer,
  splitTarget, stepSection, stepVertex, zoomAbout, type Affine,
} from "../src/mask/canvasModel";
import { useCurveDrag, useDraft, useMeasure, useSnap, useVertexSel, type CanvasEdits, type Tool, type ToolProps } from "../src/mask/useCanvasTools";
import { useCanvasKeys } from "../src/mask/useCanvasKeys";
import { useSvgView } from "../src/mask/useSvgView";
import { act, renderHook } from "./renderHook";

/** A 100 × 50 mm view drawn in an 800 × 400 px box at (10, 20): 8 px per mm, SVG y = −layer y. */
const VIEW = { x: -50, y: -25, w: 100, h: 50 };
const RECT = { left: 10, top: 20, width: 800, height: 400 };
const CTM: Affine = { a: 8, b: 0, c: 0, d: 8, e: 10 + 50 * 8, f: 20 + 25 * 8 };

const path = (key: string, points: number[][]): PreviewPath =>
  ({ key, points, zone: points.map(() => "1"), arc: points.map(() => true), speed: points.map(() => 6) }) as unknown as PreviewPath;

const MASK: Mask = {
  id: "bs1",
  from_layer: 0,
  sections: [
    { id: "A", curve: [[0, 0], [10, 0], [10, 10], [0, 10]] },
    { id: "B", curve: [[20, 0], [30, 0], [30, 10]] },
  ],
} as Mask;

function edits(): { [K in keyof CanvasEdits]: Mock<CanvasEdits[K]> } {
  return { addCurve: vi.fn(), setCurve: vi.fn(), setGuide: vi.fn(), addSplit: vi.fn(), removeSplit: vi.fn(), removeSection: vi.fn() };
}

describe("screen px ↔ layer mm", () => {
  it("screenToLayer inverts the CTM and flips y; layerToScreen is its inverse", () => {
    // the box's centre is the view's centre: layer (0, 0)
    expect(screenToLayer(CTM, 410, 220)).toEqual([0, -0]);
    // 80 px right, 40 px up = 10 mm right, 5 mm up (layer y up)
    expect(screenToLayer(CTM, 490, 180)).toEqual([10, 5]);
    expect(layerToScreen(CTM, [10, 5])).toEqual([490, 180]);
    const rot: Affine = { a: 0, b: 2, c: -2, d: 0, e: 100, f: 50 }; // rotated 90° and scaled: still exact
    const q = screenToLayer(rot, 130, 70);
    expect(layerToScreen(rot, q).map((v) => Math.round(v * 1e9) / 1e9)).toEqual([130, 70]);
    expect(screenToLayer({ a: 0, b: 0, c: 0, d: 0, e: 0, f: 0 }, 5, 5)).toEqual([0, 0]); // singular: no throw
  });
  it("pixelSize is mm per px on the letter-boxed axis", () => {
    expect(pixelSize(VIEW, RECT)).toBe(0.125);
    expect(pixelSize({ ...VIEW, h: 100 }, RECT)).toBe(0.25); // taller than the box: y decides
  });
  it("fitView frames the points with 8 % + 1 mm margin at the box's aspect", () => {
    const v = fitView({ minX: 0, minY: 0, maxX: 100, maxY: 20 }, 2);
    // pad = 100 · 0.08 + 1 = 9: 118 wide; 38 high widened to 118 / 2 = 59
    expect(v.w).toBeCloseTo(118, 9);
    expect(v.h).toBeCloseTo(59, 9);
    expect(v.x).toBeCloseTo(-9, 9);
    expect(v.y).toBeCloseTo(-10 - 29.5, 9); // centred on layer y 10 → SVG y −10
    expect(fitView({ minX: 0, minY: 0, maxX: 10, maxY: 10 }, null).w).toBeCloseTo(13.6, 9); // pad 1.8
  });
  it("zoomAbout keeps the layer point under the cursor; panView follows the pointer", () => {
    const v = zoomAbout(VIEW, RECT, 210, 120, 200); // k = e^0.3 about the px at a quarter of the box
    expect(v.w).toBeCloseTo(100 * Math.exp(0.3), 9);
    const under = (view: typeof VIEW) => [view.x + ((210 - RECT.left) / RECT.width) * view.w, view.y + ((120 - RECT.top) / RECT.height) * view.h];
    expect(under(v)[0]).toBeCloseTo(under(VIEW)[0], 9);
    expect(under(v)[1]).toBeCloseTo(under(VIEW)[1], 9);
    const p = panView(VIEW, [100, 100], [180, 60], RECT.width); // 80 px right, 40 px up
    expect(p).toEqual({ x: -60, y: -20, w: 100, h: 50 });
  });
  it("useSvgView: toWorld and pxSize from the element, fitTo at its aspect, wheel zoom", () => {
    const svg = { getBoundingClientRect: () => RECT, getScreenCTM: () => CTM } as unknown as SVGSVGElement;
    const { result } = renderHook(() => useSvgView({ current: svg }), undefined);
    expect(result.current.pxSize()).toBe(0.1); // no view yet
    expect(result.current.toWorld({ clientX: 490, clientY: 180 })).toEqual([10, 5]);
    act(() => result.current.fitTo([[0, 0], [100, 20]]));
    expect(result.current.view!.w).toBeCloseTo(118, 9);
    expect(result.current.view!.h).toBeCloseTo(59, 9);
    expect(result.current.pxSize()).toBeCloseTo(118 / 800, 12);
    act(() => result.current.onWheel({ clientX: 410, clientY: 220, deltaY: -200 } as never));
    expect(result.current.view!.w).toBeCloseTo(118 * Math.exp(-0.3), 9);
  });
});

describe("hit-testing", () => {
  const paths = [path("bs1/A", [[0, 0], [10, 0]]), path("bs1/B", [[0, 5], [10, 5]]), path("bs1/C", [[3, 3]])];
  it("nearestPath skips single points; splitTarget snaps to the path within the tolerance, else the fallback's", () => {
    expect(nearestPath(paths, [4, 1])!.key).toBe("bs1/A");
    expect(nearestPath(paths, [4, 3.9])!.key).toBe("bs1/B");
    expect(splitTarget(paths, [4.12345, 1], 1.5, null)).toEqual({ key: "bs1/A", point: [4.123, 0] });
    // 2 mm away with a 1.5 mm tolerance: on the selected section's path instead
    expect(splitTarget(paths, [4, -2], 1.5, "bs1/B")).toEqual({ key: "bs1/B", point: [4, 5] });
    expect(splitTarget(paths, [4, -2], 1.5, null)).toBeNull();
  });
  it("readHit / parseIndexed read what the drawing marks (keys may hold ':')", () => {
    const el = { getAttribute: (n: string) => ({ "data-vertex": "bs1/A:3" })[n] ?? null };
    expect(readHit(el)).toEqual({ vertex: "bs1/A:3", curve: null, split: null, section: null });
    expect(parseIndexed("m:2/A:12")).toEqual({ key: "m:2/A", index: 12 });
  });
  it("stepVertex / stepSection wrap both ways and start from the ends", () => {
    expect(stepVertex(4, null, 1)).toBe(0);
    expect(stepVertex(4, null, -1)).toBe(3);
    expect(stepVertex(4, 3, 1)).toBe(0);
    expect(stepVertex(4, 0, -1)).toBe(3);
    expect(stepSection(["a", "b", "c"], null, 1)).toBe("a");
    expect(stepSection(["a", "b", "c"], null, -1)).toBe("c");
    expect(stepSection(["a", "b", "c"], "c", 1)).toBe("a");
    expect(stepSection(["a", "b", "c"], "a", -1)).toBe("c");
  });
});

describe("drawing and editing curves", () => {
  afterEach(() => vi.restoreAllMocks());
  const draftProps = (tool: Tool, e: CanvasEdits, selected: string | null = null) => ({ tool, selected, edits: e });

  it("a mask polygon: points added at µm, closed by a click on the first point within the radius", () => {
    const e = edits();
    const h = renderHook((p: ReturnType<typeof draftProps>) => useDraft(p), draftProps("curve", e));
    act(() => h.result.current.click([0.00049, 0], 0.8, 1));
    act(() => h.result.current.click([10, 0.1234567], 0.8, 1));
    act(() => h.result.current.click([10, 10], 0.8, 1));
    expect(h.result.current.draft).toEqual([[0, 0], [10, 0.123], [10, 10]]);
    act(() => h.result.current.click([0.5, 0.5], 0.8, 1)); // 0.71 mm from the first point: closes
    expect(e.addCurve).toHaveBeenCalledTimes(1);
    expect(e.addCurve.mock.calls[0][0]).toEqual([[0, 0], [10, 0.123], [10, 10]]);
    expect(h.result.current.draft).toEqual([]);
  });
  it("a 4th point just outside the radius is added; Enter (finish) with < 3 points adds nothing; a tool change clears", () => {
    const e = edits();
    const h = renderHook((p: ReturnType<typeof draftProps>) => useDraft(p), draftProps("curve", e));
    for (const q of [[0, 0], [10, 0], [10, 10], [0.6, 0.6]] as Pt[]) act(() => h.result.current.click(q, 0.8, 1));
    expect(h.result.current.draft.length).toBe(4); // 0.85 mm > 0.8
    act(() => h.rerender(draftProps("guide", e)));
    expect(h.result.current.draft).toEqual([]);
    act(() => h.rerender(draftProps("curve", e)));
    act(() => h.result.current.click([1, 1], 0.8, 1));
    act(() => h.result.current.click([2, 1], 0.8, 1));
    act(() => h.result.current.finish());
    expect(e.addCurve).not.toHaveBeenCalled();
    expect(h.result.current.draft).toEqual([]);
  });
  it("a guide is finished by a double click and goes to the selected section", () => {
    const e = edits();
    const h = renderHook((p: ReturnType<typeof draftProps>) => useDraft(p), draftProps("guide", e, "bs1/A"));
    act(() => h.result.current.click([0, 0], 0.8, 1));
    act(() => h.result.current.click([5, 5], 0.8, 1));
    act(() => h.result.current.click([5, 5], 0.8, 2));
    expect(e.setGuide).toHaveBeenCalledWith("bs1/A", [[0, 0], [5, 5]]);
  });
  it("snapping: to a layer or mask vertex within 8 px, else to the grid; without vertex snapping only the grid", () => {
    const layer = { polygons: [{ exterior: [[0, 0], [50, 0], [50, 50]], holes: [] }] } as never;
    const px = () => 0.1; // 8 px = 0.8 mm
    const h = renderHook((p: { snapVertices: boolean }) => useSnap({ ...p, mask: MASK, grid: 1 }, layer, px), { snapVertices: true });
    expect(h.result.current([49.5, 0.3])).toEqual({ point: [50, 0], kind: "vertex" });
    expect(h.result.current([29.6, 9.7])).toEqual({ point: [30, 10], kind: "vertex" }); // a mask curve's vertex
    expect(h.result.current([24.4, 3.6])).toEqual({ point: [24, 4], kind: "grid" });
    h.rerender({ snapVertices: false });
    expect(h.result.current([49.5, 0.3])).toEqual({ point: [50, 0], kind: "grid" });
    expect(h.result.current([49.3, 0.3]).point).toEqual([49, 0]);
  });
  it("dragging a vertex or a curve writes one setCurve on drop, none when nothing moved", () => {
    expect(moveVertex([[0, 0], [1, 1]], 1, [2.00049, 3])).toEqual([[0, 0], [2, 3]]);
    expect(dragCurve([[0, 0], [1, 0]], [0, 0], [2.4, 0.6], [2.3, 0.7], 1)).toEqual([[2, 1], [3, 1]]); // whole grid steps
    expect(dragCurve([[0, 0], [1, 0]], [0, 0], [2.4, 0.6], [2.3, 0.7], 0)).toEqual([[2.3, 0.7], [3.3, 0.7]]);
    const e = edits();
    const h = renderHook((p: { mask: Mask }) => useCurveDrag({ grid: 1, mask: p.mask, edits: e }), { mask: MASK });
    h.result.current.drag.current = { kind: "vertex", key: "bs1/A", index: 2, curve: curveOf(MASK, "bs1/A")! };
    act(() => void h.result.current.move([12.2, 11.9], [12, 12]));
    expect(h.result.current.dragged).toEqual({ key: "bs1/A", curve: [[0, 0], [10, 0], [12, 12], [0, 10]] });
    act(() => h.result.current.end());
    expect(e.setCurve).toHaveBeenCalledWith("bs1/A", [[0, 0], [10, 0], [12, 12], [0, 10]]);
    h.result.current.drag.current = { kind: "curve", key: "bs1/B", start: [20, 0], curve: curveOf(MASK, "bs1/B")! };
    act(() => void h.result.current.move([20.2, 0.1], [20, 0])); // less than a grid step: no move
    act(() => h.result.current.end());
    expect(e.setCurve).toHaveBeenCalledTimes(1);
    expect(h.result.current.dragged).toBeNull();
  });
  it("measure: A, then B follows the pointer until clicked; a third click starts again", () => {
    const h = renderHook((t: Tool) => useMeasure(t), "measure" as Tool);
    act(() => h.result.current.click([0, 0]));
    act(() => h.result.current.hover([3, 4]));
    expect(h.result.current.result!.distance).toBe(5);
    act(() => h.result.current.click([0, -2]));
    act(() => h.result.current.hover([9, 9])); // B is set: the pointer no longer moves it
    expect(h.result.current.result).toEqual({ distance: 2, angleDeg: -90, dx: 0, dy: -2 });
    act(() => h.result.current.click([1, 1]));
    expect(h.result.current.ab).toEqual({ a: [1, 1], b: null });
    h.rerender("select");
    expect(h.result.current.ab).toBeNull();
  });
});

describe("canvas keys", () => {
  afterEach(() => vi.restoreAllMocks());
  function setup(selected: string | null, grid = 1) {
    const e = edits();
    const props: ToolProps = {
      tool: "select", setTool: vi.fn(), grid, snapVertices: true, mask: MASK, selected, setSelected: vi.fn(), edits: e, onLayerStep: vi.fn(),
    };
    const fit = vi.fn();
    const h = renderHook(() => {
      const draft = useDraft(props);
      const meas = useMeasure(props.tool);
      const [vertexSel, setVertexSel] = useVertexSel(props.selected);
      useCanvasKeys(props, { draft, meas, vertexSel, setVertexSel, fit });
      return { draft, vertexSel };
    }, undefined);
    const key = (k: string, o: KeyboardEventInit = {}) => {
      const ev = new KeyboardEvent("keydown", { key: k, cancelable: true, ...o });
      act(() => void window.dispatchEvent(ev));
      return ev.defaultPrevented;
    };
    return { props, e, h, key, fit };
  }
  it("] picks vertices in turn, arrows nudge the picked one by the grid (×10 with Shift)", () => {
    const { props, e, h, key } = setup("bs1/A", 0.5);
    expect(key("]")).toBe(true);
    expect(h.result.current.vertexSel).toEqual({ key: "bs1/A", index: 0 });
    key("]");
    expect(h.result.current.vertexSel).toEqual({ key: "bs1/A", index: 1 });
    expect(props.setTool).toHaveBeenCalledWith("select");
    key("ArrowUp");
    expect(e.setCurve).toHaveBeenLastCalledWith("bs1/A", [[0, 0], [10, 0.5], [10, 10], [0, 10]]);
    key("ArrowLeft", { shiftKey: true });
    expect(e.setCurve).toHaveBeenLastCalledWith("bs1/A", [[0, 0], [5, 0], [10, 10], [0, 10]]);
  });
  it("Delete drops the picked vertex (the pick moves to the last when it was last), never below 3", () => {
    const { e, h, key } = setup("bs1/A");
    key("[");
    expect(h.result.current.vertexSel).toEqual({ key: "bs1/A", index: 3 });
    expect(key("Delete")).toBe(true);
    expect(e.setCurve).toHaveBeenCalledWith("bs1/A", [[0, 0], [10, 0], [10, 10]]);
    expect(h.result.current.vertexSel).toEqual({ key: "bs1/A", index: 2 });
    expect(e.removeSection).not.toHaveBeenCalled();
    const b = setup("bs1/B"); // 3 vertices: nothing dropped, and the section stays
    b.key("]");
    b.key("Backspace");
    expect(b.e.setCurve).not.toHaveBeenCalled();
    expect(b.e.removeSection).not.toHaveBeenCalled();
  });
  it("Delete without a picked vertex removes the section; Esc drops the vertex pick, then the selection", () => {
    const s = setup("bs1/A");
    s.key("Delete");
    expect(s.e.removeSection).toHaveBeenCalledWith("bs1/A");
    expect(s.props.setSelected).toHaveBeenCalledWith(null);
    const t = setup("bs1/A");
    t.key("]");
    t.key("Escape");
    expect(t.h.result.current.vertexSel).toBeNull();
    expect(t.props.setSelected).not.toHaveBeenCalled();
    t.key("Escape");
    expect(t.props.setSelected).toHaveBeenCalledWith(null);
  });
  it("} { select sections, PageUp / PageDown step the layer, letters pick tools; typing in a field and Ctrl are left alone", () => {
    const { props, key, fit } = setup(null);
    key("}");
    expect(props.setSelected).toHaveBeenLastCalledWith("bs1/A");
    key("{");
    expect(props.setSelected).toHaveBeenLastCalledWith("bs1/B");
    key("PageUp");
    key("PageDown");
    expect((props.onLayerStep as ReturnType<typeof vi.fn>).mock.calls).toEqual([[1], [-1]]);
    key("m");
    key("f");
    expect(props.setTool).toHaveBeenLastCalledWith("measure");
    expect(fit).toHaveBeenCalledTimes(1);
    expect(key("c", { ctrlKey: true })).toBe(false);
    expect(key("x")).toBe(false);
    const input = document.createElement("input");
    document.body.append(input);
    const ev = new KeyboardEvent("keydown", { key: "c", cancelable: true, bubbles: true });
    act(() => void input.dispatchEvent(ev));
    expect(ev.defaultPrevented).toBe(false);
    expect(props.setTool).toHaveBeenCalledTimes(1);
    input.remove();
  });
});
