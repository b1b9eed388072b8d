/** The zone-parameter XML editor: layer > section > zone tree, per-zone tables, bulk edit, import/export. */
import { useEffect, useMemo, useState } from "react";
import { artifactText } from "../api/client";
import type { ProcessParameter, RunError, RunEvent } from "../api/types";
import {
  boundsByName, bulkSet, invalidEntries, orphans as findOrphans, parseParams, rangeText, serializeParams, setValue, validateValue, vocabulary,
  type Bounds, type ParamDoc,
} from "./params";

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
  const parsed = useMemo((): { doc: ParamDoc | null; error: string | null } => {
    if (p.text === null) return { doc: null, error: null };
    try {
      return { doc: parseParams(p.text), error: null };
    } catch (e) {
      return { doc: null, error: (e as Error).message };
    }
  }, [p.text]);
  const doc = parsed.doc;
  const original = p.text;
  const [importError, setImportError] = useState<string | null>(null);
  const serverError = p.serverError ?? (importError ? { message: importError } : null);
  const loadError = p.loadError ?? parsed.error;
  const [sel, setSel] = useState<{ layer: number; section: string } | null>(null);
  const [current, setCurrent] = useState<ParamDoc | null>(null);

  useEffect(() => {
    if (doc && !sel && doc.layers[0]?.sections[0]) setSel({ layer: doc.layers[0].index, section: doc.layers[0].sections[0].id });
  }, [doc, sel]);

  // What the last run's geometry has: values of ours outside it are orphans.
  useEffect(() => {
    setCurrent(null);
    if (!p.runId || !p.runParamsArtifacts.length) return;
    void artifactText(p.runId, p.runParamsArtifacts[0]).then((t) => {
      if (!t) return;
      try {
        setCurrent(parseParams(t));
      } catch {
        /* shown by the artifact itself */
      }
    });
  }, [p.runId, p.runParamsArtifacts]);

  const bounds = useMemo(() => boundsByName(p.parameters), [p.parameters]);
  const voc = useMemo(() => (doc ? vocabulary(doc) : { sections: [], zones: [], params: [] }), [doc]);
  const invalid = useMemo(() => (doc ? invalidEntries(doc, bounds) : []), [doc, bounds]);
  const orphans = useMemo(() => (doc && current ? findOrphans(doc, current) : []), [doc, current]);

  const change = (d: ParamDoc) => {
    if (original === null) return;
    setImportError(null);
    p.onChange(serializeParams(original, d));
  };

  const importFile = async (f: File) => {
    const text = await f.text();
    try {
      parseParams(text);
      setImportError(null);
      p.onChange(text);
    } catch (e) {
      setImportError(`import: ${(e as Error).message}`);
    }
  };

  const exportFile = () => {
    if (!doc || original === null) return;
    const blob = new Blob([serializeParams(original, doc)], { type: "application/xml" });
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = `${p.graph ?? "parameters"}.params.xml`;
    a.click();
    setTimeout(() => URL.revokeObjectURL(a.href), 1000);
  };

  const layerNode = doc?.layers.find((l) => l.index === sel?.layer);
  const sectionNode = layerNode?.sections.find((s) => s.id === sel?.section);
  // The server names layer and section; zone and parameter come in its field or message.
  const serverCell = (layer: number, section: string, zone: string, name: string) => {
    if (!serverError || serverError.layer !== layer || serverError.section !== section) return false;
    const text = `${String(serverError.field ?? "")} ${serverError.message}`;
    const z = (typeof serverError.zone === "string" ? serverError.zone : text.match(/zone '([^']+)'/)?.[1]) ?? null;
    return (z === null || z === zone) && new RegExp(`\\b${name}\\b`).test(text);
  };
  const errAt = (layer: number, section?: string) =>
    serverError && serverError.layer === layer && (section === undefined || serverError.section === section || !serverError.section);

  return (
    <div className="params-editor" data-testid="params-editor">
      <div className="pe-toolbar">
        <b>Zone parameters</b>
        <span className="muted">{p.graph ? `${p.graph} · ` : ""}{doc ? `${doc.layers.length} layers` : ""}</span>
        <button onClick={p.onSave} disabled={!doc || !p.unsaved} data-testid="params-save" title="save the recipe and this XML together">
          save
        </button>
        <button onClick={p.onDiscard} disabled={!p.unsaved} data-testid="params-discard" title="drop the unsaved XML: back to the saved file">
          discard draft
        </button>
        <label className="button">
          import
          <input
            type="file"
            accept=".xml,application/xml,text/xml"
            hidden
            onChange={(e) => {
              const f = e.target.files?.[0];
              e.target.value = "";
              if (f) void importFile(f);
            }}
          />
        </label>
        <button onClick={exportFile} disabled={!doc}>
          export
        </button>
        {p.unsaved ? (
          <span className="warn" data-testid="params-unsaved">unsaved: saved with the recipe</span>
        ) : (
          doc && <span className="ok" data-testid="params-saved">saved</span>
        )}
        {p.dirtyRecipe && <span className="muted">(the recipe has unsaved changes: run it to refresh the zones)</span>}
      </div>
      {!p.graph && !doc && <div className="empty">Run the recipe to create the parameter template; it is saved with the recipe.</div>}
      {loadError && <div className="empty">{loadError}</div>}
      {serverError && (
        <div className="error-box" data-testid="params-error">
          {serverError.layer != null && <>layer {String(serverError.layer)} </>}
          {serverError.section && <>section {serverError.section} </>}
          {typeof serverError.zone === "string" && <>zone {serverError.zone} </>}
          {serverError.message}
        </div>
      )}
      {doc && (
        <div className="pe-body">
          <div className="pe-tree" data-testid="params-tree">
            {doc.layers.map((l) => (
              <details key={l.index} open={sel?.layer === l.index} className={errAt(l.index) ? "err" : ""}>
                <summary>
                  layer {l.index} <span className="muted">z {l.z}</span>
                </summary>
                {l.sections.map((s) => (
                  <div
                    key={s.id}
                    className={`pe-section ${sel?.layer === l.index && sel.section === s.id ? "selected" : ""} ${errAt(l.index, s.id) ? "err" : ""}`}
                    onClick={() => setSel({ layer: l.index, section: s.id })}
                    data-tree-section={`${l.index}|${s.id}`}
                  >
                    {s.id}
                    <span className="zones">
                      {s.zones.map((z) => (
                        <span key={z.id} className="swatch" title={z.id} style={{ background: z.color }} />
                      ))}
                    </span>
                  </div>
                ))}
              </details>
            ))}
          </div>
          <div className="pe-main">
            {sectionNode && layerNode && (
              <table className="pe-table" data-testid="zone-table">
                <thead>
                  <tr>
                    <th>
                      layer {layerNode.index} · {sectionNode.id}
                    </th>
                    {sectionNode.zones.map((z) => (
                      <th key={z.id}>
                        <span className="swatch" style={{ background: z.color }} /> {z.id}
                      </th>
                    ))}
                  </tr>
                </thead>
                <tbody>
                  {voc.params.map(({ name, unit }) => (
                    <tr key={name}>
                      <td title={bounds[name] ? `${name}: ${bounds[name].description ?? ""} (${rangeText(bounds[name])})` : `${name}: not a known parameter`}>
                        {bounds[name]?.label ?? name} <span className="unit">[{unit || "–"}]</span>
                        {bounds[name] && <div className="muted range" data-range={name}>{rangeText(bounds[name])}</div>}
                      </td>
                      {sectionNode.zones.map((z) => {
                        const pv = z.params.find((x) => x.name === name);
                        if (!pv) return <td key={z.id} className="muted">–</td>;
                        const m = validateValue(pv.value, bounds[name], pv.unit);
                        const bad = m || serverCell(layerNode.index, sectionNode.id, z.id, name);
                        return (
                          <td key={z.id} className={bad ? "err" : ""} data-err={bad ? "1" : undefined}>
                            <input
                              value={pv.value}
                              data-cell={`${z.id}.${name}`}
                              onChange={(e) => change(setValue(doc, layerNode.index, sectionNode.id, z.id, name, e.target.value))}
                              title={m ?? (bounds[name] ? rangeText(bounds[name]) : unit)}
                              aria-invalid={m ? true : undefined}
                            />
                            {m && <div className="error" data-cell-error={`${z.id}.${name}`}>{m}</div>}
                          </td>
                        );
                      })}
                    </tr>
                  ))}
                </tbody>
              </table>
            )}
            <BulkEdit doc={doc} voc={voc} bounds={bounds} onApply={(d, n) => {
              change(d);
              p.onMessage(`set ${n} value(s)`);
            }} />
            {invalid.length > 0 && (
              <div className="error-box">
                {invalid.length} invalid value(s), e.g. layer {invalid[0].layer} {invalid[0].section} {invalid[0].zone} {invalid[0].name}: {invalid[0].message}
              </div>
            )}
            <div className="orphans" data-testid="orphans">
              <h4>Orphaned values and zone warnings</h4>
              {!current && !p.runWarnings.length && <div className="muted">Run the recipe to compare these values with the current geometry.</div>}
              {p.runWarnings.map((w) => (
                <div key={w.seq} className="orphan">
                  {w.layer != null ? `layer ${w.layer} · ` : ""}
                  {w.section ? `${w.section} · ` : ""}
                  {w.message}
                </div>
              ))}
              {current && !orphans.length && !p.runWarnings.length && <div className="muted">None: every filled value has its layer/section/zone.</div>}
              {orphans.map((o) => (
                <div key={`${o.layer}|${o.section}|${o.zone}`} className="orphan">
                  layer {o.layer} · {o.section} · {o.zone}: {o.values.map((v) => `${v.name}=${v.value}${v.unit ? " " + v.unit : ""}`).join(", ")}
                </div>
              ))}
            </div>
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
      <select value={name} onChange={(e) => setName(e.target.value)} data-testid="bulk-param">
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
        data-testid="bulk-value"
        title={bounds[name] ? rangeText(bounds[name]) : unit}
        aria-invalid={problem ? true : undefined}
        className={problem ? "bad" : ""}
      />{" "}
      {unit}
      {problem && <span className="error" data-testid="bulk-error"> {problem}</span>}
      <span> layers </span>
      <input type="number" value={from} onChange={(e) => setFrom(Number(e.target.value))} style={{ width: 48 }} />–
      <input type="number" value={to} onChange={(e) => setTo(Number(e.target.value))} style={{ width: 48 }} />
      <select value={section} onChange={(e) => setSection(e.target.value)} data-testid="bulk-section">
        <option value="">all sections</option>
        {voc.sections.map((s) => (
          <option key={s}>{s}</option>
        ))}
      </select>
      <select value={zone} onChange={(e) => setZone(e.target.value)} data-testid="bulk-zone">
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
