// The editor's tabs and their panes: the graph (always mounted, hidden when another tab shows),
// the mask canvas, the parameter XML, the 3D view, the results and plots.
import { memo } from "react";
import { Tabs, tabPanelProps } from "../components/Tabs";
import { GraphEditor, type GraphEditorProps } from "../graph/GraphEditor";
import { MaskView } from "../mask/MaskView";
import { Results } from "../plots/Results";
import { Viewer3D } from "../viewer/Viewer3D";
import { ParamsEditor } from "../xml/ParamsEditor";
import { TABS } from "./tabs";
import type { Editor } from "./useEditor";
import type { EditorActions } from "./useEditorActions";

type PaneProps = GraphEditorProps & { doc: string | null };

/** The graph editor renders only while shown, on being hidden (to give up its keys) and when
 * another recipe opens: hidden, a recipe edit on the mask canvas does not re-render React Flow's
 * nodes, edges and store (a share of every canvas edit's time before its preview request, #30);
 * shown again, it takes the props of that moment. Another recipe opened behind another tab
 * renders it, so the editor's nodes are the open recipe's whatever tab shows (the e2e harness's
 * openRecipe waits for them: trust.e2e fault 8 timed out on it from the results tab). */
export const hiddenAlready = (a: PaneProps, b: PaneProps) => !a.active && !b.active && a.doc === b.doc;
const GraphPane = memo(function GraphPane({ doc: _doc, ...p }: PaneProps) {
  return <GraphEditor {...p} />;
}, hiddenAlready);

export function Workspace({ ed, act }: { ed: Editor; act: EditorActions }) {
  const { doc, view, runs, findings } = ed;
  const { recipe } = doc;
  const { tab, setTab } = view;
  return (
    <main className="center">
      <Tabs tabs={TABS} active={tab} onChange={setTab} label="views" />
      <div className="tab-body">
        <div className={`pane ${tab === "graph" ? "" : "hidden"}`} {...tabPanelProps("graph")}>
          <GraphPane
            doc={doc.graphName ?? null}
            recipe={recipe}
            catalog={ed.cat.catalog}
            statuses={runs.run.nodes}
            selected={ed.sel.selected}
            previewNode={view.previewNode}
            onSelect={ed.sel.setSelected}
            onChange={doc.edit}
            onPreview={view.onPreview}
            onAddAt={act.addAt}
            onMessage={ed.message}
            problems={findings.nodeProblems}
            onSearch={(x, y, at) => act.setSearch({ x, y, at })}
            active={tab === "graph"}
          />
        </div>
        {tab === "mask" && (
          <div className="pane" {...tabPanelProps("mask")}>
            <MaskView
              key={doc.graphName ?? "unsaved"}
              recipe={recipe}
              catalog={ed.cat.catalog}
              graph={doc.graphName}
              layer={view.layer}
              setLayer={view.setLayer}
              previewNode={view.previewNode}
              setPreviewNode={view.setPreviewNode}
              onEdit={doc.edit}
              failure={runs.failure}
              onDismissFailure={() => runs.setFailure(null)}
              onMessage={ed.message}
              onNewMask={act.newMaskFrom}
              starts={findings.canvasStarts}
              mark={runs.pfMark}
              onMarkDone={() => runs.setPfMark((m) => (m ? { ...m, draw: false } : m))}
            />
          </div>
        )}
        {tab === "params" && <ParamsPane ed={ed} />}
        {tab === "viewer" && (
          <div className="pane" {...tabPanelProps("viewer")}>
            <Viewer3D health={ed.cat.health} graph={doc.graphName} runId={runs.run.id} runPhase={runs.run.phase} layer={view.layer} setLayer={view.setLayer} onMessage={ed.message} />
          </div>
        )}
        {tab === "results" && (
          <div className="pane scroll" {...tabPanelProps("results")}>
            <Results recipe={recipe} run={runs.run} artifacts={runs.artifacts} />
          </div>
        )}
      </div>
    </main>
  );
}

function ParamsPane({ ed }: { ed: Editor }) {
  const { doc, runs, saving, xmlText } = ed;
  return (
    <div className="pane scroll" {...tabPanelProps("params")}>
      <ParamsEditor
        graph={doc.graphName}
        text={xmlText}
        unsaved={doc.dirty.xml}
        loadError={xmlText === null ? saving.xmlLoadError : null}
        onChange={(t) => doc.setXmlDraft(t, true)}
        onSave={() => void saving.save()}
        onDiscard={() => {
          if (window.confirm("Drop the unsaved parameter XML?")) doc.setXmlDraft(doc.saved.xml);
        }}
        serverError={saving.xmlError}
        runId={runs.run.phase === "done" ? runs.run.id : null}
        runParamsArtifacts={ed.findings.zoneArtifacts}
        runWarnings={runs.run.warnings.filter((w) => w.node && doc.recipe.nodes.some((n) => n.id === w.node && n.type === "zone"))}
        parameters={ed.cat.processParams}
        dirtyRecipe={doc.dirty.recipe}
        onMessage={ed.message}
      />
    </div>
  );
}
