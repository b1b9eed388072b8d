/** The mask tab: canvas plus its side panel (layers, masks, sections, strategy, zoning). */
import { useCallback, useEffect, useMemo, useRef, useState } from "react";
import type { Recipe, RunError } from "../api/types";
import { ancestors, downstream, setNodeParams, type Catalog } from "../graph/recipe";
import {
  addSection, canvasNodes, forgetKey, governingMask, maskRanges, newMaskFromLayer, patchSection, removeMask, removeSection,
  sectionKey, sectionValue, setCurve, setGuide, setMaskFrom, splitKey, type GuideParams, type KeyedParams, type MaskParams,
} from "./edits";
import { polygonArea, ringSelfIntersects, worldToLayer, type Pt } from "./geom";
import { beadWidth, COLOR_BY, strategyChoices, type ColorBy } from "./canvasTools";
import { MaskCanvas, SECTION_COLORS, type CanvasEdits, type Tool } from "./MaskCanvas";
import { useLayerPreview } from "./useLayerPreview";
import { useSectionFocus } from "../forms/sectionKeys";
import { stackedStarts } from "../preflight/preflight";

// A node without params: one object for every render (memos depending on the params keep their value).
const NO_PARAMS: Record<string, unknown> = {};
/** Port types the canvas can draw for one layer. */
const PLANAR_TYPES = ["layers", "sections", "toolpath"];

export interface NewMaskEvent {
  maskNode: string;
  params: MaskParams;
  newId: string;
  layer: number;
  /** The regions of the displayed layer (under the mask that governed it). */
  regions: { key: string; polygon: { exterior: number[][]; holes: number[][][] } }[];
}

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

declare global {
  interface Window {
    __waamflowReplanMs?: number[];
  }
}

