/** The zone-parameter XML editor: layer > section > zone tree, per-zone tables, bulk edit, import/export. */
import { useCallback, useEffect, useMemo, useState } from "react";
import { ApiError, artifactText, getParams, putParams } from "../api/client";
import type { ProcessParameter, RunError, RunEvent } from "../api/types";
import {
  boundsByName, bulkSet, invalidEntries, orphans as findOrphans, parseParams, rangeText, serializeParams, setValue, validateValue, vocabulary,
  type Bounds, type ParamDoc,
} from "./params";

export interface ParamsEditorProps {
  graph: string | null;
  /** The latest finished run and the zone-parameter artifacts it wrote (`<zone node>.params.xml`). */
  runId: string | null;
  runParamsArtifacts: string[];
  /** Warnings of the zone node(s) in the last run: values dropped with vanished zones are reported there. */
  runWarnings: RunEvent[];
  /** The server's parameter table (GET /api/process-parameters): labels, units and bounds. */
  parameters: readonly ProcessParameter[];
  dirtyRecipe: boolean;
  onMessage: (m: string) => void;
}

export function ParamsEditor(p: ParamsEditorProps) {
  const [original, setOriginal] = useState<string | null>(null);
  const [doc, setDoc] = useState<ParamDoc | null>(null);
  const [dirty, setDirty] = useState(false);
  const [serverError, setServerError] = useState<(RunError & Record<string, unknown>) | null>(null);
  const [loadError, setLoadError] = useState<string | null>(null);
  const [sel, setSel] = useState<{ layer: number; section: string } | null>(null);
  const [current, setCurrent] = useState<ParamDoc | null>(null);
  const [saved, setSaved] = useState<string>("");

  const load = useCallback(async () => {
    setLoadError(null);
    setServerError(null);
    if (!p.graph) {
      setOriginal(null);
      setDoc(null);
      return;
    }
    try {
      const text = await getParams(p.graph);
      if (text === null) {
        setOriginal(null);
        setDoc(null);
        setLoadError("This graph has no parameter file yet: run it once to create the template.");
        return;
      }
      const d = parseParams(text);
      setOriginal(text);
      setDoc(d);
      setDirty(false);
      setSel((s) => s ?? (d.layers[0]?.sections[0] ? { layer: d.layers[0].index, section: d.layers[0].sections[0].id } : null));
    } catch (e) {
      setLoadError(e instanceof ApiError ? e.detail.message : String(e));
    }
  }, [p.graph]);

  useEffect(() => {
    void load();
  }, [load, p.runId]);

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
    setDoc(d);
    setDirty(true);
  };

  const save = async () => {
    if (!p.graph || !doc || original === null) return;
    // Checked here first (the server checks the same): nothing is sent while a value is invalid.
    // The cells are marked by their own check, so the message names no layer/section to mark.
    if (invalid.length) {
      const [f] = invalid;
      setServerError({
        message: `not saved: ${invalid.length} invalid value(s), e.g. layer ${f.layer} · ${f.section} · ${f.zone} · ${f.name}: ${f.message}; fix the fields marked in red`,
      });
      return;
    }
    const text = serializeParams(original, doc);
    try {
      await putParams(p.graph, text);
      setOriginal(text);
      setDirty(false);
      setServerError(null);
      setSaved(new Date().toLocaleTimeString());
    } catch (e) {
      setServerError(e instanceof ApiError ? e.detail : { message: String(e) });
    }
  };

  const importFile = async (f: File) => {
    const text = await f.text();
    try {
      const d = parseParams(text);
      setOriginal(text);
      setDoc(d);
      setDirty(true);
      setServerError(null);
    } catch (e) {
      setServerError({ message: `import: ${(e as Error).message}` });
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
        <button onClick={save} disabled={!doc || !dirty} data-testid="params-save">
          save
        </button>
        <button onClick={() => void load()} disabled={!p.graph}>
          reload
        </button>
        <label className="button">
          import
          <input type="file" accept=".xml,application/xml,text/xml" hidden onChange={(e) => e.target.files?.[0] && void importFile(e.target.files[0])} />
        </label>
        <button onClick={exportFile} disabled={!doc}>
          export
        </button>
        {dirty && <span className="warn">unsaved</span>}
        {!dirty && saved && <span className="ok" data-testid="params-saved">saved {saved}</span>}
        {p.dirtyRecipe && <span className="muted">(the recipe has unsaved changes: run it to refresh the zones)</span>}
      </div>
      {!p.graph && <div className="empty">Save the recipe first: the parameter file belongs to a saved graph.</div>}
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
                              aria-label={`${name}, zone ${z.id}, section ${sectionNode.id}, layer ${layerNode.index}`}
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
