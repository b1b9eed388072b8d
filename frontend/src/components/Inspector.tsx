import { useEffect, useState } from "react";
import type { Recipe, RecipeNode } from "../api/types";
import { ParamForm } from "../forms/ParamForm";
import { inputField, validateField, validateParams, type FieldSpec } from "../forms/schema";
import { referencedInputs, renameNode, setNodeParams, type Catalog } from "../graph/recipe";
import { badgeText, computeText, type NodeStatus } from "../run/status";

export interface InspectorProps {
  recipe: Recipe;
  catalog: Catalog;
  node: RecipeNode | null;
  selectedCount: number;
  status?: NodeStatus;
  onEdit: (edit: (r: Recipe) => Recipe) => void;
  onRenamed: (id: string) => void;
  onUpload?: (file: File) => Promise<string | null>;
  onMessage: (m: string) => void;
}

/** The selected node's id, description, status and its generated parameter form; else the recipe's. */
export function Inspector(p: InspectorProps) {
  if (!p.node) return <RecipeSettings {...p} />;
  const node = p.node;
  const spec = p.catalog.get(node.type);
  const errors = spec ? validateParams(spec.params_schema, node.params) : {};
  const compute = p.status ? computeText(p.status) : null;
  return (
    <div className="inspector" data-testid="inspector">
      <h3>
        {spec?.title ?? node.type} <span className="muted">{node.type}</span>
      </h3>
      <IdField id={node.id} onRename={(next) => {
        const r = renameNode(p.recipe, node.id, next);
        if (typeof r === "string") p.onMessage(r);
        else {
          p.onEdit((cur) => {
            const x = renameNode(cur, node.id, next);
            return typeof x === "string" ? cur : x;
          });
          p.onRenamed(next);
        }
      }} />
      <label className="field">
        label
        <input
          value={node.label ?? ""}
          placeholder={spec?.title ?? node.type}
          onChange={(e) => p.onEdit((r) => ({ ...r, nodes: r.nodes.map((n) => (n.id === node.id ? { ...n, label: e.target.value || undefined } : n)) }))}
        />
      </label>
      {p.status && <div className={`badge b-${p.status.state}`}>{badgeText(p.status)}{p.status.message ? ` — ${p.status.message}` : ""}</div>}
      {compute && <div className="muted" data-testid="compute-time">{compute}</div>}
      {spec && <p className="desc">{spec.description}</p>}
      {Object.keys(errors).length > 0 && <div className="error">{Object.keys(errors).length} parameter problem(s)</div>}
      {spec ? (
        <ParamForm
          key={node.id}
          idPrefix={node.id}
          schema={spec.params_schema}
          params={node.params}
          onUpload={p.onUpload}
          onChange={(params) => p.onEdit((r) => setNodeParams(r, node.id, params))}
        />
      ) : (
        <div className="error">Unknown node type “{node.type}”: not in the server's catalog.</div>
      )}
    </div>
  );
}

function IdField({ id, onRename }: { id: string; onRename: (next: string) => void }) {
  const [text, setText] = useState(id);
  useEffect(() => setText(id), [id]);
  return (
    <label className="field">
      id
      <input value={text} onChange={(e) => setText(e.target.value)} onBlur={() => text !== id && onRename(text)} onKeyDown={(e) => e.key === "Enter" && text !== id && onRename(text)} />
    </label>
  );
}

function RecipeSettings({ recipe, onEdit, selectedCount, catalog }: InspectorProps) {
  const used = referencedInputs(recipe);
  return (
    <div className="inspector">
      <h3>Recipe</h3>
      {selectedCount > 1 && <div className="muted">{selectedCount} nodes selected (Ctrl+C copies, Delete removes)</div>}
      <label className="field">
        description
        <textarea rows={2} value={recipe.description} onChange={(e) => onEdit((r) => ({ ...r, description: e.target.value }))} />
      </label>
      <InputsEditor recipe={recipe} onEdit={onEdit} used={used} catalog={catalog} />
      <p className="muted">
        Select a node to edit its parameters. Shift+drag box-selects, Delete removes, Ctrl+Z/Ctrl+Y undo/redo, Ctrl+C/Ctrl+V copy/paste, F fits the view.
      </p>
    </div>
  );
}

