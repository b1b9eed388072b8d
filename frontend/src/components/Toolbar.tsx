import type { ReactNode } from "react";
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
  /** The recipe being fetched after a pick (null when none): shown in the picker, run waits. */
  opening?: string | null;
  run: RunState;
  /** A shipped example: read-only (save → save as, no delete). */
  isExample: boolean;
  problemCount: number;
  errorCount: number;
  onProblems: () => void;
  /** The last run's preflight verdict badge (shown after the problem count). */
  preflight?: ReactNode;
  /** Frame the selected nodes (a node group that moves them together). */
  onFrame: () => void;
  onOpen: (name: string) => void;
  onNew: () => void;
  /** Save under `name` (default: the current graph); resolves to whether it was saved. */
  onSave: (name?: string | null) => Promise<boolean>;
  onDelete: () => void;
  /** Open the saved recipe's history (its revisions); absent: no history button. */
  onHistory?: () => void;
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
      <select value={p.opening ?? p.graphName ?? ""} onChange={(e) => e.target.value && p.onOpen(e.target.value)} data-testid="open-graph" data-opening={p.opening ?? undefined} aria-busy={p.opening ? true : undefined} title="open a saved recipe" aria-label="open a recipe">
        <option value="">{p.graphName ? "" : "open recipe…"}</option>
        {p.graphs.map((g) => (
          <option key={g.name} value={g.name}>
            {g.name}
            {g.example ? " (example)" : ""}
          </option>
        ))}
      </select>
      <button onClick={p.onNew}>new</button>
      <button
        onClick={() => void p.onSave()}
        disabled={!p.dirty && !!p.graphName && !p.isExample}
        data-testid="save"
        title={p.isExample ? "a shipped example is read-only: save a copy under a new name" : "save the recipe and its parameter XML (Ctrl+S)"}
      >
        save{p.dirty ? " *" : ""}
      </button>
      {p.saveAs === null ? (
        <button onClick={() => p.setSaveAs(p.graphName ? `${p.graphName}-copy` : p.defaultName)}>save as…</button>
      ) : (
        <span className="save-as">
          <input autoFocus aria-label="save as: new recipe name" value={p.saveAs} onChange={(e) => p.setSaveAs(e.target.value)} data-testid="save-as-name" onKeyDown={(e) => e.key === "Enter" && commitSaveAs()} />
          <button onClick={commitSaveAs}>ok</button>
          <button onClick={() => p.setSaveAs(null)} aria-label="cancel save as">✕</button>
        </span>
      )}
      <button onClick={p.onDelete} disabled={!p.graphName || p.isExample} data-testid="delete" title={p.isExample ? "shipped examples cannot be deleted" : "delete this saved recipe"}>
        delete
      </button>
      {p.onHistory && (
        <button
          onClick={p.onHistory}
          disabled={!p.graphName || p.isExample}
          data-testid="history"
          aria-haspopup="dialog"
          title={p.isExample ? "a shipped example is read-only and has no history: save a copy to keep revisions" : p.graphName ? "the saved revisions of this recipe: list them, open an earlier one" : "save the recipe first: each save is a revision"}
        >
          history
        </button>
      )}
      <span className="sep" />
      <button onClick={p.onUndo} disabled={!p.canUndo} title="undo (Ctrl+Z)" aria-label="undo" data-testid="undo">
        ↶
      </button>
      <button onClick={p.onRedo} disabled={!p.canRedo} title="redo (Ctrl+Y)" aria-label="redo" data-testid="redo">
        ↷
      </button>
      <button onClick={p.onFrame} data-testid="add-frame" title="put a frame around the selected nodes (a group that moves them together)">
        ⬚ frame
      </button>
      <span className="sep" />
      <button
        className="run"
        title="run the recipe and parameter XML as shown (unsaved edits included, nothing is saved) with the saved graph's files"
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
      <button
        className={`problem-count ${p.errorCount ? "has-errors" : p.problemCount ? "has-warnings" : ""}`}
        onClick={p.onProblems}
        data-testid="problem-count"
        title="problems of the last run: errors and warnings (click to list them)"
      >
        {p.errorCount ? `✖ ${p.errorCount} ` : ""}⚠ {p.problemCount - p.errorCount}
      </button>
      {p.preflight}
      <a href="#/builds" className="button builds-link" style={{ textDecoration: "none", color: "var(--text)" }} data-testid="builds-link" title="builds: as built vs as planned, layer by layer (scans in, the next layer's program out)">builds</a>
      <span className="title">{p.graphName ?? "unsaved recipe"}</span>
      {p.isExample && (
        <span className="example-badge" data-testid="example-badge" title="shipped example: save as a new name to keep changes">
          example (read-only)
        </span>
      )}
    </header>
  );
}
