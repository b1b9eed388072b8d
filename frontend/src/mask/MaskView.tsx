/** The mask tab: canvas plus its side panel (layers, masks, sections, strategy, zoning). The state
 * is in useMaskView's hooks, the pieces around the canvas in MaskPanels. */
import { useCallback, useMemo, useRef, useState } from "react";
import type { Recipe, RunError } from "../api/types";
import type { Catalog } from "../graph/recipe";
import {
  governingMask, maskRanges, newMaskFromLayer, sectionKey, type GuideParams, type KeyedParams, type Mask, type MaskParams,
} from "./edits";
import { polygonArea } from "./geom";
import { beadWidth, strategyChoices, type ColorBy } from "./canvasTools";
import { MaskCanvas, type Tool } from "./MaskCanvas";
import { useLayerPreview, type PreviewState } from "./useLayerPreview";
import {
  useCanvasEdits, useDrawHint, useLayerCoords, useNodeEdit, usePreviewNodes, useReplanLatency, useShowProblems, type Edit, type PreflightMark,
} from "./useMaskView";
import { DrawHint, FailureBanner, LayerPanel, MaskToolbar, MasksPanel, SectionItem, sectionColor } from "./MaskPanels";

export type { PreflightMark } from "./useMaskView";

// A node without params: one object for every render (memos depending on the params keep their value).
const NO_PARAMS: Record<string, unknown> = {};

export interface NewMaskEvent {
  maskNode: string;
  params: MaskParams;
  newId: string;
  layer: number;
  /** The regions of the displayed layer (under the mask that governed it). */
  regions: { key: string; polygon: { exterior: number[][]; holes: number[][][] } }[];
}

export interface MaskViewProps {
  /** "New mask from layer N": the App applies it (with carry-over); false when the user declined. */
  onNewMask?: (e: NewMaskEvent) => boolean;
  recipe: Recipe;
  catalog: Catalog;
  graph: string | null;
  layer: number;
  setLayer: (n: number) => void;
  previewNode: string | null;
  setPreviewNode: (id: string) => void;
  onEdit: (edit: (r: Recipe) => Recipe) => void;
  failure: RunError | null;
  onDismissFailure: () => void;
  onMessage: (m: string) => void;
  /** The last run's ignition points of the shown layer and the layer below (world mm), with the
   * distance (mm) under which a start counts as stacked on one below; null = none to show. */
  starts?: { here: number[][]; below: number[][]; stops?: number[][]; radius: number | null } | null;
  mark?: PreflightMark | null;
  /** The "new mask here" drawing is finished or abandoned. */
  onMarkDone?: () => void;
}

/** The canvas's display choices (toolbar). */
function useCanvasChoices() {
  const [tool, setTool] = useState<Tool>("select");
  const [grid, setGrid] = useState(1);
  const [snapVertices, setSnapVertices] = useState(true);
  const [colorBy, setColorBy] = useState<ColorBy>("zone");
  const [showBead, setShowBead] = useState(true);
  return { tool, setTool, grid, setGrid, snapVertices, setSnapVertices, colorBy, setColorBy, showBead, setShowBead };
}

/** The params of the MPP nodes the canvas edits (one object each while the node has none). */
function nodeParams(nodes: ReturnType<typeof usePreviewNodes>["nodes"]) {
  return {
    maskParams: (nodes.mask?.params ?? NO_PARAMS) as MaskParams,
    guideParams: (nodes.guide?.params ?? NO_PARAMS) as GuideParams,
    strategyParams: (nodes.strategy?.params ?? NO_PARAMS) as KeyedParams,
    zoneParams: (nodes.zone?.params ?? NO_PARAMS) as KeyedParams,
  };
}

/** Area per section and path length per section of the shown layer (mm², mm). */
function sectionMeasures(data: PreviewState["data"]) {
  const areas = new Map((data?.sections ?? []).map((s) => [s.key, s.polygon ? polygonArea(s.polygon) : 0]));
  const lengths = new Map(
    (data?.paths ?? []).map((q) => {
      let L = 0;
      for (let i = 1; i < q.points.length; i++) L += Math.hypot(q.points[i][0] - q.points[i - 1][0], q.points[i][1] - q.points[i - 1][1]);
      return [q.key, L];
    }),
  );
  return { areas, lengths };
}

/** "new mask from layer N": the App carries each section's settings and XML values over (matched by region overlap). */
function useNewMask(p: MaskViewProps, maskParams: MaskParams, maskId: string | undefined, data: PreviewState["data"], edit: Edit) {
  return () => {
    const r = newMaskFromLayer(maskParams, p.layer);
    if ("error" in r) {
      p.onMessage(r.error);
      return;
    }
    if (p.onNewMask && maskId) {
      if (p.onNewMask({ maskNode: maskId, params: r.params, newId: r.id, layer: p.layer, regions: data?.sections ?? [] })) p.onDismissFailure();
      return;
    }
    edit(maskId, () => r.params);
    p.onDismissFailure();
  };
}

/** Which layers a section drawn now applies to: those of the mask governing the shown layer. */
function joinsText(mask: Mask | undefined, ranges: ReturnType<typeof maskRanges>) {
  const range = mask ? ranges.find((m) => m.id === mask.id) : undefined;
  return mask ? `It joins mask ${mask.id} (layers ${range?.from ?? mask.from_layer}–${range?.to ?? "end"}).` : "It starts mask bs1 (all layers).";
}

