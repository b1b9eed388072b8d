import { memo, useEffect, useMemo, useState } from "react";
import type { JSONSchema } from "../api/types";
import { boundsText, describeFields, enrichFromRoot, fieldKind, parseNumberInput, unwrapNullable, validateField, type FieldSpec } from "./schema";
import { sectionChoices, useSectionFocus, useSectionKeys } from "./sectionKeys";

export interface ParamFormProps {
  schema: JSONSchema;
  params: Record<string, unknown>;
  onChange: (params: Record<string, unknown>) => void;
  /** Upload a file for an `x-file` param; resolves to the name to store in the param. */
  onUpload?: (file: File) => Promise<string | null>;
  idPrefix?: string;
}

type Upload = ((file: File) => Promise<string | null>) | undefined;
const STRUCTURED = new Set(["object", "map", "points", "list", "vector"]);

/**
 * A parameter form generated from a node's JSON Schema: one row per field, units and bounds shown.
 * Nested models become sub-forms, per-section maps a section picker with the form of the picked
 * section, point lists an editable table, fixed-length vectors one input per component.
 */
export const ParamForm = memo(function ParamForm({ schema, params, onChange, onUpload, idPrefix = "p" }: ParamFormProps) {
  const fields = useMemo(() => describeFields(schema), [schema]);
  const unknown = Object.keys(params).filter((k) => !fields.some((f) => f.name === k));
  return (
    <div className="param-form">
      <ObjectFields root={schema} fields={fields} value={params} onChange={(v) => onChange(v ?? {})} onUpload={onUpload} id={idPrefix} />
      {unknown.map((k) => (
        <div className="field err" key={k}>
          <span className="label">{k}</span>
          <span className="error">unknown parameter</span>
          <button
            aria-label={`remove unknown parameter ${k}`}
            onClick={() => {
              const next = { ...params };
              delete next[k];
              onChange(next);
            }}
          >
            remove
          </button>
        </div>
      ))}
    </div>
  );
});

/** Set `key` of an object value; an emptied object becomes "unset" (the defaults apply). */
function setKey(obj: unknown, key: string, v: unknown, keepEmpty = false): Record<string, unknown> | undefined {
  const next = { ...((obj && typeof obj === "object" ? obj : {}) as Record<string, unknown>) };
  if (v === undefined) delete next[key];
  else next[key] = v;
  return Object.keys(next).length || keepEmpty ? next : undefined;
}

function ObjectFields({ root, fields, value, onChange, onUpload, id, keepEmpty = true }: { root: JSONSchema; fields: FieldSpec[]; value: unknown; onChange: (v: Record<string, unknown> | undefined) => void; onUpload: Upload; id: string; keepEmpty?: boolean }) {
  const obj = (value && typeof value === "object" ? value : {}) as Record<string, unknown>;
  return (
    <>
      {fields.map((f) => (
        <FieldRow key={f.name} root={root} f={f} value={obj[f.name]} onChange={(v) => onChange(setKey(obj, f.name, v, keepEmpty))} onUpload={onUpload} id={`${id}-${f.name}`} />
      ))}
    </>
  );
}

function FieldRow({ root, f, value, onChange, onUpload, id }: { root: JSONSchema; f: FieldSpec; value: unknown; onChange: (v: unknown) => void; onUpload: Upload; id: string }) {
  const [asJson, setAsJson] = useState(false);
  const err = STRUCTURED.has(f.kind) ? null : validateField(f, value);
  const shown = value === undefined ? f.default : value;
  const hint = err ?? [boundsText(f), f.description].filter(Boolean).join(" — ");
  if (STRUCTURED.has(f.kind))
    return (
      <fieldset className={`field group k-${f.kind}`} data-field={f.name}>
        <legend title={f.description}>
          {f.title}
          {f.unit && <span className="unit"> [{f.unit}]</span>}
          <button type="button" className="link small" aria-pressed={asJson} aria-label={`edit ${f.title} as JSON`} onClick={() => setAsJson(!asJson)}>
            {asJson ? "form" : "JSON"}
          </button>
        </legend>
        {f.description && <div className="hint">{f.description}</div>}
        {asJson ? <JsonInput id={id} label={f.title} value={value} placeholder={shown} onChange={onChange} /> : <Control root={root} f={f} value={value} shown={shown} onChange={onChange} onUpload={onUpload} id={id} />}
      </fieldset>
    );
  return (
    <div className={`field ${err ? "err" : ""}`} data-field={f.name}>
      <label htmlFor={id} title={f.description}>
        {f.title}
        {f.unit && <span className="unit"> [{f.unit}]</span>}
      </label>
      <div className="control">
        <Control root={root} f={f} value={value} shown={shown} onChange={onChange} onUpload={onUpload} id={id} />
      </div>
      {hint && <div className={err ? "error" : "hint"}>{hint}</div>}
    </div>
  );
}

