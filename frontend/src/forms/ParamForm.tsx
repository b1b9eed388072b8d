import { memo, useEffect, useMemo, useState } from "react";
import type { JSONSchema } from "../api/types";
import { boundsText, describeFields, parseNumberInput, validateField, type FieldSpec } from "./schema";

export interface ParamFormProps {
  schema: JSONSchema;
  params: Record<string, unknown>;
  onChange: (params: Record<string, unknown>) => void;
  /** Upload a file for an `x-file` param; resolves to the name to store in the param. */
  onUpload?: (file: File) => Promise<string | null>;
  idPrefix?: string;
}

/** A parameter form generated from a node's JSON Schema: one row per field, units and bounds shown. */
export const ParamForm = memo(function ParamForm({ schema, params, onChange, onUpload, idPrefix = "p" }: ParamFormProps) {
  const fields = useMemo(() => describeFields(schema), [schema]);
  const set = (name: string, v: unknown) => {
    const next = { ...params };
    if (v === undefined) delete next[name];
    else next[name] = v;
    onChange(next);
  };
  const unknown = Object.keys(params).filter((k) => !fields.some((f) => f.name === k));
  return (
    <div className="param-form">
      {fields.map((f) => (
        <FieldRow key={f.name} f={f} value={params[f.name]} onChange={(v) => set(f.name, v)} onUpload={onUpload} id={`${idPrefix}-${f.name}`} />
      ))}
      {unknown.map((k) => (
        <div className="field err" key={k}>
          <label>{k}</label>
          <span className="error">unknown parameter</span>
          <button onClick={() => set(k, undefined)}>remove</button>
        </div>
      ))}
    </div>
  );
});

function FieldRow({ f, value, onChange, onUpload, id }: { f: FieldSpec; value: unknown; onChange: (v: unknown) => void; onUpload?: (file: File) => Promise<string | null>; id: string }) {
  const err = validateField(f, value);
  const shown = value === undefined ? f.default : value;
  return (
    <div className={`field ${err ? "err" : ""}`} data-field={f.name}>
      <label htmlFor={id} title={f.description}>
        {f.title}
        {f.unit && <span className="unit"> [{f.unit}]</span>}
      </label>
      <div className="control">
        <Control f={f} value={value} shown={shown} onChange={onChange} onUpload={onUpload} id={id} />
      </div>
      {(err || boundsText(f) || f.description) && (
        <div className={err ? "error" : "hint"}>{err ?? [boundsText(f), f.description].filter(Boolean).join(" — ")}</div>
      )}
    </div>
  );
}

function Control({ f, value, shown, onChange, onUpload, id }: { f: FieldSpec; value: unknown; shown: unknown; onChange: (v: unknown) => void; onUpload?: (file: File) => Promise<string | null>; id: string }) {
  switch (f.kind) {
    case "number":
    case "integer":
      return <NumberInput id={id} value={value} placeholder={shown === undefined || shown === null ? "" : String(shown)} onChange={onChange} nullable={f.nullable} />;
    case "boolean":
      return <input id={id} type="checkbox" checked={Boolean(shown)} onChange={(e) => onChange(e.target.checked)} />;
    case "enum":
      return (
        <select id={id} value={value === undefined ? "" : JSON.stringify(value)} onChange={(e) => onChange(e.target.value === "" ? undefined : JSON.parse(e.target.value))}>
          <option value="">{shown !== undefined ? `default (${String(shown)})` : "—"}</option>
          {f.options?.map((o) => (
            <option key={JSON.stringify(o)} value={JSON.stringify(o)}>
              {String(o)}
            </option>
          ))}
        </select>
      );
    case "file":
      return (
        <span className="file-control">
          <input id={id} type="text" value={typeof value === "string" ? value : ""} placeholder={typeof shown === "string" ? shown : "file name"} onChange={(e) => onChange(e.target.value || undefined)} />
          {onUpload && (
            <label className="button small">
              upload
              <input
                type="file"
                hidden
                onChange={async (e) => {
                  const file = e.target.files?.[0];
                  e.target.value = ""; // picking the same file again must upload again
                  const name = file ? await onUpload(file) : null;
                  if (name) onChange(name);
                }}
              />
            </label>
          )}
        </span>
      );
    case "string":
      return <input id={id} type="text" value={typeof value === "string" ? value : ""} placeholder={typeof shown === "string" ? shown : ""} onChange={(e) => onChange(e.target.value === "" ? undefined : e.target.value)} />;
    default:
      return <JsonInput id={id} value={value} placeholder={shown} onChange={onChange} />;
  }
}

/** Numbers are typed as text so that "$input" references and half-typed values ("1.") work. */
function NumberInput({ id, value, placeholder, onChange, nullable }: { id: string; value: unknown; placeholder: string; onChange: (v: unknown) => void; nullable: boolean }) {
  const [text, setText] = useState(value === undefined || value === null ? "" : String(value));
  const [bad, setBad] = useState<string | null>(null);
  useEffect(() => {
    const parsed = parseNumberInput(text);
    if (parsed !== value && !(value === null && text === "")) setText(value === undefined || value === null ? "" : String(value));
    // eslint-disable-next-line react-hooks/exhaustive-deps
  }, [value]);
  return (
    <>
      <input
        id={id}
        type="text"
        inputMode="decimal"
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

function JsonInput({ id, value, placeholder, onChange }: { id: string; value: unknown; placeholder: unknown; onChange: (v: unknown) => void }) {
  const fmt = (v: unknown) => (v === undefined ? "" : JSON.stringify(v));
  const [text, setText] = useState(fmt(value));
  const [bad, setBad] = useState<string | null>(null);
  useEffect(() => setText(fmt(value)), [value]);
  return (
    <>
      <textarea
        id={id}
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
