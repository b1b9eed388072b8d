/**
 * The mask tab's pieces around the canvas (presentational: props in, HTML out): the toolbar, the
 * failure / "new mask here" / preview-error banners, and the side panel's layer, masks and
 * sections blocks.
 */
import { useEffect, useState } from "react";
import type { Preview, Recipe, RunError } from "../api/types";
import {
  patchSection, removeMask, sectionValue, setGuide, setMaskFrom, splitKey, type GuideParams, type KeyedParams, type Mask, type MaskParams,
} from "./edits";
import { COLOR_BY, type ColorBy } from "./canvasTools";
import { SECTION_COLORS } from "./MaskCanvas";
import type { Tool } from "./useCanvasTools";
import type { Edit, PreflightMark } from "./useMaskView";

export interface ToolbarProps {
  tool: Tool;
  setTool: (t: Tool) => void;
  grid: number;
  setGrid: (g: number) => void;
  snapVertices: boolean;
  setSnapVertices: (v: boolean) => void;
  colorBy: ColorBy;
  setColorBy: (c: ColorBy) => void;
  showBead: boolean;
  setShowBead: (v: boolean) => void;
  loading: boolean;
}

const TOOL_TEXT: Record<string, string> = { select: "select/move", curve: "draw mask curve", guide: "draw guide", split: "zone split" };

export function MaskToolbar(p: ToolbarProps) {
  return (
    <div className="mask-toolbar">
      {(["select", "curve", "guide", "split"] as Tool[]).map((t) => (
        <button key={t} className={p.tool === t ? "active" : ""} onClick={() => p.setTool(t)} data-tool={t} title={`${t} (${t === "select" ? "V" : t[0].toUpperCase()})`}>
          {TOOL_TEXT[t]}
        </button>
      ))}
      <label title="grid pitch for snapping, mm (0 = off)">
        grid <input type="number" min={0} step={0.5} value={p.grid} onChange={(e) => p.setGrid(Math.max(0, Number(e.target.value) || 0))} style={{ width: 48 }} /> mm
      </label>
      <label>
        <input type="checkbox" checked={p.snapVertices} onChange={(e) => p.setSnapVertices(e.target.checked)} /> snap to vertices
      </label>
      <button className={p.tool === "measure" ? "active" : ""} onClick={() => p.setTool("measure")} data-tool="measure" title="measure distance and angle (M)">
        measure
      </button>
      <label title="what the path colours show">
        colour by{" "}
        <select value={p.colorBy} onChange={(e) => p.setColorBy(e.target.value as ColorBy)} data-testid="color-by">
          {COLOR_BY.map(([m, l]) => (
            <option key={m} value={m}>
              {l}
            </option>
          ))}
        </select>
      </label>
      <label title="draw each path at the bead width of its section's strategy">
        <input type="checkbox" checked={p.showBead} onChange={(e) => p.setShowBead(e.target.checked)} data-testid="show-bead" /> bead width
      </label>
      {p.loading && <span className="muted">re-planning…</span>}
    </div>
  );
}

export function FailureBanner({ failure, canNewMask, onNewMask, onDismiss }: { failure: RunError; canNewMask: boolean; onNewMask: () => void; onDismiss: () => void }) {
  return (
    <div className="failure-banner" data-testid="failure-banner">
      <b>Run failed</b>
      {failure.node && <> at node {failure.node}</>}
      {failure.layer != null && <>, layer {failure.layer}</>}
      {failure.section && <>, section {failure.section}</>}: {failure.message}
      {failure.layer != null && canNewMask && (
        <button onClick={onNewMask} data-testid="new-mask-from-layer">
          new mask from layer {failure.layer}
        </button>
      )}
      <button onClick={onDismiss}>dismiss</button>
    </div>
  );
}

export function DrawHint({ hint, hasMask, joinsText, onCancel }: { hint: PreflightMark; hasMask: boolean; joinsText: string; onCancel: () => void }) {
  return (
    <div className="pf-draw-hint" data-testid="pf-draw-hint" role="status">
      <span>
        <b>New mask section</b> for the uncovered area{hint.section ? ` of ${hint.section}` : ""} on layer {hint.layer}:{" "}
        {hasMask ? `draw a closed curve around the marked spot (click points, click the first one to close; Esc clears the points). ${joinsText}` : "this recipe has no mask node: add one (palette → mask) to draw sections."}
      </span>
      <button onClick={onCancel}>cancel</button>
    </div>
  );
}

