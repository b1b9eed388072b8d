// The editor's dialogs and panels over the page: problems, save conflict, revision history, upload
// of a name already stored, node search.
import { ConflictDialog, overwriteWith } from "../components/ConflictDialog";
import { HistoryDialog } from "../components/HistoryDialog";
import { UploadDialog } from "../components/UploadDialog";
import { change, withRecipe } from "../document/document";
import { clearDraft } from "../graph/drafts";
import { NodeSearch } from "../graph/NodeSearch";
import { ProblemsPanel } from "../problems/ProblemsPanel";
import type { Editor } from "./useEditor";
import type { EditorActions } from "./useEditorActions";

export function Dialogs({ ed, act }: { ed: Editor; act: EditorActions }) {
  const { doc, saving, opener } = ed;
  const { conflict, setConflict } = saving;
  const { graphName } = doc;
  const { search } = act;
  return (
    <>
      {act.showProblems && (
        <ProblemsPanel
          problems={ed.findings.problems}
          onPick={act.pickProblem}
          onClose={() => act.setShowProblems(false)}
          preflight={ed.runs.preflight}
          preflightStale={ed.findings.preflightStale}
          onPickPreflight={(pr) => act.pickPreflight(pr)}
          onMaskHere={(pr) => act.pickPreflight(pr, true)}
          focusPreflight={act.showProblems === "preflight"}
        />
      )}
      {conflict && (
        <ConflictDialog
          conflict={conflict}
          onReload={() => {
            setConflict(null);
            clearDraft(localStorage, conflict.name);
            void opener.open(conflict.name);
          }}
          onOverwrite={() => {
            overwriteWith(conflict);
            setConflict(null);
            void saving.save(conflict.name);
          }}
          onSaveAs={() => {
            setConflict(null);
            saving.setSaveAs(`${conflict.name}-copy`);
          }}
          onCancel={() => setConflict(null)}
        />
      )}
      {act.showHistory && graphName && !ed.isExample && (
        <HistoryDialog
          name={graphName}
          current={doc.recipe}
          onClose={() => {
            act.setShowHistory(false);
            document.querySelector<HTMLElement>("[data-testid=history]")?.focus();
          }}
          onOpen={(r, rev) => {
            // One undo step on top of what is on screen; the loaded revision (If-Match) stays the
            // current one, so "save" stores it as a new revision, never over someone's save.
            doc.setHist((h) => change(h, withRecipe(h.present, { ...r, name: graphName, files: r.files ?? h.present.recipe.files })));
            act.setShowHistory(false);
            ed.message(`revision ${rev} opened as an unsaved change: save to make it the newest revision, or undo`);
          }}
        />
      )}
      {ed.uploads.uploadAsk && <UploadDialog ask={ed.uploads.uploadAsk.ask} onChoose={ed.uploads.uploadAsk.resolve} />}
      {search && (
        <NodeSearch
          specs={ed.cat.specs}
          at={{ x: search.x, y: search.y }}
          onClose={() => act.setSearch(null)}
          onPick={(type) => {
            act.addAt(type, search.at);
            act.setSearch(null);
          }}
        />
      )}
    </>
  );
}