export function MaskView(p: MaskViewProps) {
  const { recipe, layer } = p;
  const previewable = useMemo(
    () => recipe.nodes.filter((n) => p.catalog.get(n.type)?.outputs.some((o) => PLANAR_TYPES.includes(o.type))),
    [recipe, p.catalog],
  );
  // With no MPP node to show, the most downstream node that has layers, sections or a toolpath.
  const fallback = useMemo(() => {
    if (p.previewNode || canvasNodes(recipe).preview) return undefined;
    const ids = new Set(previewable.map((n) => n.id));
    return previewable.find((n) => ![...downstream(recipe, n.id)].some((d) => ids.has(d)))?.id;
  }, [recipe, previewable, p.previewNode]);
  const nodes = useMemo(() => canvasNodes(recipe, p.previewNode ?? fallback), [recipe, p.previewNode, fallback]);
  const editStarted = useRef<number | null>(null);
  // Ghost layers come from the node that makes the layers: a slice node, else any upstream node
  // with a `layers` output (rectangle, fan slice, …).
  const layersSource = useMemo(() => {
    if (nodes.slice) return nodes.slice.id;
    if (!nodes.preview) return undefined;
    const up = ancestors(recipe, nodes.preview.id);
    up.add(nodes.preview.id);
    return recipe.nodes.find((n) => up.has(n.id) && p.catalog.get(n.type)?.outputs.some((o) => o.type === "layers"))?.id;
  }, [recipe, nodes, p.catalog]);
  const pv = useLayerPreview(recipe, nodes.preview?.id, layersSource, layer, p.graph, editStarted);
  // Toolpath points are world coordinates; layers with a frame (fan slicing) draw them layer-local.
  const shown = useMemo(() => {
    const frame = pv.data?.layer?.frame;
    if (!pv.data || !frame) return pv.data;
    return { ...pv.data, paths: pv.data.paths.map((q) => ({ ...q, points: worldToLayer(q.points, frame) })) };
  }, [pv.data]);
  // The preflight's points are world coordinates too (read back from the program).
  const frame = pv.data?.layer?.frame;
  const starts = useMemo(() => {
    if (!p.starts || (!p.starts.here.length && !p.starts.below.length)) return null;
    const here = worldToLayer(p.starts.here, frame), below = worldToLayer(p.starts.below, frame);
    const stops = worldToLayer(p.starts.stops ?? [], frame);
    return { here, below, stops, stacked: stackedStarts(here, below, p.starts.radius) };
  }, [p.starts, frame]);
  const markPoint = useMemo(
    () => (p.mark?.point && p.mark.layer === layer ? worldToLayer([p.mark.point], frame)[0] : null),
    [p.mark, layer, frame],
  );
  const [tool, setTool] = useState<Tool>("select");
  const [grid, setGrid] = useState(1);
  const [snapVertices, setSnapVertices] = useState(true);
  const [selected, setSelected] = useState<string | null>(null);
  const [replanMs, setReplanMs] = useState<number | null>(null);
  const [colorBy, setColorBy] = useState<ColorBy>("zone");
  const [showBead, setShowBead] = useState(true);
  // "new mask here": the curve tool on the problem's layer, with a hint until a curve is drawn.
  const [drawHint, setDrawHint] = useState<PreflightMark | null>(null);
  useEffect(() => {
    if (!p.mark) return;
    if (p.mark.section) setSelected(p.mark.section);
    if (p.mark.draw) {
      setTool("curve");
      setDrawHint(p.mark);
    } else setDrawHint(null);
    // eslint-disable-next-line react-hooks/exhaustive-deps -- a mark is acted on once, when a new one arrives (its seq); the same mark re-rendered is not a new one
  }, [p.mark?.seq]);
  const endDraw = useCallback(() => {
    setDrawHint(null);
    p.onMarkDone?.();
  }, [p]);
  useEffect(() => {
    if (tool !== "curve" && drawHint) endDraw();
  }, [tool, drawHint, endDraw]);

  // Edit → canvas latency, measured after the frame that shows the re-planned layer.
  useEffect(() => {
    const t0 = pv.editT0;
    if (t0 === null || !pv.data) return;
    const id = requestAnimationFrame(() => {
      const ms = performance.now() - t0;
      setReplanMs(ms);
      (window.__waamflowReplanMs ??= []).push(ms);
    });
    return () => cancelAnimationFrame(id);
  }, [pv.data, pv.editT0]);

  // A problem picked in the problems panel: select its section.
  const focus = useSectionFocus();
  useEffect(() => {
    if (focus) setSelected(focus.key);
  }, [focus]);

  // A failed run: show its layer and section.
  useEffect(() => {
    if (p.failure?.layer != null) p.setLayer(p.failure.layer);
    if (p.failure?.section) setSelected(p.failure.section);
    // eslint-disable-next-line react-hooks/exhaustive-deps -- a failure is shown once when it arrives; p.setLayer is the parent's setter
  }, [p.failure]);

  const maskParams = (nodes.mask?.params ?? NO_PARAMS) as MaskParams;
  const guideParams = (nodes.guide?.params ?? NO_PARAMS) as GuideParams;
  const strategyParams = (nodes.strategy?.params ?? NO_PARAMS) as KeyedParams;
  const zoneParams = (nodes.zone?.params ?? NO_PARAMS) as KeyedParams;
  const mask = governingMask(maskParams, layer);
  const layerCount = pv.data?.layer_count ?? null;
  const ranges = maskRanges(maskParams, layerCount);

  const edit = useCallback(
    (id: string | undefined, fn: (params: Record<string, unknown>) => Record<string, unknown>) => {
      if (!id) {
        p.onMessage("the recipe has no node for this edit upstream of the previewed node");
        return;
      }
      editStarted.current = performance.now();
      p.onEdit((r) => setNodeParams(r, id, fn(r.nodes.find((n) => n.id === id)?.params ?? {})));
    },
    [p],
  );
  const maskId = nodes.mask?.id, guideId = nodes.guide?.id, strategyId = nodes.strategy?.id, zoneId = nodes.zone?.id;

  const edits: CanvasEdits = useMemo(
    () => ({
      addCurve: (curve: Pt[]) => {
        if (ringSelfIntersects(curve)) {
          p.onMessage("the curve crosses itself: draw a simple closed curve");
          return;
        }
        if (!maskId) {
          p.onMessage("add a mask node to draw segmentation curves");
          return;
        }
        setSelected(addSection(maskParams, layer, curve).key);
        edit(maskId, (m) => addSection(m as MaskParams, layer, curve).params);
        if (drawHint) {
          p.onMessage(`new section ${addSection(maskParams, layer, curve).key} drawn over the uncovered area: run again to check it`);
          setDrawHint(null);
          setTool("select");
          p.onMarkDone?.();
        }
      },
      setCurve: (key, curve) => edit(maskId, (m) => setCurve(m as MaskParams, key, curve)),
      setGuide: (key, guide) => edit(guideId, (g) => setGuide(g as GuideParams, key, guide)),
      addSplit: (key, pt) =>
        edit(zoneId, (z) => {
          const cur = (sectionValue(z as KeyedParams, key, "split_points") as number[][] | undefined) ?? [];
          return patchSection(z as KeyedParams, key, { split_points: [...cur, pt] });
        }),
      removeSplit: (key, i) =>
        edit(zoneId, (z) => {
          const cur = (sectionValue(z as KeyedParams, key, "split_points") as number[][] | undefined) ?? [];
          return patchSection(z as KeyedParams, key, { split_points: cur.filter((_, j) => j !== i) });
        }),
      removeSection: (key) => {
        editStarted.current = performance.now();
        p.onEdit((r) => {
          let out = r;
          for (const n of r.nodes) {
            if (n.id === maskId) out = setNodeParams(out, n.id, removeSection(n.params as MaskParams, key));
            else if (n.id === guideId || n.id === strategyId || n.id === zoneId) out = setNodeParams(out, n.id, forgetKey(n.params, key));
          }
          return out;
        });
      },
    }),
    [edit, maskId, guideId, strategyId, zoneId, layer, p, maskParams, drawHint],
  );

  // The patterns, the pattern a section gets when neither it nor the node's default names one, and
  // the bead width default: the catalog's (one source with the backend).
  const { patterns, patternDefault: schemaDefault, beadDefault } = useMemo(
    () => strategyChoices(nodes.strategy ? p.catalog.get(nodes.strategy.type) : undefined),
    [nodes.strategy, p.catalog],
  );
  const beadWidthOf = useCallback(
    (key: string) => (showBead && nodes.strategy ? beadWidth(strategyParams as Parameters<typeof beadWidth>[0], key, beadDefault) : null),
    [showBead, nodes.strategy, strategyParams, beadDefault],
  );
  const layerCountKnown = pv.data?.layer_count ?? null;
  const onLayerStep = useCallback(
    (d: number) => p.setLayer(Math.max(0, Math.min(layer + d, layerCountKnown !== null ? layerCountKnown - 1 : layer + d))),
    [p, layer, layerCountKnown],
  );


  const areas = new Map((pv.data?.sections ?? []).map((s) => [s.key, s.polygon ? polygonArea(s.polygon) : 0]));
  const lengths = new Map(
    (pv.data?.paths ?? []).map((q) => {
      let L = 0;
      for (let i = 1; i < q.points.length; i++) L += Math.hypot(q.points[i][0] - q.points[i - 1][0], q.points[i][1] - q.points[i - 1][1]);
      return [q.key, L];
    }),
  );
  const sectionKeys = mask ? mask.sections.map((s) => sectionKey(mask.id, s.id)) : (pv.data?.sections ?? []).map((s) => s.key);
  const err = pv.error;

  // Which layers a section drawn now applies to: those of the mask governing the shown layer.
  const range = mask ? ranges.find((m) => m.id === mask.id) : undefined;
  const joinsText = mask ? `It joins mask ${mask.id} (layers ${range?.from ?? mask.from_layer}–${range?.to ?? "end"}).` : "It starts mask bs1 (all layers).";

  const newMask = () => {
    const r = newMaskFromLayer(maskParams, layer);
    if ("error" in r) {
      p.onMessage(r.error);
      return;
    }
    // The App carries each section's settings and XML values over (matched by region overlap).
    if (p.onNewMask && maskId) {
      if (p.onNewMask({ maskNode: maskId, params: r.params, newId: r.id, layer, regions: pv.data?.sections ?? [] })) p.onDismissFailure();
      return;
    }
    edit(maskId, () => r.params);
    p.onDismissFailure();
  };

  return (
    <div className="mask-view">
      <div className="mask-main">
        <div className="mask-toolbar">
          {(["select", "curve", "guide", "split"] as Tool[]).map((t) => (
            <button key={t} className={tool === t ? "active" : ""} onClick={() => setTool(t)} data-tool={t} title={`${t} (${t === "select" ? "V" : t[0].toUpperCase()})`}>
              {t === "select" ? "select/move" : t === "curve" ? "draw mask curve" : t === "guide" ? "draw guide" : "zone split"}
            </button>
          ))}
          <label title="grid pitch for snapping, mm (0 = off)">
            grid <input type="number" min={0} step={0.5} value={grid} onChange={(e) => setGrid(Math.max(0, Number(e.target.value) || 0))} style={{ width: 48 }} /> mm
          </label>
          <label>
            <input type="checkbox" checked={snapVertices} onChange={(e) => setSnapVertices(e.target.checked)} /> snap to vertices
          </label>
          <button className={tool === "measure" ? "active" : ""} onClick={() => setTool("measure")} data-tool="measure" title="measure distance and angle (M)">
            measure
          </button>
          <label title="what the path colours show">
            colour by{" "}
            <select value={colorBy} onChange={(e) => setColorBy(e.target.value as ColorBy)} data-testid="color-by">
              {COLOR_BY.map(([m, l]) => (
                <option key={m} value={m}>
                  {l}
                </option>
              ))}
            </select>
          </label>
          <label title="draw each path at the bead width of its section's strategy">
            <input type="checkbox" checked={showBead} onChange={(e) => setShowBead(e.target.checked)} data-testid="show-bead" /> bead width
          </label>
          {pv.loading && <span className="muted">re-planning…</span>}
        </div>
        {p.failure && (
          <div className="failure-banner" data-testid="failure-banner">
            <b>Run failed</b>
            {p.failure.node && <> at node {p.failure.node}</>}
            {p.failure.layer != null && <>, layer {p.failure.layer}</>}
            {p.failure.section && <>, section {p.failure.section}</>}: {p.failure.message}
            {p.failure.layer != null && maskId && (
              <button onClick={newMask} data-testid="new-mask-from-layer">
                new mask from layer {p.failure.layer}
              </button>
            )}
            <button onClick={p.onDismissFailure}>dismiss</button>
          </div>
        )}
        {drawHint && (
          <div className="pf-draw-hint" data-testid="pf-draw-hint" role="status">
            <span>
              <b>New mask section</b> for the uncovered area{drawHint.section ? ` of ${drawHint.section}` : ""} on layer {drawHint.layer}:{" "}
              {maskId ? `draw a closed curve around the marked spot (click points, click the first one to close; Esc clears the points). ${joinsText}` : "this recipe has no mask node: add one (palette → mask) to draw sections."}
            </span>
            <button onClick={() => setTool("select")}>cancel</button>
          </div>
        )}
        {err && (
          <div className="preview-error" data-testid="preview-error">
            {err.layer != null ? `layer ${err.layer}` : ""} {err.section ?? ""} {err.message}
          </div>
        )}
        {!nodes.preview && <div className="empty">Add a slice node (and mask, guide, strategy, zone) to draw masks.</div>}
        <MaskCanvas
          preview={shown}
          ghosts={pv.ghosts}
          mask={mask}
          guides={guideParams}
          zone={zoneParams}
          tool={tool}
          setTool={setTool}
          grid={grid}
          snapVertices={snapVertices}
          selected={selected}
          setSelected={setSelected}
          highlight={p.failure?.section ?? err?.section ?? null}
          edits={edits}
          replanMs={replanMs}
          colorBy={colorBy}
          beadWidthOf={beadWidthOf}
          onLayerStep={onLayerStep}
          starts={starts}
          mark={markPoint}
        />
      </div>
      <aside className="mask-panel">
        <section>
          <h4>Layer</h4>
          <label>
            show node{" "}
            <select value={nodes.preview?.id ?? ""} onChange={(e) => p.setPreviewNode(e.target.value)} data-testid="preview-node">
              {previewable.map((n) => (
                <option key={n.id} value={n.id}>
                  {n.id} ({n.type})
                </option>
              ))}
            </select>
          </label>
          <div className="layer-row">
            <input
              type="range"
              min={0}
              max={Math.max(0, (layerCount ?? layer + 1) - 1)}
              value={layer}
              onChange={(e) => p.setLayer(Number(e.target.value))}
              data-testid="layer-slider"
              aria-label="layer"
            />
            <input aria-label="layer index" type="number" min={0} max={layerCount !== null ? layerCount - 1 : undefined} value={layer} onChange={(e) => p.setLayer(Math.max(0, Number(e.target.value) || 0))} className="layer-num" />
          </div>
          <div className="muted">
            {layerCount !== null ? `${layerCount} layers` : ""}
            {pv.data?.layer ? ` · z ${pv.data.layer.z} mm · ${pv.data.layer.area_mm2.toFixed(1)} mm²` : ""}
            {pv.data ? ` · server ${pv.data.ms.toFixed(0)} ms` : ""}
          </div>
        </section>
        <section>
          <h4>Masks</h4>
          <table className="masks">
            <tbody>
              {ranges.map((m) => (
                <tr key={m.id} className={mask?.id === m.id ? "current" : ""} data-mask={m.id}>
                  <td>
                    <button className="link" onClick={() => p.setLayer(m.from)}>
                      {m.id}
                    </button>
                  </td>
                  <td>
                    layers{" "}
                    <input aria-label={`first layer of mask ${m.id}`} type="number" min={0} value={m.from} className="layer-num" onChange={(e) => edit(maskId, (mp) => setMaskFrom(mp as MaskParams, m.id, Number(e.target.value)))} />
                    –{m.to ?? "end"}
                  </td>
                  <td>
                    <button title="delete mask" onClick={() => edit(maskId, (mp) => removeMask(mp as MaskParams, m.id))}>
                      ✕
                    </button>
                  </td>
                </tr>
              ))}
            </tbody>
          </table>
          {!ranges.length && <div className="muted">No masks: each connected region is a section.</div>}
          <button onClick={newMask} disabled={!maskId} data-testid="new-mask">
            new mask from layer {layer}
          </button>
        </section>
        <section className="sections-list">
          <h4>Sections {mask ? `of ${mask.id}` : ""}</h4>
          {sectionKeys.map((key, i) => {
            const st = String(sectionValue(strategyParams, key, "pattern") ?? "");
            const sl = sectionValue(zoneParams, key, "start_length");
            const el = sectionValue(zoneParams, key, "end_length");
            const splits = (sectionValue(zoneParams, key, "split_points") as unknown[] | undefined)?.length ?? 0;
            return (
              <div key={key} className={`section-item ${selected === key ? "selected" : ""}`} data-section-item={key} onClick={() => setSelected(key)}>
                <div className="section-head">
                  <span className="swatch" style={{ background: SECTION_COLORS[i % SECTION_COLORS.length] }} />
                  <b>{key}</b>
                  <span className="muted">
                    {areas.has(key) ? `${areas.get(key)!.toFixed(0)} mm²` : "—"}
                    {lengths.has(key) ? ` · path ${lengths.get(key)!.toFixed(0)} mm` : ""}
                  </span>
                </div>
                <div className="section-fields">
                  <label>
                    strategy
                    <select
                      value={strategyParams.sections?.[key]?.pattern !== undefined ? st : ""}
                      disabled={!strategyId}
                      onChange={(e) => edit(strategyId, (s) => patchSection(s as KeyedParams, key, { pattern: e.target.value || undefined }))}
                      data-testid={`strategy-${key}`}
                    >
                      <option value="">default ({String(strategyParams.default?.pattern ?? schemaDefault ?? "—")})</option>
                      {patterns.map((x) => (
                        <option key={x} value={x}>
                          {x}
                        </option>
                      ))}
                    </select>
                  </label>
                  <label>
                    start
                    <LengthInput value={sl} disabled={!zoneId} testid={`start-${key}`} onChange={(v) => edit(zoneId, (z) => patchSection(z as KeyedParams, key, { start_length: v }))} />
                    mm
                  </label>
                  <label>
                    end
                    <LengthInput value={el} disabled={!zoneId} testid={`end-${key}`} onChange={(v) => edit(zoneId, (z) => patchSection(z as KeyedParams, key, { end_length: v }))} />
                    mm
                  </label>
                </div>
                <div className="section-fields">
                  <span className="muted">guide: {guideParams.guides?.[key] ? "drawn" : "auto (long axis)"}</span>
                  {guideParams.guides?.[key] && <button onClick={() => edit(guideId, (g) => setGuide(g as GuideParams, key, null))}>clear guide</button>}
                  <span className="muted">splits: {splits}</span>
                  {splits > 0 && <button onClick={() => edit(zoneId, (z) => patchSection(z as KeyedParams, key, { split_points: [] }))}>clear</button>}
                  {mask && splitKey(key).mask === mask.id && <button onClick={() => edits.removeSection(key)}>delete</button>}
                </div>
              </div>
            );
          })}
        </section>
      </aside>
    </div>
  );
}

function LengthInput({ value, onChange, disabled, testid }: { value: unknown; onChange: (v: number) => void; disabled: boolean; testid: string }) {
  const [text, setText] = useState(value === undefined ? "" : String(value));
  useEffect(() => setText(value === undefined ? "" : String(value)), [value]);
  const commit = () => {
    const v = Number(text);
    if (text.trim() !== "" && Number.isFinite(v) && v >= 0 && v !== value) onChange(v);
    else setText(value === undefined ? "" : String(value));
  };
  return (
    <input
      type="number"
      min={0}
      step={0.5}
      value={text}
      disabled={disabled}
      data-testid={testid}
      style={{ width: 56 }}
      onChange={(e) => setText(e.target.value)}
      onBlur={commit}
      onKeyDown={(e) => e.key === "Enter" && commit()}
    />
  );
}