export function MaskView(p: MaskViewProps) {
  const { recipe, layer, onMessage, onMarkDone } = p;
  const { previewable, nodes, layersSource } = usePreviewNodes(recipe, p.catalog, p.previewNode);
  const editStarted = useRef<number | null>(null);
  const pv = useLayerPreview(recipe, nodes.preview?.id, layersSource, layer, p.graph, editStarted);
  const { shown, starts, markPoint } = useLayerCoords(pv.data, p.starts, p.mark, layer);
  const c = useCanvasChoices();
  const { setTool } = c;
  const [selected, setSelected] = useState<string | null>(null);
  const [drawHint, setDrawHint] = useDrawHint(p.mark, c.tool, setTool, setSelected, onMarkDone);
  const replanMs = useReplanLatency(pv);
  useShowProblems(p.failure, p.setLayer, setSelected);
  const { maskParams, guideParams, strategyParams, zoneParams } = nodeParams(nodes);
  const mask = governingMask(maskParams, layer);
  const layerCount = pv.data?.layer_count ?? null;
  const ranges = maskRanges(maskParams, layerCount);
  const edit = useNodeEdit(p.onEdit, onMessage, editStarted);
  const onCurveAdded = useCallback(
    (key: string) => {
      setSelected(key);
      if (!drawHint) return;
      onMessage(`new section ${key} drawn over the uncovered area: run again to check it`);
      setDrawHint(null);
      setTool("select");
      onMarkDone?.();
    },
    [drawHint, onMessage, setDrawHint, setTool, onMarkDone],
  );
  const edits = useCanvasEdits({ nodes, maskParams, layer, edit, onEdit: p.onEdit, onMessage, editStarted, onCurveAdded });
  // The patterns, the pattern a section gets when neither it nor the node's default names one, and
  // the bead width default: the catalog's (one source with the backend).
  const { patterns, patternDefault, beadDefault } = useMemo(() => strategyChoices(nodes.strategy ? p.catalog.get(nodes.strategy.type) : undefined), [nodes.strategy, p.catalog]);
  const beadWidthOf = useCallback(
    (key: string) => (c.showBead && nodes.strategy ? beadWidth(strategyParams as Parameters<typeof beadWidth>[0], key, beadDefault) : null),
    [c.showBead, nodes.strategy, strategyParams, beadDefault],
  );
  const { setLayer } = p;
  const onLayerStep = useCallback((d: number) => setLayer(Math.max(0, Math.min(layer + d, layerCount !== null ? layerCount - 1 : layer + d))), [setLayer, layer, layerCount]);
  const { areas, lengths } = sectionMeasures(pv.data);
  const sectionKeys = mask ? mask.sections.map((s) => sectionKey(mask.id, s.id)) : (pv.data?.sections ?? []).map((s) => s.key);
  const err = pv.error;
  const maskId = nodes.mask?.id;
  const newMask = useNewMask(p, maskParams, maskId, pv.data, edit);
  return (
    <div className="mask-view">
      <div className="mask-main">
        <MaskToolbar {...c} loading={pv.loading} />
        {p.failure && <FailureBanner failure={p.failure} canNewMask={!!maskId} onNewMask={newMask} onDismiss={p.onDismissFailure} />}
        {drawHint && <DrawHint hint={drawHint} hasMask={!!maskId} joinsText={joinsText(mask, ranges)} onCancel={() => setTool("select")} />}
        {err && (
          <div className="preview-error" data-testid="preview-error">
            {err.layer != null ? `layer ${err.layer}` : ""} {err.section ?? ""} {err.message}
          </div>
        )}
        {!nodes.preview && <div className="empty">Add a slice node (and mask, guide, strategy, zone) to draw masks.</div>}
        <MaskCanvas
          preview={shown} ghosts={pv.ghosts} mask={mask} guides={guideParams} zone={zoneParams} tool={c.tool} setTool={setTool} grid={c.grid}
          snapVertices={c.snapVertices} selected={selected} setSelected={setSelected} highlight={p.failure?.section ?? err?.section ?? null}
          edits={edits} replanMs={replanMs} colorBy={c.colorBy} beadWidthOf={beadWidthOf} onLayerStep={onLayerStep} starts={starts} mark={markPoint}
        />
      </div>
      <aside className="mask-panel">
        <LayerPanel previewable={previewable} previewId={nodes.preview?.id ?? ""} setPreviewNode={p.setPreviewNode} layer={layer} setLayer={setLayer} layerCount={layerCount} data={pv.data} />
        <MasksPanel ranges={ranges} current={mask?.id} maskId={maskId} layer={layer} setLayer={setLayer} edit={edit} onNewMask={newMask} />
        <section className="sections-list">
          <h4>Sections {mask ? `of ${mask.id}` : ""}</h4>
          {sectionKeys.map((key, i) => (
            <SectionItem
              key={key} sectionKey={key} color={sectionColor(i)} selected={selected === key} onSelect={() => setSelected(key)} area={areas.get(key)} length={lengths.get(key)}
              strategy={strategyParams} zone={zoneParams} guides={guideParams} ids={{ strategy: nodes.strategy?.id, zone: nodes.zone?.id, guide: nodes.guide?.id }}
              patterns={patterns} patternDefault={patternDefault} mask={mask} edit={edit} onRemove={() => edits.removeSection(key)}
            />
          ))}
        </section>
      </aside>
    </div>
  );
}
