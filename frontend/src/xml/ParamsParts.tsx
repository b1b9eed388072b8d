/** The parameter editor's pieces (presentational: props in, HTML out): toolbar, the layer > section tree, the zone table, orphans and warnings. */
import type { RunEvent } from "../api/types";
import { orphans as findOrphans, rangeText, setValue, validateValue, vocabulary, type Bounds, type ParamDoc } from "./params";
import { errAt, serverCell, type ServerError } from "./useParamsEditor";

export interface ToolbarProps {
  graph: string | null;
  doc: ParamDoc | null;
  unsaved: boolean;
  dirtyRecipe: boolean;
  onSave: () => void;
  onDiscard: () => void;
  importFile: (f: File) => Promise<void>;
  exportFile: () => void;
}

export function ParamsToolbar(p: ToolbarProps) {
  const doc = p.doc;
  return (
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
            if (f) void p.importFile(f);
          }}
        />
      </label>
      <button onClick={p.exportFile} disabled={!doc}>
        export
      </button>
      {p.unsaved ? (
        <span className="warn" data-testid="params-unsaved">unsaved: saved with the recipe</span>
      ) : (
        doc && <span className="ok" data-testid="params-saved">saved</span>
      )}
      {p.dirtyRecipe && <span className="muted">(the recipe has unsaved changes: run it to refresh the zones)</span>}
    </div>
  );
}

export function ServerErrorBox({ serverError }: { serverError: ServerError }) {
  return (
    <div className="error-box" data-testid="params-error">
      {serverError.layer != null && <>layer {String(serverError.layer)} </>}
      {serverError.section && <>section {serverError.section} </>}
      {typeof serverError.zone === "string" && <>zone {serverError.zone} </>}
      {serverError.message}
    </div>
  );
}

type Sel = { layer: number; section: string } | null;

/** Layers, each with its sections and their zone colours; a click shows the section's table. */
export function ParamsTree({ doc, sel, setSel, serverError }: { doc: ParamDoc; sel: Sel; setSel: (s: Sel) => void; serverError: ServerError | null }) {
  return (
    <div className="pe-tree" data-testid="params-tree">
      {doc.layers.map((l) => (
        <details key={l.index} open={sel?.layer === l.index} className={errAt(serverError, l.index) ? "err" : ""}>
          <summary>
            layer {l.index} <span className="muted">z {l.z}</span>
          </summary>
          {l.sections.map((s) => (
            <div
              key={s.id}
              className={`pe-section ${sel?.layer === l.index && sel.section === s.id ? "selected" : ""} ${errAt(serverError, l.index, s.id) ? "err" : ""}`}
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
  );
}

export interface ZoneTableProps {
  doc: ParamDoc;
  layerNode: ParamDoc["layers"][number];
  sectionNode: ParamDoc["layers"][number]["sections"][number];
  voc: ReturnType<typeof vocabulary>;
  bounds: Record<string, Bounds>;
  serverError: ServerError | null;
  change: (d: ParamDoc) => void;
}

/** One section's zones (columns) × parameters (rows), each value checked against its bounds as typed. */
export function ZoneTable({ doc, layerNode, sectionNode, voc, bounds, serverError, change }: ZoneTableProps) {
  return (
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
              const bad = m || serverCell(serverError, layerNode.index, sectionNode.id, z.id, name);
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
  );
}

/** Values of ours the last run's geometry no longer has, and the zone node's warnings. */
export function Orphans({ current, orphans, runWarnings }: { current: ParamDoc | null; orphans: ReturnType<typeof findOrphans>; runWarnings: RunEvent[] }) {
  return (
    <div className="orphans" data-testid="orphans">
      <h4>Orphaned values and zone warnings</h4>
      {!current && !runWarnings.length && <div className="muted">Run the recipe to compare these values with the current geometry.</div>}
      {runWarnings.map((w) => (
        <div key={w.seq} className="orphan">
          {w.layer != null ? `layer ${w.layer} · ` : ""}
          {w.section ? `${w.section} · ` : ""}
          {w.message}
        </div>
      ))}
      {current && !orphans.length && !runWarnings.length && <div className="muted">None: every filled value has its layer/section/zone.</div>}
      {orphans.map((o) => (
        <div key={`${o.layer}|${o.section}|${o.zone}`} className="orphan">
          layer {o.layer} · {o.section} · {o.zone}: {o.values.map((v) => `${v.name}=${v.value}${v.unit ? " " + v.unit : ""}`).join(", ")}
        </div>
      ))}
    </div>
  );
}