export function LayerPanel(p: { previewable: Recipe["nodes"]; previewId: string; setPreviewNode: (id: string) => void; layer: number; setLayer: (n: number) => void; layerCount: number | null; data: Preview | null }) {
  const { layer, layerCount, data } = p;
  return (
    <section>
      <h4>Layer</h4>
      <label>
        show node{" "}
        <select value={p.previewId} onChange={(e) => p.setPreviewNode(e.target.value)} data-testid="preview-node">
          {p.previewable.map((n) => (
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
        {data?.layer ? ` · z ${data.layer.z} mm · ${data.layer.area_mm2.toFixed(1)} mm²` : ""}
        {data ? ` · server ${data.ms.toFixed(0)} ms` : ""}
      </div>
    </section>
  );
}

export function MasksPanel(p: { ranges: { id: string; from: number; to: number | null }[]; current: string | undefined; maskId: string | undefined; layer: number; setLayer: (n: number) => void; edit: Edit; onNewMask: () => void }) {
  const { maskId, edit } = p;
  return (
    <section>
      <h4>Masks</h4>
      <table className="masks">
        <tbody>
          {p.ranges.map((m) => (
            <tr key={m.id} className={p.current === m.id ? "current" : ""} data-mask={m.id}>
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
      {!p.ranges.length && <div className="muted">No masks: each connected region is a section.</div>}
      <button onClick={p.onNewMask} disabled={!maskId} data-testid="new-mask">
        new mask from layer {p.layer}
      </button>
    </section>
  );
}

export interface SectionItemProps {
  sectionKey: string;
  color: string;
  selected: boolean;
  onSelect: () => void;
  area: number | undefined;
  length: number | undefined;
  strategy: KeyedParams;
  zone: KeyedParams;
  guides: GuideParams;
  ids: { strategy?: string; zone?: string; guide?: string };
  patterns: string[];
  patternDefault: string | undefined;
  mask: Mask | undefined;
  edit: Edit;
  onRemove: () => void;
}

/** One section of the side panel: area and path length, strategy, start / end lengths, guide and splits. */
export function SectionItem(p: SectionItemProps) {
  const { sectionKey: key, strategy, zone, edit, ids } = p;
  const st = String(sectionValue(strategy, key, "pattern") ?? "");
  const splits = (sectionValue(zone, key, "split_points") as unknown[] | undefined)?.length ?? 0;
  return (
    <div className={`section-item ${p.selected ? "selected" : ""}`} data-section-item={key} onClick={p.onSelect}>
      <div className="section-head">
        <span className="swatch" style={{ background: p.color }} />
        <b>{key}</b>
        <span className="muted">
          {p.area !== undefined ? `${p.area.toFixed(0)} mm²` : "—"}
          {p.length !== undefined ? ` · path ${p.length.toFixed(0)} mm` : ""}
        </span>
      </div>
      <div className="section-fields">
        <label>
          strategy
          <select
            value={strategy.sections?.[key]?.pattern !== undefined ? st : ""}
            disabled={!ids.strategy}
            onChange={(e) => edit(ids.strategy, (s) => patchSection(s as KeyedParams, key, { pattern: e.target.value || undefined }))}
            data-testid={`strategy-${key}`}
          >
            <option value="">default ({String(strategy.default?.pattern ?? p.patternDefault ?? "—")})</option>
            {p.patterns.map((x) => (
              <option key={x} value={x}>
                {x}
              </option>
            ))}
          </select>
        </label>
        <label>
          start
          <LengthInput value={sectionValue(zone, key, "start_length")} disabled={!ids.zone} testid={`start-${key}`} onChange={(v) => edit(ids.zone, (z) => patchSection(z as KeyedParams, key, { start_length: v }))} />
          mm
        </label>
        <label>
          end
          <LengthInput value={sectionValue(zone, key, "end_length")} disabled={!ids.zone} testid={`end-${key}`} onChange={(v) => edit(ids.zone, (z) => patchSection(z as KeyedParams, key, { end_length: v }))} />
          mm
        </label>
      </div>
      <div className="section-fields">
        <span className="muted">guide: {p.guides.guides?.[key] ? "drawn" : "auto (long axis)"}</span>
        {p.guides.guides?.[key] && <button onClick={() => edit(ids.guide, (g) => setGuide(g as GuideParams, key, null))}>clear guide</button>}
        <span className="muted">splits: {splits}</span>
        {splits > 0 && <button onClick={() => edit(ids.zone, (z) => patchSection(z as KeyedParams, key, { split_points: [] }))}>clear</button>}
        {p.mask && splitKey(key).mask === p.mask.id && <button onClick={p.onRemove}>delete</button>}
      </div>
    </div>
  );
}

export const sectionColor = (i: number) => SECTION_COLORS[i % SECTION_COLORS.length];

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
