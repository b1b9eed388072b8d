/**
 * A saved recipe's history (#25 Build 2): its revisions newest first (number, local time, who).
 * Picking one says in a line what it would change; "Open this revision" puts it on screen as an
 * unsaved edit on top of the current revision (one undo step; "save" stores it as a new revision
 * with If-Match). Nothing is overwritten here. Same look and keys as the ConflictDialog, focus
 * kept inside (Tab wraps), Escape closes.
 */
import { useEffect, useRef, useState, type KeyboardEvent } from "react";
import * as API from "../api/client";
import type { Recipe, RevisionInfo } from "../api/types";
import { newestFirst, revisionSummary, whenOf, whoOf } from "../document/revisions";

/** Tab / Shift+Tab wrap around the focusable elements of `box` (a modal keeps focus inside). */
export function trapTab(e: KeyboardEvent, box: HTMLElement | null): void {
  if (e.key !== "Tab" || !box) return;
  const items = [...box.querySelectorAll<HTMLElement>("button:not([disabled]), [href], input:not([disabled]), select, textarea, [tabindex]:not([tabindex='-1'])")];
  if (!items.length) return;
  const first = items[0];
  const last = items[items.length - 1];
  if (e.shiftKey && document.activeElement === first) {
    e.preventDefault();
    last.focus();
  } else if (!e.shiftKey && document.activeElement === last) {
    e.preventDefault();
    first.focus();
  }
}

export function HistoryDialog({ name, current, onOpen, onClose }: {
  name: string;
  /** The recipe on screen (what a revision is compared with). */
  current: Recipe;
  onOpen: (recipe: Recipe, revision: number) => void;
  onClose: () => void;
}) {
  const [rows, setRows] = useState<RevisionInfo[] | null>(null);
  const [error, setError] = useState<string | null>(null);
  const [picked, setPicked] = useState<number | null>(null);
  const [recipes, setRecipes] = useState<Record<number, Recipe>>({});
  const box = useRef<HTMLDivElement>(null);
  const closeRef = useRef<HTMLButtonElement>(null);

  useEffect(() => {
    closeRef.current?.focus();
    API.listRevisions(name)
      .then((r) => setRows(newestFirst(r)))
      .catch((e) => setError(e instanceof API.ApiError ? e.detail.message : String(e)));
  }, [name]);

  const pick = (rev: number) => {
    setPicked(rev);
    if (recipes[rev]) return;
    API.getRevision(name, rev)
      .then((r) => setRecipes((m) => ({ ...m, [rev]: r })))
      .catch((e) => setError(e instanceof API.ApiError ? e.detail.message : String(e)));
  };
  const newest = rows?.[0]?.revision ?? null;
  const chosen = picked !== null ? recipes[picked] : undefined;

  return (
    <div role="dialog" aria-modal="true" aria-labelledby="history-title" aria-describedby="history-text" data-testid="history-dialog"
      onKeyDown={(e) => {
        if (e.key === "Escape") onClose();
        else trapTab(e, box.current);
      }}
      style={{ position: "fixed", inset: 0, background: "rgba(0,0,0,.45)", display: "grid", placeItems: "center", zIndex: 10000 }}>
      <div ref={box} style={{ background: "var(--panel, #fff)", color: "inherit", padding: 20, borderRadius: 8, width: "min(560px, calc(100vw - 40px))", maxHeight: "calc(100vh - 80px)", display: "grid", gridTemplateRows: "auto auto minmax(0, 1fr) auto auto", gap: 10 }}>
        <h2 id="history-title" style={{ margin: 0, fontSize: 16 }}>History of “{name}”</h2>
        <p id="history-text" style={{ margin: 0 }}>
          Saved revisions, newest first. Opening one puts it on screen as an unsaved change: save it to make it the newest revision, or undo.
        </p>
        <div style={{ overflowY: "auto", border: "1px solid var(--line, #d9dce1)", borderRadius: 4 }}>
          {error && <p role="alert" style={{ margin: 8 }}>{error}</p>}
          {!rows && !error && <p style={{ margin: 8 }}>Loading…</p>}
          {rows && (
            <ul aria-label="revisions" style={{ listStyle: "none", margin: 0, padding: 0 }} data-testid="history-list">
              {rows.map((r) => (
                <li key={r.revision}>
                  <button type="button" aria-pressed={picked === r.revision} data-testid="history-row" data-revision={r.revision} onClick={() => pick(r.revision)}
                    style={{ display: "grid", gridTemplateColumns: "9em 1fr 8em", gap: 8, width: "100%", textAlign: "left", borderRadius: 0, border: "none", borderBottom: "1px solid var(--line, #d9dce1)", padding: "6px 8px", fontWeight: picked === r.revision ? 700 : 400, background: picked === r.revision ? "var(--sel, #dbe9ff)" : "transparent", color: "inherit" }}>
                    <span>rev {r.revision}{r.revision === newest ? " (current)" : ""}</span>
                    <span>{whenOf(r.time)}</span>
                    <span style={{ overflow: "hidden", textOverflow: "ellipsis" }}>{whoOf(r.user)}</span>
                  </button>
                </li>
              ))}
            </ul>
          )}
        </div>
        <p style={{ margin: 0, minHeight: "1.3em" }} aria-live="polite" data-testid="history-summary">
          {picked === null ? "Pick a revision to see what it changes." : chosen ? `Revision ${picked}: ${revisionSummary(chosen, current)}` : `Revision ${picked}: loading…`}
        </p>
        <div style={{ display: "flex", gap: 8, flexWrap: "wrap" }}>
          <button type="button" disabled={!chosen} data-testid="history-open" onClick={() => chosen && picked !== null && onOpen(chosen, picked)}>
            Open this revision
          </button>
          <button type="button" ref={closeRef} onClick={onClose} data-testid="history-close">Close</button>
        </div>
      </div>
    </div>
  );
}
