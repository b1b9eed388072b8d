/**
 * The mask tab's state, one hook per concern: which node the canvas shows (and where its ghost
 * layers come from), the preview in layer coordinates with the preflight's points, the "new mask
 * here" drawing, the edit → canvas latency, problems and failures that select a section, and the
 * canvas's edits of the mask / guide / strategy / zone nodes.
 */
import { useCallback, useEffect, useMemo, useState, type MutableRefObject } from "react";
import type { Recipe, RunError } from "../api/types";
import { ancestors, downstream, setNodeParams, type Catalog } from "../graph/recipe";
import {
  addSection, canvasNodes, forgetKey, patchSection, removeSection, sectionValue, setCurve, setGuide,
  type GuideParams, type KeyedParams, type MaskParams,
} from "./edits";
import { ringSelfIntersects, worldToLayer, type Pt } from "./geom";
import type { CanvasEdits, Tool } from "./useCanvasTools";
import type { PreviewState } from "./useLayerPreview";
import { useSectionFocus } from "../forms/sectionKeys";
import { stackedStarts } from "../preflight/preflight";

/** Port types the canvas can draw for one layer. */
const PLANAR_TYPES = ["layers", "sections", "toolpath"];

/** A preflight problem shown on the canvas: its layer, its point (world mm) marked; `draw` = the
 * "new mask here" action (the mask-drawing tool on that layer). `seq` makes a repeated click count. */
export interface PreflightMark {
  layer: number;
  point: number[] | null;
  section: string | null;
  draw: boolean;
  message: string;
  seq: number;
}

declare global {
  interface Window {
    __waamflowReplanMs?: number[];
  }
}

/** The nodes the canvas can show, the MPP nodes it edits, and the node its ghost layers come from. */
export function usePreviewNodes(recipe: Recipe, catalog: Catalog, previewNode: string | null) {
  const previewable = useMemo(
    () => recipe.nodes.filter((n) => catalog.get(n.type)?.outputs.some((o) => PLANAR_TYPES.includes(o.type))),
    [recipe, catalog],
  );
  // With no MPP node to show, the most downstream node that has layers, sections or a toolpath.
  const fallback = useMemo(() => {
    if (previewNode || canvasNodes(recipe).preview) return undefined;
    const ids = new Set(previewable.map((n) => n.id));
    return previewable.find((n) => ![...downstream(recipe, n.id)].some((d) => ids.has(d)))?.id;
  }, [recipe, previewable, previewNode]);
  const nodes = useMemo(() => canvasNodes(recipe, previewNode ?? fallback), [recipe, previewNode, fallback]);
  // Ghost layers come from the node that makes the layers: a slice node, else any upstream node
  // with a `layers` output (rectangle, fan slice, …).
  const layersSource = useMemo(() => {
    if (nodes.slice) return nodes.slice.id;
    if (!nodes.preview) return undefined;
    const up = ancestors(recipe, nodes.preview.id);
    up.add(nodes.preview.id);
    return recipe.nodes.find((n) => up.has(n.id) && catalog.get(n.type)?.outputs.some((o) => o.type === "layers"))?.id;
  }, [recipe, nodes, catalog]);
  return { previewable, nodes, layersSource };
}

type WorldStarts = { here: number[][]; below: number[][]; stops?: number[][]; radius: number | null } | null | undefined;

/** The preview, the preflight's starts and the picked problem's point, in layer coordinates. */
export function useLayerCoords(data: PreviewState["data"], worldStarts: WorldStarts, mark: PreflightMark | null | undefined, layer: number) {
  // Toolpath points are world coordinates; layers with a frame (fan slicing) draw them layer-local.
  const shown = useMemo(() => {
    const frame = data?.layer?.frame;
    if (!data || !frame) return data;
    return { ...data, paths: data.paths.map((q) => ({ ...q, points: worldToLayer(q.points, frame) })) };
  }, [data]);
  // The preflight's points are world coordinates too (read back from the program).
  const frame = data?.layer?.frame;
  const starts = useMemo(() => {
    if (!worldStarts || (!worldStarts.here.length && !worldStarts.below.length)) return null;
    const here = worldToLayer(worldStarts.here, frame), below = worldToLayer(worldStarts.below, frame);
    const stops = worldToLayer(worldStarts.stops ?? [], frame);
    return { here, below, stops, stacked: stackedStarts(here, below, worldStarts.radius) };
  }, [worldStarts, frame]);
  const markPoint = useMemo(() => (mark?.point && mark.layer === layer ? worldToLayer([mark.point], frame)[0] : null), [mark, layer, frame]);
  return { shown, starts, markPoint };
}

/** "new mask here": the curve tool on the problem's layer, with a hint until a curve is drawn or the tool changes. */
export function useDrawHint(mark: PreflightMark | null | undefined, tool: Tool, setTool: (t: Tool) => void, setSelected: (k: string) => void, onMarkDone: (() => void) | undefined) {
  const [drawHint, setDrawHint] = useState<PreflightMark | null>(null);
  useEffect(() => {
    if (!mark) return;
    if (mark.section) setSelected(mark.section);
    if (mark.draw) {
      setTool("curve");
      setDrawHint(mark);
    } else setDrawHint(null);
    // eslint-disable-next-line react-hooks/exhaustive-deps -- a mark is acted on once, when a new one arrives (its seq); the same mark re-rendered is not a new one
  }, [mark?.seq]);
  const endDraw = useCallback(() => {
    setDrawHint(null);
    onMarkDone?.();
  }, [onMarkDone]);
  useEffect(() => {
    if (tool !== "curve" && drawHint) endDraw();
  }, [tool, drawHint, endDraw]);
  return [drawHint, setDrawHint] as const;
}