const OTHER = "\u0000other";

/** A string field with names to pick from (the catalog's shipped cells, robots, machine profiles,
 * materials): a list, and "other…" for a value of the user's own (a cell file path, a material). */
function Picker({ id, f, value, shown, onChange }: { id: string; f: FieldSpec; value: unknown; shown: unknown; onChange: (v: unknown) => void }) {
  const v = typeof value === "string" ? value : "";
  const list = f.suggestions ?? [];
  const [other, setOther] = useState(v !== "" && !list.includes(v));
  const isOther = other || (v !== "" && !list.includes(v));
  return (
    <div className="picker">
      <select id={id} value={isOther ? OTHER : v} onChange={(e) => {
        const x = e.target.value;
        if (x === OTHER) return setOther(true);
        setOther(false);
        onChange(x === "" ? undefined : x);
      }}>
        <option value="">{typeof shown === "string" && shown ? `default (${shown})` : "— none —"}</option>
        {list.map((o) => (
          <option key={o} value={o}>
            {o}
          </option>
        ))}
        <option value={OTHER}>other…</option>
      </select>
      {isOther && <input type="text" aria-label={`${f.title}: your own value`} value={v} onChange={(e) => onChange(e.target.value === "" ? undefined : e.target.value)} />}
    </div>
  );
}

function Control({ root, f, value, shown, onChange, onUpload, id }: { root: JSONSchema; f: FieldSpec; value: unknown; shown: unknown; onChange: (v: unknown) => void; onUpload: Upload; id: string }) {
  switch (f.kind) {
    case "number":
    case "integer":
      return <NumberInput id={id} value={value} placeholder={shown === undefined || shown === null ? "" : String(shown)} onChange={onChange} nullable={f.nullable} />;
    case "boolean":
      return <input id={id} type="checkbox" checked={Boolean(shown)} onChange={(e) => onChange(e.target.checked)} />;
    case "enum":
      return (
        <select id={id} value={value === undefined || value === null ? "" : JSON.stringify(value)} onChange={(e) => onChange(e.target.value === "" ? undefined : JSON.parse(e.target.value))}>
          <option value="">{shown !== undefined && shown !== null ? `default (${String(shown)})` : "— default —"}</option>
          {f.options?.map((o) => (
            <option key={JSON.stringify(o)} value={JSON.stringify(o)}>
              {String(o)}
            </option>
          ))}
        </select>
      );
    case "file":
      return <FileControl id={id} value={value} shown={shown} onChange={onChange} onUpload={onUpload} label={f.title} />;
    case "string":
      if (f.suggestions) return <Picker id={id} f={f} value={value} shown={shown} onChange={onChange} />;
      return <input id={id} type="text" value={typeof value === "string" ? value : ""} placeholder={typeof shown === "string" ? shown : ""} onChange={(e) => onChange(e.target.value === "" ? undefined : e.target.value)} />;
    case "object":
      return <ObjectFields root={root} fields={describeFields(root, f.schema)} value={value} onChange={(v) => onChange(v)} onUpload={onUpload} id={id} keepEmpty={false} />;
    case "map":
      return <MapEditor root={root} f={f} value={value} onChange={onChange} onUpload={onUpload} id={id} />;
    case "vector":
      return <VectorInput id={id} label={f.title} dims={(f.schema.prefixItems as unknown[]).length} value={value} shown={shown} onChange={onChange} />;
    case "points":
      return <PointsTable id={id} label={f.title} schema={f.schema} root={root} value={value} onChange={onChange} />;
    case "list":
      return <ListEditor root={root} f={f} value={value} onChange={onChange} onUpload={onUpload} id={id} />;
    default:
      return <JsonInput id={id} label={f.title} value={value} placeholder={shown} onChange={onChange} />;
  }
}

