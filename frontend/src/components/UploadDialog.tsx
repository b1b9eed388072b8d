/**
 * A same-name upload (#25 fault 5): the recipe's file of that name is never replaced without the
 * user's word. Replace (the recipe points at the new content: unsaved, undo brings the old one
 * back), keep both (the new file under a free name) or cancel.
 */
export type UploadChoice = "replace" | "both" | "cancel";

export interface UploadAsk {
  name: string;
  /** the new file's size, bytes */
  size: number;
  /** what the name holds now */
  have: { size: number; updated: number; sha256: string };
  /** the name "keep both" uploads under */
  other: string;
}

const kb = (n: number) => (n < 1024 ? `${n} B` : `${(n / 1024).toFixed(1)} kB`);

export function UploadDialog({ ask, onChoose }: { ask: UploadAsk; onChoose: (c: UploadChoice) => void }) {
  return (
    <div className="modal-backdrop" onKeyDown={(e) => e.key === "Escape" && onChoose("cancel")}>
      <div role="dialog" aria-modal="true" aria-labelledby="upload-title" aria-describedby="upload-text" className="modal" data-testid="upload-dialog">
        <h2 id="upload-title">“{ask.name}” is already in this recipe</h2>
        <p id="upload-text">
          The recipe runs with the stored {ask.name} ({kb(ask.have.size)}, uploaded {new Date(ask.have.updated * 1000).toLocaleString()},
          sha256 {ask.have.sha256.slice(0, 12)}…). The new file is {kb(ask.size)}. Replacing marks the recipe unsaved; undo brings the stored
          content back.
        </p>
        <div className="modal-actions">
          <button type="button" onClick={() => onChoose("replace")} data-testid="upload-replace">Replace</button>
          <button type="button" onClick={() => onChoose("both")} data-testid="upload-keep-both">Keep both (upload as {ask.other})</button>
          <button type="button" onClick={() => onChoose("cancel")} data-testid="upload-cancel" autoFocus>Cancel</button>
        </div>
      </div>
    </div>
  );
}