/**
 * Edit → canvas latency: from the edit to the frame that shows the re-planned layer, ms. Kept in
 * `window.__waamflowReplanMs` and as a performance measure "waamflow:edit-to-canvas" (the e2e
 * tests and the GUI latency bench read them).
 */
export function useReplanLatency(pv: Pick<PreviewState, "data" | "editT0">) {
  const [replanMs, setReplanMs] = useState<number | null>(null);
  useEffect(() => {
    const t0 = pv.editT0;
    if (t0 === null || !pv.data) return;
    const id = requestAnimationFrame(() => {
      const end = performance.now();
      setReplanMs(end - t0);
      (window.__waamflowReplanMs ??= []).push(end - t0);
      performance.measure?.("waamflow:edit-to-canvas", { start: t0, end });
    });
    return () => cancelAnimationFrame(id);
  }, [pv.data, pv.editT0]);
  return replanMs;
}

/** A problem picked in the problems panel selects its section; a failed run shows its layer and section. */
export function useShowProblems(failure: RunError | null, setLayer: (n: number) => void, setSelected: (k: string) => void) {
  const focus = useSectionFocus();
  useEffect(() => {
    if (focus) setSelected(focus.key);
  }, [focus, setSelected]);
  useEffect(() => {
    if (failure?.layer != null) setLayer(failure.layer);
    if (failure?.section) setSelected(failure.section);
    // eslint-disable-next-line react-hooks/exhaustive-deps -- a failure is shown once when it arrives; setLayer is the parent's setter
  }, [failure]);
}

type Nodes = ReturnType<typeof canvasNodes>;
type ParamsFn = (params: Record<string, unknown>) => Record<string, unknown>;
export type Edit = (id: string | undefined, fn: ParamsFn) => void;

/** One edit of a node's params (one undo step), timed for the edit → canvas latency. */
export function useNodeEdit(onEdit: (edit: (r: Recipe) => Recipe) => void, onMessage: (m: string) => void, editStarted: MutableRefObject<number | null>): Edit {
  return useCallback(
    (id, fn) => {
      if (!id) {
        onMessage("the recipe has no node for this edit upstream of the previewed node");
        return;
      }
      editStarted.current = performance.now();
      onEdit((r) => setNodeParams(r, id, fn(r.nodes.find((n) => n.id === id)?.params ?? {})));
    },
    [onEdit, onMessage, editStarted],
  );
}

const splitsOf = (z: Record<string, unknown>, key: string) => (sectionValue(z as KeyedParams, key, "split_points") as number[][] | undefined) ?? [];

export interface EditsCtx {
  nodes: Nodes;
  maskParams: MaskParams;
  layer: number;
  edit: Edit;
  onEdit: (edit: (r: Recipe) => Recipe) => void;
  onMessage: (m: string) => void;
  editStarted: MutableRefObject<number | null>;
  /** A curve drawn: select its section (and close the "new mask here" drawing). */
  onCurveAdded: (key: string) => void;
}

/** The canvas's edits of the mask, guide and zone nodes (removing a section forgets it in all four). */
export function useCanvasEdits(c: EditsCtx): CanvasEdits {
  const { nodes, maskParams, layer, edit, onEdit, onMessage, editStarted, onCurveAdded } = c;
  const maskId = nodes.mask?.id, guideId = nodes.guide?.id, strategyId = nodes.strategy?.id, zoneId = nodes.zone?.id;
  return useMemo(
    () => ({
      addCurve: (curve: Pt[]) => {
        if (ringSelfIntersects(curve)) return onMessage("the curve crosses itself: draw a simple closed curve");
        if (!maskId) return onMessage("add a mask node to draw segmentation curves");
        const key = addSection(maskParams, layer, curve).key;
        edit(maskId, (m) => addSection(m as MaskParams, layer, curve).params);
        onCurveAdded(key);
      },
      setCurve: (key, curve) => edit(maskId, (m) => setCurve(m as MaskParams, key, curve)),
      setGuide: (key, guide) => edit(guideId, (g) => setGuide(g as GuideParams, key, guide)),
      addSplit: (key, pt) => edit(zoneId, (z) => patchSection(z as KeyedParams, key, { split_points: [...splitsOf(z, key), pt] })),
      removeSplit: (key, i) => edit(zoneId, (z) => patchSection(z as KeyedParams, key, { split_points: splitsOf(z, key).filter((_, j) => j !== i) })),
      removeSection: (key) => {
        editStarted.current = performance.now();
        onEdit((r) => {
          let out = r;
          for (const n of r.nodes) {
            if (n.id === maskId) out = setNodeParams(out, n.id, removeSection(n.params as MaskParams, key));
            else if (n.id === guideId || n.id === strategyId || n.id === zoneId) out = setNodeParams(out, n.id, forgetKey(n.params, key));
          }
          return out;
        });
      },
    }),
    [edit, maskId, guideId, strategyId, zoneId, layer, maskParams, onEdit, onMessage, editStarted, onCurveAdded],
  );
}
