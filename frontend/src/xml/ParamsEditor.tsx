/** The zone-parameter XML editor: layer > section > zone tree, per-zone tables, bulk edit, import/export. */
import { useMemo, useState } from "react";
import type { ProcessParameter, RunError, RunEvent } from "../api/types";
import {
  boundsByName, bulkSet, invalidEntries, orphans as findOrphans, rangeText, validateValue, vocabulary, type Bounds, type ParamDoc,
} from "./params";
import { useDraftFiles, useParsedDoc, useRunParams, useTreeSelection, type ServerError } from "./useParamsEditor";
import { Orphans, ParamsToolbar, ParamsTree, ServerErrorBox, ZoneTable } from "./ParamsParts";

export interface ParamsEditorProps {
  graph: string | null;
  /**
   * The XML shown: the draft when there is one (unsaved edits, or the merged XML of the last run),
   * else the saved file; null when the graph has none yet.
   */
  text: string | null;
  /** True while `text` differs from the saved file (it is saved with the recipe). */
  unsaved: boolean;
  /** Why there is no text (e.g. the graph has no parameter file yet). */
  loadError: string | null;
  /** The latest finished run and the zone-parameter artifacts it wrote (`<zone node>.params.xml`). */
  runId: string | null;
  runParamsArtifacts: string[];
  /** Warnings of the zone node(s) in the last run: values dropped with vanished zones are reported there. */
  runWarnings: RunEvent[];
  /** The server's parameter table (GET /api/process-parameters): labels, units and bounds. */
  parameters: readonly ProcessParameter[];
  dirtyRecipe: boolean;
  /** Edits replace the draft text; nothing is sent to the server until the recipe is saved. */
  onChange: (text: string) => void;
  /** Save recipe and XML together (the toolbar's save). */
  onSave: () => void;
  /** Drop the draft: back to the saved file. */
  onDiscard: () => void;
  /** An error of the last save, naming layer/section/zone when the server did. */
  serverError: (RunError & Record<string, unknown>) | null;
  onMessage: (m: string) => void;
}

export function ParamsEditor(p: ParamsEditorProps) {
  const parsed = useParsedDoc(p.text);
  const doc = parsed.doc;
  const files = useDraftFiles(p.text, doc, p.graph, p.onChange);
  const serverError: ServerError | null = p.serverError ?? (files.importError ? { message: files.importError } : null);
  const loadError = p.loadError ?? parsed.error;
  const [sel, setSel] = useTreeSelection(doc);
  const current = useRunParams(p.runId, p.runParamsArtifacts);
  const bounds = useMemo(() => boundsByName(p.parameters), [p.parameters]);
  const voc = useMemo(() => (doc ? vocabulary(doc) : { sections: [], zones: [], params: [] }), [doc]);
  const invalid = useMemo(() => (doc ? invalidEntries(doc, bounds) : []), [doc, bounds]);
  const orphans = useMemo(() => (doc && current ? findOrphans(doc, current) : []), [doc, current]);
  const layerNode = doc?.layers.find((l) => l.index === sel?.layer);
  const sectionNode = layerNode?.sections.find((s) => s.id === sel?.section);

  return (
    <div className="params-editor" data-testid="params-editor">
      <ParamsToolbar graph={p.graph} doc={doc} unsaved={p.unsaved} dirtyRecipe={p.dirtyRecipe} onSave={p.onSave} onDiscard={p.onDiscard} importFile={files.importFile} exportFile={files.exportFile} />
      {!p.graph && !doc && <div className="empty">Run the recipe to create the parameter template; it is saved with the recipe.</div>}
      {loadError && <div className="empty">{loadError}</div>}
      {serverError && <ServerErrorBox serverError={serverError} />}
      {doc && (
        <div className="pe-body">
          <ParamsTree doc={doc} sel={sel} setSel={setSel} serverError={serverError} />
          <div className="pe-main">
            {sectionNode && layerNode && <ZoneTable doc={doc} layerNode={layerNode} sectionNode={sectionNode} voc={voc} bounds={bounds} serverError={serverError} change={files.change} />}
            <BulkEdit doc={doc} voc={voc} bounds={bounds} onApply={(d, n) => {
              files.change(d);
              p.onMessage(`set ${n} value(s)`);
            }} />
            {invalid.length > 0 && (
              <div className="error-box">
                {invalid.length} invalid value(s), e.g. layer {invalid[0].layer} {invalid[0].section} {invalid[0].zone} {invalid[0].name}: {invalid[0].message}
              </div>
            )}
            <Orphans current={current} orphans={orphans} runWarnings={p.runWarnings} />
          </div>
        </div>
      )}
    </div>
  );
}

function BulkEdit({ doc, voc, bounds, onApply }: {
  doc: ParamDoc;
  voc: ReturnType<typeof vocabulary>;
  bounds: Record<string, Bounds>;
  onApply: (d: ParamDoc, count: number) => void;
}) {
  const idx = doc.layers.map((l) => l.index);
  const [name, setName] = useState(voc.params[0]?.name ?? "");
  const [value, setValueText] = useState("");
  const [from, setFrom] = useState(Math.min(...idx));
  const [to, setTo] = useState(Math.max(...idx));
  const [section, setSection] = useState("");
  const [zone, setZone] = useState("");
  const unit = voc.params.find((x) => x.name === name)?.unit;
  const problem = validateValue(value, bounds[name]);
  return (
    <div className="bulk" data-testid="bulk-edit">
      <h4>Bulk edit</h4>
      <select aria-label="parameter to set" value={name} onChange={(e) => setName(e.target.value)} data-testid="bulk-param">
        {voc.params.map((x) => (
          <option key={x.name} value={x.name}>
            {bounds[x.name]?.label ?? x.name}
          </option>
        ))}
      </select>
      ={" "}
      <input
        value={value}
        onChange={(e) => setValueText(e.target.value)}
        style={{ width: 70 }}
        data-testid="bulk-value" aria-label="value to set"
        title={bounds[name] ? rangeText(bounds[name]) : unit}
        aria-invalid={problem ? true : undefined}
        className={problem ? "bad" : ""}
      />{" "}
      {unit}
      {problem && <span className="error" data-testid="bulk-error"> {problem}</span>}
      <span> layers </span>
      <input aria-label="from layer" type="number" value={from} onChange={(e) => setFrom(Number(e.target.value))} style={{ width: 48 }} />–
      <input aria-label="to layer" type="number" value={to} onChange={(e) => setTo(Number(e.target.value))} style={{ width: 48 }} />
      <select aria-label="section" value={section} onChange={(e) => setSection(e.target.value)} data-testid="bulk-section">
        <option value="">all sections</option>
        {voc.sections.map((s) => (
          <option key={s}>{s}</option>
        ))}
      </select>
      <select aria-label="zone" value={zone} onChange={(e) => setZone(e.target.value)} data-testid="bulk-zone">
        <option value="">all zones</option>
        {voc.zones.map((z) => (
          <option key={z}>{z}</option>
        ))}
      </select>
      <button
        disabled={!name || problem !== null}
        data-testid="bulk-apply"
        onClick={() => {
          const r = bulkSet(doc, { layers: [from, to], section: section || undefined, zone: zone || undefined }, name, value.trim());
          onApply(r.doc, r.count);
        }}
      >
        apply
      </button>
    </div>
  );
}