/** The item/value schema of a list or map as a field (so the same widgets edit it). */
function subField(root: JSONSchema, raw: JSONSchema, name: string, title: string): FieldSpec {
  const { schema, nullable } = unwrapNullable(root, raw);
  return enrichFromRoot(root, {
    name, title, description: "", kind: fieldKind(schema, root), unit: schema.unit as string | undefined,
    minimum: schema.minimum, maximum: schema.maximum, exclusiveMinimum: schema.exclusiveMinimum, exclusiveMaximum: schema.exclusiveMaximum,
    options: schema.enum, default: schema.default, hasDefault: "default" in schema, nullable, required: false, schema,
  });
}

/** Section key → value: a picker of the known sections (latest preview) plus keys already set, and the picked one's form. */
function MapEditor({ root, f, value, onChange, onUpload, id }: { root: JSONSchema; f: FieldSpec; value: unknown; onChange: (v: unknown) => void; onUpload: Upload; id: string }) {
  const known = useSectionKeys();
  const obj = (value && typeof value === "object" ? value : {}) as Record<string, unknown>;
  const focus = useSectionFocus();
  const [picked, setPicked] = useState<string>(() => focus?.key ?? Object.keys(obj)[0] ?? sectionChoices(known, [])[0] ?? "");
  // A problem clicked in the problems panel shows its section here.
  useEffect(() => {
    if (focus) setPicked(focus.key);
  }, [focus]);
  const choices = sectionChoices(known, picked ? [...Object.keys(obj), picked] : Object.keys(obj));
  const [newKey, setNewKey] = useState("");
  const key = picked || choices[0] || "";
  const valueSchema = typeof f.schema.additionalProperties === "object" ? f.schema.additionalProperties : {};
  const vf = subField(root, valueSchema, key, `${f.title}: ${key}`);
  const fields = vf.kind === "object" ? describeFields(root, vf.schema).map((x) => enrichFromRoot(root, x)) : null;
  const set = (v: unknown) => onChange(setKey(obj, key, v, false) ?? {});
  return (
    <div className="map-editor">
      <div className="map-picker">
        <label htmlFor={`${id}-key`}>section</label>
        <select id={`${id}-key`} value={key} onChange={(e) => setPicked(e.target.value)}>
          {!choices.length && <option value="">— no sections known: run or preview —</option>}
          {choices.map((k) => (
            <option key={k} value={k}>
              {k}
              {k in obj ? " • set" : ""}
            </option>
          ))}
        </select>
        {key in obj && (
          <button type="button" className="small" aria-label={`remove the setting for section ${key}`} onClick={() => onChange(setKey(obj, key, undefined, true))}>
            remove
          </button>
        )}
      </div>
      <div className="map-add">
        <input aria-label={`other section key for ${f.title}`} placeholder="other section key" value={newKey} onChange={(e) => setNewKey(e.target.value)} />
        <button
          type="button"
          className="small"
          disabled={!newKey.trim() || newKey in obj}
          onClick={() => {
            setPicked(newKey.trim());
            setNewKey("");
          }}
        >
          pick
        </button>
      </div>
      {key && (
        <div className="map-value" data-section={key}>
          {fields ? (
            <ObjectFields root={root} fields={fields} value={obj[key]} onChange={(v) => set(v)} onUpload={onUpload} id={`${id}-${slugId(key)}`} keepEmpty={false} />
          ) : (
            <FieldRow root={root} f={{ ...vf, title: key }} value={obj[key]} onChange={set} onUpload={onUpload} id={`${id}-${slugId(key)}`} />
          )}
        </div>
      )}
    </div>
  );
}

