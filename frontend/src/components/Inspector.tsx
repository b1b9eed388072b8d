import { useEffect, useState } from "react";
import type { Recipe, RecipeNode } from "../api/types";
import { ParamForm } from "../forms/ParamForm";
import { validateParams } from "../forms/schema";
import { referencedInputs, renameNode, setNodeParams, type Catalog } from "../graph/recipe";
import { badgeText, type NodeStatus } from "../run/status";

export interface InspectorProps {
  recipe: Recipe;
  catalog: Catalog;
  node: RecipeNode | null;
  selectedCount: number;
  status?: NodeStatus;
  onEdit: (edit: (r: Recipe) => Recipe) => void;
  onRenamed: (id: string) => void;
  onUpload?: (file: File) => Promise<string>;
  onMessage: (m: string) => void;
}

/** The selected node's id, description, status and its generated parameter form; else the recipe's. */
export function Inspector(p: InspectorProps) {
  if (!p.node) return <RecipeSettings {...p} />;
  const node = p.node;
  const spec = p.catalog.get(node.type);
  const errors = spec ? validateParams(spec.params_schema, node.params) : {};
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
      {p.status && <div className={`badge b-${p.status.state}`}>{badgeText(p.status)}{p.status.message ? ` — ${p.status.message}` : ""}</div>}
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

function RecipeSettings({ recipe, onEdit, selectedCount }: InspectorProps) {
  const used = referencedInputs(recipe);
  return (
    <div className="inspector">
      <h3>Recipe</h3>
      {selectedCount > 1 && <div className="muted">{selectedCount} nodes selected (Ctrl+C copies, Delete removes)</div>}
      <label className="field">
        description
        <textarea rows={2} value={recipe.description} onChange={(e) => onEdit((r) => ({ ...r, description: e.target.value }))} />
      </label>
      <InputsEditor recipe={recipe} onEdit={onEdit} used={used} />
      <p className="muted">
        Select a node to edit its parameters. Shift+drag box-selects, Delete removes, Ctrl+Z/Ctrl+Y undo/redo, Ctrl+C/Ctrl+V copy/paste, F fits the view.
      </p>
    </div>
  );
}

/** Recipe inputs (the "$name" knobs of batch runs) as editable fields. */
export function InputsEditor({ recipe, onEdit, used }: { recipe: Recipe; onEdit: (e: (r: Recipe) => Recipe) => void; used: Set<string> }) {
  const [name, setName] = useState("");
  const set = (k: string, v: unknown) => onEdit((r) => ({ ...r, inputs: { ...r.inputs, [k]: v } }));
  return (
    <div className="inputs-editor" data-testid="inputs">
      <h4>Inputs</h4>
      {Object.entries(recipe.inputs).map(([k, v]) => (
        <div className="field" key={k} data-input={k}>
          <label title={used.has(k) ? `used as $${k}` : "not referenced by any node"}>
            {k} {!used.has(k) && <span className="muted">(unused)</span>}
          </label>
          <div className="control">
            {typeof v === "boolean" ? (
              <input type="checkbox" checked={v} onChange={(e) => set(k, e.target.checked)} />
            ) : typeof v === "number" ? (
              <NumberSlider value={v} onChange={(x) => set(k, x)} />
            ) : (
              <input value={typeof v === "string" ? v : JSON.stringify(v)} onChange={(e) => set(k, e.target.value)} />
            )}
            <button
              title="remove input"
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
        </div>
      ))}
      <div className="add-input">
        <input placeholder="new input name" value={name} onChange={(e) => setName(e.target.value)} />
        <button disabled={!/^[A-Za-z_][A-Za-z0-9_]*$/.test(name) || name in recipe.inputs} onClick={() => (set(name, 0), setName(""))}>
          add
        </button>
      </div>
    </div>
  );
}

/** A number field with a slider spanning 0…2× the value (or its sign-symmetric range). */
function NumberSlider({ value, onChange }: { value: number; onChange: (v: number) => void }) {
  const [text, setText] = useState(String(value));
  const [span] = useState(() => Math.max(1, Math.abs(value) * 2));
  useEffect(() => setText(String(value)), [value]);
  const lo = value < 0 ? -span : 0;
  return (
    <span className="num-slider">
      <input type="range" min={lo} max={span} step={span / 200} value={value} onChange={(e) => onChange(Number(Number(e.target.value).toPrecision(4)))} />
      <input
        type="text"
        value={text}
        onChange={(e) => {
          setText(e.target.value);
          const v = Number(e.target.value);
          if (e.target.value.trim() !== "" && Number.isFinite(v)) onChange(v);
        }}
        style={{ width: 60 }}
      />
    </span>
  );
}
