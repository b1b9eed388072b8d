// The editor's page: toolbar, palette, the tabs (graph, mask canvas, XML, results, 3D view),
// inspector, dialogs and status bar. The state lives in hooks by concern (app/useEditor.ts); the
// cross-concern actions in app/useEditorActions.ts; this file only lays them out.
import { Inspector } from "./components/Inspector";
import { Palette } from "./components/Palette";
import { Toolbar } from "./components/Toolbar";
import { PreflightBadge } from "./preflight/PreflightBadge";
import { Dialogs } from "./app/Dialogs";
import { useEditor, type Editor } from "./app/useEditor";
import { useEditorActions, type EditorActions } from "./app/useEditorActions";
import { Workspace } from "./app/Workspace";

export function App() {
  const ed = useEditor();
  const act = useEditorActions(ed);
  const { doc, sel, runs, drafts } = ed;
  const { recipe } = doc;
  return (
    <div className={`app tab-${ed.view.tab}`}>
      <EditorToolbar ed={ed} act={act} />
      {drafts.offer && (
        <div className="draft-offer" role="alertdialog" aria-label="unsaved changes" data-testid="draft-offer">
          restore unsaved changes from {new Date(drafts.offer.savedAt).toLocaleString()}?
          <button onClick={drafts.restore} data-testid="draft-restore">restore</button>
          <button onClick={drafts.discard} data-testid="draft-discard">discard</button>
        </div>
      )}
      <div className="body">
        <aside className="left">
          <Palette specs={ed.cat.specs} onAdd={(t) => act.addAt(t)} />
        </aside>
        <Workspace ed={ed} act={act} />
        <aside className="right">
          <div className="inspector-wrap">
            <Inspector
              recipe={recipe}
              catalog={ed.cat.catalog}
              node={sel.single}
              selectedCount={sel.selected.size}
              status={sel.single ? runs.run.nodes[sel.single.id] : undefined}
              onEdit={doc.typingEdit}
              onRenamed={(id) => sel.setSelected(new Set([id]))}
              onUpload={ed.uploads.upload}
              onMessage={ed.message}
            />
          </div>
        </aside>
      </div>
      <Dialogs ed={ed} act={act} />
      <footer className="status">
        <span>{recipe.nodes.length} nodes · {recipe.edges.length} edges</span>
        {runs.run.error && <span className="error">{runs.run.error.node} {runs.run.error.layer != null ? `layer ${runs.run.error.layer}` : ""} {runs.run.error.section ?? ""}: {runs.run.error.message}</span>}
        <span className="grow" />
        {ed.messages.map((m) => (
          <span key={m.id} className="toast" data-testid="toast">
            {m.text}
          </span>
        ))}
      </footer>
    </div>
  );
}

function EditorToolbar({ ed, act }: { ed: Editor; act: EditorActions }) {
  const { doc, runs, findings, saving } = ed;
  return (
    <Toolbar
      graphs={ed.cat.graphs}
      graphName={doc.graphName}
      defaultName={doc.recipe.name}
      dirty={doc.dirty.any}
      canUndo={doc.hist.past.length > 0}
      canRedo={doc.hist.future.length > 0}
      canRun={doc.recipe.nodes.length > 0 && ed.opener.opening === null}
      opening={ed.opener.opening}
      run={runs.run}
      isExample={ed.isExample}
      problemCount={findings.problems.length}
      errorCount={findings.problems.filter((x) => x.severity === "error").length}
      onProblems={() => act.setShowProblems((v) => !v)}
      preflight={<PreflightBadge view={findings.badge} onOpen={() => act.setShowProblems("preflight")} />}
      onFrame={act.frame}
      onOpen={(name) => void ed.opener.open(name)}
      onNew={ed.opener.openNew}
      onSave={saving.save}
      onDelete={saving.remove}
      onHistory={() => act.setShowHistory(true)}
      onUndo={doc.undo}
      onRedo={doc.redo}
      onRun={act.startRun}
      onCancel={() => void runs.cancel()}
      saveAs={saving.saveAs}
      setSaveAs={saving.setSaveAs}
    />
  );
}