const slugId = (k: string) => k.replace(/[^A-Za-z0-9_-]/g, "_");
const AXES = ["x", "y", "z", "w"];

function VectorInput({ id, label, dims, value, shown, onChange }: { id: string; label: string; dims: number; value: unknown; shown: unknown; onChange: (v: unknown) => void }) {
  const cur = Array.isArray(value) ? (value as unknown[]) : null;
  const base = (Array.isArray(shown) ? shown : Array(dims).fill(0)) as unknown[];
  return (
    <span className="vector">
      {Array.from({ length: dims }, (_, i) => (
        <NumberInput
          key={i}
          id={i === 0 ? id : `${id}-${i}`}
          label={`${label} ${AXES[i] ?? i}`}
          value={cur ? cur[i] : undefined}
          placeholder={String(base[i] ?? "")}
          nullable={false}
          onChange={(v) => {
            const next = [...(cur ?? base)];
            next[i] = v === undefined ? base[i] ?? 0 : v;
            onChange(next);
          }}
        />
      ))}
    </span>
  );
}

/** A list of (x, y[, z]) points as a table: edit cells, add a row, remove a row. */
function PointsTable({ id, label, schema, root, value, onChange }: { id: string; label: string; schema: JSONSchema; root: JSONSchema; value: unknown; onChange: (v: unknown) => void }) {
  const dims = Math.max(2, ((unwrapNullable(root, schema.items ?? {}).schema.prefixItems as unknown[]) ?? []).length);
  const rows = (Array.isArray(value) ? value : []) as number[][];
  const set = (next: number[][]) => onChange(next.length ? next : undefined);
  return (
    <div className="points">
      <table>
        <thead>
          <tr>
            <th scope="col">#</th>
            {Array.from({ length: dims }, (_, i) => (
              <th scope="col" key={i}>
                {AXES[i]}
              </th>
            ))}
            <th scope="col">
              <span className="sr-only">actions</span>
            </th>
          </tr>
        </thead>
        <tbody>
          {rows.map((row, r) => (
            <tr key={r}>
              <td>{r + 1}</td>
              {Array.from({ length: dims }, (_, i) => (
                <td key={i}>
                  <NumberInput
                    id={`${id}-${r}-${i}`}
                    label={`${label} point ${r + 1} ${AXES[i]}`}
                    value={row[i]}
                    placeholder="0"
                    nullable={false}
                    onChange={(v) => set(rows.map((p, k) => (k === r ? p.map((c, j) => (j === i ? (typeof v === "number" ? v : 0) : c)) : p)))}
                  />
                </td>
              ))}
              <td>
                <button type="button" className="small" aria-label={`remove ${label} point ${r + 1}`} onClick={() => set(rows.filter((_, k) => k !== r))}>
                  ✕
                </button>
              </td>
            </tr>
          ))}
        </tbody>
      </table>
      <button type="button" className="small" aria-label={`add a point to ${label}`} onClick={() => set([...rows, rows.length ? [...rows[rows.length - 1]] : Array(dims).fill(0)])}>
        + point
      </button>
    </div>
  );
}

/** A list of scalars or of models: one row (or sub-form) per item, add/remove. */
function ListEditor({ root, f, value, onChange, onUpload, id }: { root: JSONSchema; f: FieldSpec; value: unknown; onChange: (v: unknown) => void; onUpload: Upload; id: string }) {
  const items = (Array.isArray(value) ? value : Array.isArray(f.default) ? f.default : []) as unknown[];
  const itemField = (i: number) => subField(root, f.schema.items ?? {}, String(i), `${f.title} ${i + 1}`);
  const blank = (): unknown => {
    const k = itemField(0);
    if (k.default !== undefined) return k.default;
    return { number: 0, integer: 0, string: "", boolean: false, enum: k.options?.[0], object: {}, map: {}, points: [], list: [], vector: Array((k.schema.prefixItems as unknown[] | undefined)?.length ?? 2).fill(0) }[k.kind as string] ?? null;
  };
  const set = (next: unknown[]) => onChange(next);
  return (
    <div className="list-editor">
      {items.map((it, i) => {
        const itemId = it && typeof it === "object" && typeof (it as { id?: unknown }).id === "string" ? (it as { id: string }).id : "";
        const fi = { ...itemField(i), title: `${f.title} ${i + 1}${itemId ? `: ${itemId}` : ""}` };
        return (
          <div className="list-item" key={i}>
            <FieldRow root={root} f={fi} value={it} onChange={(v) => set(items.map((x, k) => (k === i ? v : x)))} onUpload={onUpload} id={`${id}-${i}`} />
            <button type="button" className="small" aria-label={`remove ${fi.title}`} onClick={() => set(items.filter((_, k) => k !== i))}>
              ✕
            </button>
          </div>
        );
      })}
      <button type="button" className="small" aria-label={`add to ${f.title}`} onClick={() => set([...items, blank()])}>
        + add
      </button>
    </div>
  );
}

