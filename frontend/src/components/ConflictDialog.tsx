/**
 * Concurrent editing (#25): a save refused with 409 because someone saved the recipe (or its
 * parameter XML) since it was opened. Never overwritten silently: the user picks reload (theirs),
 * overwrite (save again on their revision) or save as.
 */
import * as API from "../api/client";

export interface Conflict {
  kind: API.Saved;
  name: string;
  /** Their stored revision; null when the graph was deleted meanwhile. */
  theirsRevision: number | null;
  message: string;
}

/** The dialog's state for an error of a save, or null when it is not a revision conflict. */
export function conflictOf(e: unknown): Conflict | null {
  if (!(e instanceof API.ConflictError)) return null;
  return { kind: e.kind, name: e.name, theirsRevision: e.theirs?.revision ?? null, message: e.detail.message };
}

/** "Overwrite": the next save of this graph sends their revision as If-Match (deleted meanwhile:
 * no condition, the save creates it again). Call the save after this. */
export function overwriteWith(c: Conflict): void {
  API.setLoadedRevision(c.kind, c.name, c.theirsRevision === null ? null : `"${c.theirsRevision}"`);
}

export function ConflictDialog({ conflict, onReload, onOverwrite, onSaveAs, onCancel }: {
  conflict: Conflict;
  onReload: () => void;
  onOverwrite: () => void;
  onSaveAs: () => void;
  onCancel: () => void;
}) {
  const what = conflict.kind === "params" ? "parameter file of this recipe" : "recipe";
  const deleted = conflict.theirsRevision === null;
  return (
    <div role="dialog" aria-modal="true" aria-labelledby="conflict-title" aria-describedby="conflict-text" data-testid="conflict-dialog"
      onKeyDown={(e) => { if (e.key === "Escape") onCancel(); }}
      style={{ position: "fixed", inset: 0, background: "rgba(0,0,0,.45)", display: "grid", placeItems: "center", zIndex: 10000 }}>
      <div style={{ background: "var(--panel, #fff)", color: "inherit", padding: 20, borderRadius: 8, maxWidth: 480, display: "grid", gap: 10 }}>
        <h2 id="conflict-title" style={{ margin: 0, fontSize: 16 }}>
          {deleted ? "Someone deleted this recipe since you opened it" : `Someone saved this ${what} since you opened it`}
        </h2>
        <p id="conflict-text" style={{ margin: 0 }}>
          {deleted
            ? `“${conflict.name}” no longer exists on the server. Nothing was saved.`
            : `“${conflict.name}” is now at revision ${conflict.theirsRevision}. Nothing was saved: keep their version, replace it with yours, or keep both.`}
        </p>
        <div style={{ display: "flex", gap: 8, flexWrap: "wrap" }}>
          {!deleted && <button type="button" onClick={onReload}>Reload theirs (discard mine)</button>}
          <button type="button" onClick={onOverwrite}>{deleted ? "Save mine again" : "Overwrite with mine"}</button>
          <button type="button" onClick={onSaveAs} autoFocus>Save mine as…</button>
          <button type="button" onClick={onCancel}>Cancel</button>
        </div>
      </div>
    </div>
  );
}
