/**
 * The 2D canvas's tool state, one hook per concern: the curve / guide being drawn (draft), the
 * measure tool's two points, the picked vertex, a curve or vertex being dragged, snapping, and the
 * pointer handlers that drive them by tool. The arithmetic is canvasModel's.
 */
import { useEffect, useMemo, useRef, useState, type PointerEvent as RPointerEvent, type RefObject } from "react";
import type { LayerJson, PreviewPath } from "../api/types";
import { dist, polygonVertices, snapPoint, type Pt } from "./geom";
import type { Mask } from "./edits";
import { measure, mm } from "./canvasTools";
import {
  curveChanged, curveOf, dragCurve, moveVertex, parseIndexed, readHit, roundPt, splitTarget, type Hit,
} from "./canvasModel";
import type { useSvgView } from "./useSvgView";

export type Tool = "select" | "curve" | "guide" | "split" | "measure";

export interface CanvasEdits {
  addCurve: (curve: Pt[]) => void;
  setCurve: (key: string, curve: Pt[]) => void;
  setGuide: (key: string, guide: Pt[]) => void;
  addSplit: (key: string, p: Pt) => void;
  removeSplit: (key: string, index: number) => void;
  removeSection: (key: string) => void;
}

/** What the tool hooks read of the canvas's props. */
export interface ToolProps {
  tool: Tool;
  setTool: (t: Tool) => void;
  grid: number;
  snapVertices: boolean;
  mask: Mask | undefined;
  selected: string | null;
  setSelected: (k: string | null) => void;
  edits: CanvasEdits;
  onLayerStep: (delta: number) => void;
}

export type Snap = (w: Pt) => ReturnType<typeof snapPoint>;

/** Snapping of a layer point: to the layer's and the mask's vertices within 8 px, else to the grid. */
export function useSnap(p: Pick<ToolProps, "snapVertices" | "mask" | "grid">, layer: LayerJson | null, pxSize: () => number): Snap {
  const vertices = useMemo(() => {
    const v = p.snapVertices ? polygonVertices(layer?.polygons ?? []) : [];
    const curves = p.snapVertices ? (p.mask?.sections.flatMap((s) => s.curve) ?? []) : [];
    return [...v, ...curves];
  }, [layer, p.mask, p.snapVertices]);
  return (w) => snapPoint(w, { vertices, radius: 8 * pxSize(), grid: p.grid });
}

/** The curve (≥ 3 points, closed on its first) or guide (≥ 2 points) being drawn; cleared when the tool changes. */
export function useDraft(p: Pick<ToolProps, "tool" | "selected" | "edits">) {
  const [draft, setDraft] = useState<Pt[]>([]);
  useEffect(() => setDraft([]), [p.tool]);
  const finish = () => {
    if (p.tool === "curve" && draft.length >= 3) p.edits.addCurve(draft);
    if (p.tool === "guide" && p.selected && draft.length >= 2) p.edits.setGuide(p.selected, draft);
    setDraft([]);
  };
  /** A click at the snapped point s: on the first point (within `closeRadius` mm) closes a curve,
   * a double click (`detail` ≥ 2) finishes, else the point (µm) is added. */
  const click = (s: Pt, closeRadius: number, detail: number) => {
    if (p.tool === "curve" && draft.length >= 3 && dist(s, draft[0]) <= closeRadius) {
      p.edits.addCurve(draft);
      setDraft([]);
    } else if (detail >= 2) finish();
    else setDraft((d) => [...d, roundPt(s)]);
  };
  return { draft, finish, click, clear: () => setDraft([]) };
}

/** The measure tool: first click A, second B (a third starts again); B follows the pointer until set. */
export function useMeasure(tool: Tool) {
  const [ab, setAB] = useState<{ a: Pt; b: Pt | null } | null>(null);
  const [hover, setHover] = useState<Pt | null>(null);
  useEffect(() => {
    if (tool !== "measure") setAB(null);
  }, [tool]);
  const b = ab ? (ab.b ?? hover) : null;
  return {
    ab,
    b,
    result: ab && b ? measure(ab.a, b) : null,
    click: (q: Pt) => setAB((m) => (!m || m.b ? { a: q, b: null } : { a: m.a, b: q })),
    hover: (q: Pt) => {
      if (ab && !ab.b) setHover(q);
    },
    clear: () => setAB(null),
  };
}

export type VertexSel = { key: string; index: number } | null;

/** The picked vertex (arrows nudge it, Delete drops it): dropped when another section is selected. */
export function useVertexSel(selected: string | null) {
  const [vertexSel, setVertexSel] = useState<VertexSel>(null);
  useEffect(() => setVertexSel((v) => (v && v.key === selected ? v : null)), [selected]);
  return [vertexSel, setVertexSel] as const;
}

type Drag =
  | { kind: "pan" }
  | { kind: "vertex"; key: string; index: number; curve: Pt[] }
  | { kind: "curve"; key: string; start: Pt; curve: Pt[] };