/** Recipe inputs (the "$name" knobs of batch runs) as fields typed by the parameters that use them. */
export function InputsEditor({ recipe, onEdit, used, catalog }: { recipe: Recipe; onEdit: (e: (r: Recipe) => Recipe) => void; used: Set<string>; catalog: Catalog }) {
  const [name, setName] = useState("");
  const set = (k: string, v: unknown) => onEdit((r) => ({ ...r, inputs: { ...r.inputs, [k]: v } }));
  return (
    <div className="inputs-editor" data-testid="inputs">
      <h4>Inputs</h4>
      {Object.entries(recipe.inputs).map(([k, v]) => {
        const f = inputField(recipe.nodes, (t) => catalog.get(t)?.params_schema, k);
        const err = f ? validateField(f, v) : null;
        return (
          <div className={`field ${err ? "err" : ""}`} key={k} data-input={k}>
            <label title={used.has(k) ? `used as $${k}${f?.description ? ": " + f.description : ""}` : "not referenced by any node"}>
              {k} {f?.unit && <span className="unit">[{f.unit}]</span>} {!used.has(k) && <span className="muted">(unused)</span>}
            </label>
            <div className="control">
              <InputControl f={f} value={v} onChange={(x) => set(k, x)} label={`input ${k}`} />
              <button
                title="remove input"
                aria-label={`remove input ${k}`}
                onClick={() =>
                  onEdit((r) => {
                    const inputs = { ...r.inputs };
                    delete inputs[k];
                    return { ...r, inputs };
                  })
                }
              >
                ✕
              </button>
            </div>
            {err && <div className="error">{err}</div>}
          </div>
        );
      })}
      <div className="add-input">
        <input aria-label="new input name" placeholder="new input name" value={name} onChange={(e) => setName(e.target.value)} />
        <button disabled={!/^[A-Za-z_][A-Za-z0-9_]*$/.test(name) || name in recipe.inputs} onClick={() => (set(name, 0), setName(""))}>
          add
        </button>
      </div>
    </div>
  );
}

function InputControl({ f, value, onChange, label }: { f?: FieldSpec; value: unknown; onChange: (v: unknown) => void; label: string }) {
  if (f?.options)
    return (
      <select aria-label={label} value={JSON.stringify(value)} onChange={(e) => onChange(JSON.parse(e.target.value))}>
        {!f.options.some((o) => o === value) && <option value={JSON.stringify(value)}>{String(value)}</option>}
        {f.options.map((o) => (
          <option key={JSON.stringify(o)} value={JSON.stringify(o)}>
            {String(o)}
          </option>
        ))}
      </select>
    );
  if (typeof value === "boolean") return <input aria-label={label} type="checkbox" checked={value} onChange={(e) => onChange(e.target.checked)} />;
  const numeric = f?.kind === "number" || f?.kind === "integer";
  if (typeof value === "number" || (value === null && numeric && f?.nullable)) {
    const lo = f?.minimum ?? f?.exclusiveMinimum;
    const hi = f?.maximum ?? f?.exclusiveMaximum;
    return <NumberSlider label={label} value={value} onChange={onChange} lo={lo} hi={hi} integer={f?.kind === "integer"} nullable={!!f?.nullable} />;
  }
  return <input aria-label={label} value={typeof value === "string" ? value : JSON.stringify(value)} onChange={(e) => onChange(e.target.value)} />;
}

/**
 * A number field with a slider. The slider spans the parameter's bounds when they are of the
 * value's magnitude (≤ 10× it), else 0…2× the value: a knob to explore, the field for anything else.
 */
function NumberSlider({ label, value, onChange, lo, hi, integer, nullable }: { label: string; value: number | null; onChange: (v: number | null) => void; lo?: number; hi?: number; integer?: boolean; nullable?: boolean }) {
  const [text, setText] = useState(value === null ? "" : String(value));
  // the slider's span is fixed when a value first appears (it must not move under the thumb)
  const span = (v: number) => {
    const mag = Math.max(1, Math.abs(v));
    const a = lo !== undefined && Math.abs(lo) <= 10 * mag ? lo : v < 0 ? -2 * mag : 0;
    const b = hi !== undefined && Math.abs(hi) <= 10 * mag ? hi : 2 * mag;
    return [a, Math.max(b, a + 1e-9)] as const;
  };
  const [fixed, setFixed] = useState<readonly [number, number] | null>(() => (value === null ? null : span(value)));
  useEffect(() => {
    setText(value === null ? "" : String(value));
    if (fixed === null && value !== null) setFixed(span(value));
    // eslint-disable-next-line react-hooks/exhaustive-deps -- only a new value resets the text; the span is fixed once (span() reads lo/hi of this render)
  }, [value]);
  const range = fixed ?? [0, 1];
  const step = integer ? 1 : (range[1] - range[0]) / 200;
  return (
    <span className="num-slider">
      {value !== null && (
        <input aria-label={`${label} slider`} type="range" min={range[0]} max={range[1]} step={step} value={value} onChange={(e) => onChange(integer ? Math.round(Number(e.target.value)) : Number(Number(e.target.value).toPrecision(4)))} />
      )}
      <input
        aria-label={label}
        type="text"
        value={text}
        placeholder={nullable ? "not set" : undefined}
        title={nullable ? "optional: leave empty for the parameter's default behaviour" : undefined}
        onChange={(e) => {
          setText(e.target.value);
          const v = Number(e.target.value);
          if (e.target.value.trim() === "") {
            if (nullable) onChange(null);
          } else if (Number.isFinite(v)) onChange(v);
        }}
        style={{ width: value === null ? 120 : 60 }}
      />
    </span>
  );
}