function FileControl({ id, value, shown, onChange, onUpload, label }: { id: string; value: unknown; shown: unknown; onChange: (v: unknown) => void; onUpload: Upload; label: string }) {
  return (
    <span className="file-control">
      <input id={id} type="text" value={typeof value === "string" ? value : ""} placeholder={typeof shown === "string" && shown ? shown : "file name"} onChange={(e) => onChange(e.target.value || undefined)} />
      {onUpload && (
        <label className="button small">
          upload<span className="sr-only"> {label}</span>
          <input
            type="file"
            hidden
            onChange={async (e) => {
              const input = e.target;
              const file = input.files?.[0];
              const name = file ? await onUpload(file) : null;
              input.value = ""; // picking the same file again must upload again
              if (name) onChange(name);
            }}
          />
        </label>
      )}
    </span>
  );
}

/** Numbers are typed as text so that "$input" references and half-typed values ("1.") work. */
function NumberInput({ id, value, placeholder, onChange, nullable, label }: { id: string; value: unknown; placeholder: string; onChange: (v: unknown) => void; nullable: boolean; label?: string }) {
  const [text, setText] = useState(value === undefined || value === null ? "" : String(value));
  const [bad, setBad] = useState<string | null>(null);
  useEffect(() => {
    const parsed = parseNumberInput(text);
    if (parsed !== value && !(value === null && text === "")) setText(value === undefined || value === null ? "" : String(value));
    // eslint-disable-next-line react-hooks/exhaustive-deps -- only a new value from outside resets the text; re-running on each keystroke (text) would undo half-typed input
  }, [value]);
  return (
    <>
      <input
        id={id}
        type="text"
        inputMode="decimal"
        aria-label={label}
        value={text}
        placeholder={placeholder}
        onChange={(e) => {
          setText(e.target.value);
          const v = parseNumberInput(e.target.value);
          if (typeof v === "object" && v !== null) setBad(v.error);
          else {
            setBad(null);
            onChange(v === undefined && nullable && value === null ? null : v);
          }
        }}
      />
      {bad && <span className="error">{bad}</span>}
    </>
  );
}

function JsonInput({ id, label, value, placeholder, onChange }: { id: string; label: string; value: unknown; placeholder: unknown; onChange: (v: unknown) => void }) {
  const fmt = (v: unknown) => (v === undefined ? "" : JSON.stringify(v));
  const [text, setText] = useState(fmt(value));
  const [bad, setBad] = useState<string | null>(null);
  useEffect(() => setText(fmt(value)), [value]);
  return (
    <>
      <textarea
        id={id}
        aria-label={`${label} (JSON)`}
        rows={Math.min(6, Math.max(1, Math.ceil(text.length / 40)))}
        value={text}
        placeholder={placeholder === undefined ? "" : JSON.stringify(placeholder)}
        spellCheck={false}
        onChange={(e) => setText(e.target.value)}
        onBlur={() => {
          if (text.trim() === "") {
            setBad(null);
            onChange(undefined);
            return;
          }
          try {
            const v = JSON.parse(text);
            setBad(null);
            onChange(v);
          } catch (e) {
            setBad(`not JSON: ${(e as Error).message}`);
          }
        }}
      />
      {bad && <span className="error">{bad}</span>}
    </>
  );
}