/** A pan, vertex or curve drag in progress; the dragged curve is shown until the recipe has it. */
export function useCurveDrag(p: Pick<ToolProps, "grid" | "mask" | "edits">) {
  const drag = useRef<Drag | null>(null);
  const [dragged, setDragged] = useState<{ key: string; curve: Pt[] } | null>(null);
  // Keep the dragged curve on screen until the recipe has it (no flicker back to the old one).
  useEffect(() => setDragged(null), [p.mask]);
  /** The pointer at w (s: snapped): the kind of the drag in progress, null when none is. */
  const move = (w: Pt, s: Pt): Drag["kind"] | null => {
    const d = drag.current;
    if (d?.kind === "vertex") setDragged({ key: d.key, curve: moveVertex(d.curve, d.index, s) });
    if (d?.kind === "curve") setDragged({ key: d.key, curve: dragCurve(d.curve, d.start, s, w, p.grid) });
    return d?.kind ?? null;
  };
  /** Drop: a curve that moved is written to the mask (one edit). */
  const end = () => {
    const d = drag.current;
    drag.current = null;
    if ((d?.kind === "vertex" || d?.kind === "curve") && dragged && curveChanged(d.curve, dragged.curve)) p.edits.setCurve(dragged.key, dragged.curve);
    setDragged(null);
  };
  return { drag, dragged, move, end };
}

type Sv = ReturnType<typeof useSvgView>;
type Tools = { draft: ReturnType<typeof useDraft>; meas: ReturnType<typeof useMeasure>; setVertexSel: (v: VertexSel) => void; curves: ReturnType<typeof useCurveDrag> };

/** A click of the select tool on a vertex, a curve, a split point or a section region. */
function selectDown(p: ToolProps, t: Tools, hit: Hit, w: Pt) {
  if (hit.vertex) {
    const { key, index } = parseIndexed(hit.vertex);
    t.setVertexSel({ key, index });
    const curve = curveOf(p.mask, key);
    if (curve) t.curves.drag.current = { kind: "vertex", key, index, curve };
    p.setSelected(key);
  } else if (hit.curve) {
    const curve = curveOf(p.mask, hit.curve);
    if (curve) t.curves.drag.current = { kind: "curve", key: hit.curve, start: w, curve };
    p.setSelected(hit.curve);
  } else if (hit.split) p.setSelected(parseIndexed(hit.split).key);
  else if (hit.section) p.setSelected(hit.section);
}

/** A click of the split tool: on a split point removes it, else adds one on the path (within 12 px). */
function splitDown(p: ToolProps, paths: readonly PreviewPath[], hit: Hit, w: Pt, px: number) {
  if (hit.split) {
    const { key, index } = parseIndexed(hit.split);
    p.edits.removeSplit(key, index);
    return;
  }
  const at = splitTarget(paths, w, 12 * px, p.selected ?? hit.section);
  if (!at) return;
  p.setSelected(at.key);
  p.edits.addSplit(at.key, at.point);
}

/** The canvas's pointer handlers: pan, select / drag, split, measure, draw (by tool). */
export function useCanvasPointer(p: ToolProps, sv: Sv, svgRef: RefObject<SVGSVGElement | null>, t: Tools, snap: Snap, paths: readonly PreviewPath[]) {
  const [cursor, setCursor] = useState<{ p: Pt; kind: string } | null>(null);
  const coordsRef = useRef<HTMLSpanElement>(null);
  const onPointerDown = (e: RPointerEvent<SVGSVGElement>) => {
    if (!sv.view) return;
    const w = sv.toWorld(e);
    const hit = readHit(e.target as SVGElement);
    svgRef.current!.setPointerCapture(e.pointerId);
    if (e.button === 1 || e.button === 2 || (p.tool === "select" && !hit.vertex && !hit.curve && !hit.split && !hit.section)) {
      t.curves.drag.current = { kind: "pan" };
      sv.startPan(e);
      if (p.tool === "select" && e.button === 0) p.setSelected(null);
      return;
    }
    if (e.button !== 0) return;
    if (p.tool === "measure") t.meas.click(snap(w).point);
    else if (p.tool === "select") selectDown(p, t, hit, w);
    else if (p.tool === "split") splitDown(p, paths, hit, w, sv.pxSize());
    else if (p.tool === "guide" && !p.selected) {
      if (hit.section) p.setSelected(hit.section);
    } else t.draft.click(snap(w).point, 8 * sv.pxSize(), e.detail);
  };
  const onPointerMove = (e: RPointerEvent<SVGSVGElement>) => {
    const w = sv.toWorld(e);
    // Cursor coordinates in layer mm, written straight into the HUD (no re-render per move).
    if (coordsRef.current) coordsRef.current.textContent = `x ${mm(w[0])}  y ${mm(w[1])} mm`;
    if (t.curves.drag.current?.kind === "pan") {
      sv.movePan(e);
      return;
    }
    if (t.curves.drag.current) {
      t.curves.move(w, snap(w).point);
      return;
    }
    if (p.tool === "curve" || p.tool === "guide" || p.tool === "measure") {
      const s = snap(w);
      setCursor({ p: s.point, kind: s.kind });
      if (p.tool === "measure") t.meas.hover(s.point);
    } else setCursor(null);
  };
  const onPointerUp = () => {
    sv.endPan();
    t.curves.end();
  };
  const onPointerLeave = () => {
    setCursor(null);
    if (coordsRef.current) coordsRef.current.textContent = "";
  };
  return { cursor, coordsRef, onPointerDown, onPointerMove, onPointerUp, onPointerLeave };
}
