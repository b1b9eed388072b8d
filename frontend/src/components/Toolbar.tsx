import type { GraphInfo } from "../api/types";
import type { RunState } from "../run/status";

export interface ToolbarProps {
  graphs: GraphInfo[];
  graphName: string | null;
  defaultName: string;
  dirty: boolean;
  canUndo: boolean;
  canRedo: boolean;
  canRun: boolean;
  run: RunState;
  onOpen: (name: string) => void;
  onNew: () => void;
  /** Save under `name` (default: the current graph); resolves to whether it was saved. */
  onSave: (name?: string | null) => Promise<boolean>;
  onDelete: () => void;
  onUndo: () => void;
  onRedo: () => void;
  onRun: () => void;
  onCancel: () => void;
  /** The name being typed for "save as", or null when that field is closed. */
  saveAs: string | null;
  setSaveAs: (name: string | null) => void;
}

/** Recipe file actions, undo/redo, run with its progress bar (driven by the run's events). */
export function Toolbar(p: ToolbarProps) {
  const { run } = p;
  const commitSaveAs = () => p.saveAs !== null && void p.onSave(p.saveAs).then((ok) => ok && p.setSaveAs(null));
  return (
    <header className="toolbar">
      <h1 className="brand">waamflow</h1>
      <select value={p.graphName ?? ""} onChange={(e) => e.target.value && p.onOpen(e.target.value)} data-testid="open-graph" title="open a saved recipe" aria-label="open a recipe">
        <option value="">{p.graphName ? "" : "open recipe…"}</option>
        {p.graphs.map((g) => (
          <option key={g.name} value={g.name}>
            {g.name}
            {g.example ? " (example)" : ""}
          </option>
        ))}
      </select>
      <button onClick={p.onNew}>new</button>
      <button onClick={() => void p.onSave()} disabled={!p.dirty && !!p.graphName} data-testid="save">
        save{p.dirty ? " *" : ""}
      </button>
      {p.saveAs === null ? (
        <button onClick={() => p.setSaveAs(p.graphName ? `${p.graphName}-copy` : p.defaultName)}>save as…</button>
      ) : (
        <span className="save-as">
          <input autoFocus value={p.saveAs} onChange={(e) => p.setSaveAs(e.target.value)} data-testid="save-as-name" onKeyDown={(e) => e.key === "Enter" && commitSaveAs()} />
          <button onClick={commitSaveAs}>ok</button>
          <button onClick={() => p.setSaveAs(null)}>✕</button>
        </span>
      )}
      <button onClick={p.onDelete} disabled={!p.graphName}>
        delete
      </button>
      <span className="sep" />
      <button onClick={p.onUndo} disabled={!p.canUndo} title="undo (Ctrl+Z)">
        ↶
      </button>
      <button onClick={p.onRedo} disabled={!p.canRedo} title="redo (Ctrl+Y)">
        ↷
      </button>
      <span className="sep" />
      <button
        className="run"
        title="run the recipe as shown (unsaved edits included) with the saved graph's files and parameter XML"
        onClick={p.onRun}
        disabled={run.phase === "running" || !p.canRun}
        data-testid="run"
      >
        ▶ run
      </button>
      {run.phase === "running" && <button onClick={p.onCancel}>cancel</button>}
      <div className={`progress p-${run.phase}`} data-testid="progress" data-phase={run.phase} data-run-id={run.id ?? ""} title={`${Math.round(run.progress * 100)}%`}>
        <div className="bar" style={{ width: `${run.progress * 100}%` }} />
        <span>{run.phase === "idle" ? "" : `${run.phase} ${Math.round(run.progress * 100)}%`}</span>
      </div>
      <span className="title">{p.graphName ?? "unsaved recipe"}</span>
    </header>
  );
}
