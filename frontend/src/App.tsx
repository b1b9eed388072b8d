import { useReactFlow } from "@xyflow/react";
import { useCallback, useEffect, useMemo, useRef, useState } from "react";
import * as API from "./api/client";
import type { Artifact, GraphInfo, Health, NodeSpec, ProcessParameter, Recipe, RunError } from "./api/types";
import { Inspector } from "./components/Inspector";
import { Palette } from "./components/Palette";
import { Tabs, tabPanelProps } from "./components/Tabs";
import { Toolbar } from "./components/Toolbar";
import { GraphEditor } from "./graph/GraphEditor";
import { useShortcuts } from "./graph/useShortcuts";
import {
  addNode, amend, catalogMap, changeSignature, commit, copySelection, emptyRecipe, engineView, history, paste, positionsOf, redo, undo, type Clip, type History, type XY,
} from "./graph/recipe";
import { MaskView } from "./mask/MaskView";
import { Results } from "./plots/Results";
import { useRun } from "./run/useRun";
import { Viewer3D } from "./viewer/Viewer3D";
import { ParamsEditor } from "./xml/ParamsEditor";

type Tab = "graph" | "mask" | "params" | "results" | "viewer";
const TABS: [Tab, string][] = [["graph", "Graph"], ["mask", "Mask canvas"], ["params", "Parameters (XML)"], ["results", "Results & plots"], ["viewer", "3D view"]];


export function App() {
  const [specs, setSpecs] = useState<NodeSpec[]>([]);
  const [processParams, setProcessParams] = useState<ProcessParameter[]>([]);
  const catalog = useMemo(() => catalogMap(specs), [specs]);
  const [graphs, setGraphs] = useState<GraphInfo[]>([]);
  const [healthInfo, setHealth] = useState<Health | null>(null);
  const [hist, setHist] = useState<History<Recipe>>(() => history(emptyRecipe()));
  const recipe = hist.present;
  const [graphName, setGraphName] = useState<string | null>(null);
  const [savedJson, setSavedJson] = useState(JSON.stringify(emptyRecipe()));
  const [selected, setSelected] = useState<Set<string>>(new Set());
  const [tab, setTab] = useState<Tab>("graph");
  const [layer, setLayer] = useState(0);
  const [previewNode, setPreviewNode] = useState<string | null>(null);
  const [artifacts, setArtifacts] = useState<Artifact[]>([]);
  const [failure, setFailure] = useState<RunError | null>(null);
  const [messages, setMessages] = useState<{ id: number; text: string }[]>([]);
  const [saveAs, setSaveAs] = useState<string | null>(null);
  const clip = useRef<Clip | null>(null);
  const rf = useReactFlow();

  const dirty = JSON.stringify(recipe) !== savedJson;

  // Keep the selection to nodes that exist (after delete, undo, open).
  useEffect(() => {
    setSelected((sel) => {
      const ids = new Set(recipe.nodes.map((n) => n.id));
      return [...sel].every((id) => ids.has(id)) ? sel : new Set([...sel].filter((id) => ids.has(id)));
    });
  }, [recipe]);

  const message = useCallback((text: string) => {
    const id = Date.now() + Math.random();
    setMessages((m) => [...m.slice(-3), { id, text }]);
    setTimeout(() => setMessages((m) => m.filter((x) => x.id !== id)), 6000);
  }, []);
  const fail = useCallback((e: unknown) => message(e instanceof API.ApiError ? e.detail.message : String(e)), [message]);

  // Each edit is one undo step, except typing: form edits within 800 ms that change the same
  // thing (one field being typed into) share one step.
  const lastEdit = useRef<{ sig: string; t: number } | null>(null);
  const edit = useCallback(
    (fn: (r: Recipe) => Recipe, typing = false) =>
      setHist((h) => {
        const next = fn(h.present);
        if (next === h.present) return h;
        const sig = typing ? changeSignature(h.present, next) : null;
        const now = performance.now();
        const same = sig !== null && lastEdit.current?.sig === sig && now - lastEdit.current.t < 800 && h.past.length > 0;
        lastEdit.current = sig !== null ? { sig, t: now } : null;
        return same ? amend(h, next) : commit(h, next);
      }),
    [],
  );
  const typingEdit = useCallback((fn: (r: Recipe) => Recipe) => edit(fn, true), [edit]);

  const { run, follow, cancel } = useRun(async (s) => {
    if (!s.id) return;
    try {
      setArtifacts(await API.listArtifacts(s.id));
    } catch (e) {
      fail(e);
    }
    if (s.phase === "failed" && s.error) {
      setFailure(s.error);
      if (s.error.layer != null) setTab("mask");
      message(`run failed: ${s.error.message}`);
    } else if (s.phase === "done") message("run finished");
  });

  // ---- loading ----------------------------------------------------------------------------------
  const refreshGraphs = useCallback(() => API.listGraphs().then(setGraphs).catch(fail), [fail]);
  useEffect(() => {
    API.nodes().then(setSpecs).catch(fail);
    API.processParameters().then(setProcessParams).catch(fail);
    API.health().then(setHealth).catch(fail);
    void refreshGraphs();
  }, [fail, refreshGraphs]);

  // Leaving the page with unsaved edits asks first.
  useEffect(() => {
    if (!dirty) return;
    const warn = (e: BeforeUnloadEvent) => e.preventDefault();
    window.addEventListener("beforeunload", warn);
    return () => window.removeEventListener("beforeunload", warn);
  }, [dirty]);

  const open = useCallback(
    async (name: string) => {
      if (dirty && !window.confirm("Discard the unsaved changes of this recipe?")) return;
      try {
        const r = await API.getGraph(name);
        const full: Recipe = { ...emptyRecipe(name), ...r };
        setHist(history(full));
        setSavedJson(JSON.stringify(full));
        setGraphName(name);
        setSelected(new Set());
        setPreviewNode(null);
        setFailure(null);
        setArtifacts([]);
        setLayer(0);
        setTimeout(() => rf.fitView({ padding: 0.15 }), 50);
      } catch (e) {
        fail(e);
      }
    },
    [fail, rf, dirty],
  );

  const save = useCallback(
    async (name: string | null = graphName) => {
      if (!name) {
        setSaveAs(recipe.name || "untitled");
        return false;
      }
      try {
        const toSave = { ...recipe, name };
        const res = await API.putGraph(name, toSave);
        // "Save as" takes the zone-parameter values along to the new graph.
        if (graphName && name !== graphName && res.created) {
          const xml = await API.getParams(graphName).catch(() => null);
          if (xml) await API.putParams(name, xml).catch(() => undefined);
        }
        setHist((h) => ({ ...h, present: toSave }));
        setSavedJson(JSON.stringify(toSave));
        setGraphName(name);
        if (res.problems.length) message(`saved; not runnable yet: ${String(res.problems[0].message)}`);
        else message(`saved ${name}`);
        void refreshGraphs();
        return true;
      } catch (e) {
        fail(e);
        return false;
      }
    },
    [graphName, recipe, message, fail, refreshGraphs],
  );

  const remove = async () => {
    if (!graphName || !window.confirm(`Delete graph ${graphName}?`)) return;
    try {
      await API.deleteGraph(graphName);
      message(`deleted ${graphName}`);
      setGraphName(null);
      setSavedJson("");
      void refreshGraphs();
    } catch (e) {
      fail(e);
    }
  };

  const startRun = async () => {
    setFailure(null);
    setArtifacts([]);
    try {
      // The recipe runs exactly as displayed (unsaved edits included, nothing is saved); a saved
      // graph lends it its uploaded files and its parameter XML.
      const { id } = await API.startRun({ graph: graphName, recipe: engineView(recipe) });
      follow(id);
    } catch (e) {
      if (e instanceof API.ApiError && (e.detail.node || e.detail.layer != null)) setFailure(e.detail);
      fail(e);
    }
  };

  const addAt = useCallback(
    (type: string, at?: XY) => {
      const spec = catalog.get(type);
      if (!spec) return;
      // Without a drop point, append: right of the selected node (else of the rightmost one).
      let pos = at;
      if (!pos) {
        const all = positionsOf(recipe);
        const anchorId = [...selected].find((id) => all[id]) ?? Object.keys(all).sort((a, b) => all[b][0] - all[a][0])[0];
        pos = anchorId ? [all[anchorId][0] + 230, all[anchorId][1]] : [0, 0];
        // Wrap after four columns, below everything, so a growing chain stays readable.
        const ps = Object.values(all);
        const x0 = ps.length ? Math.min(...ps.map((q) => q[0])) : 0;
        if (pos[0] > x0 + 3 * 230) pos = [x0, Math.max(...ps.map((q) => q[1])) + 160];
      }
      // A new node starts with empty params: the engine applies the schema defaults and the form
      // shows them as placeholders, so the recipe only records what the user changed.
      const { recipe: r, id } = addNode(recipe, spec, pos);
      edit(() => r);
      setSelected(new Set([id]));
      setTab("graph");
    },
    [catalog, recipe, selected, edit],
  );

  const upload = useCallback(
    async (file: File): Promise<string | null> => {
      if (!graphName) {
        message("save the recipe first: uploaded files belong to a saved graph");
        return null;
      }
      try {
        await API.putFile(graphName, file.name, file);
        message(`uploaded ${file.name}`);
        return file.name;
      } catch (e) {
        fail(e);
        return null;
      }
    },
    [graphName, message, fail],
  );

  useShortcuts({
    graphActive: tab === "graph",
    save: () => void save(),
    undo: () => setHist(undo),
    redo: () => setHist(redo),
    copy: () => {
      if (!selected.size) return;
      clip.current = copySelection(recipe, selected);
      message(`copied ${selected.size} node(s)`);
    },
    paste: () => {
      if (!clip.current) return;
      const { recipe: r, ids } = paste(recipe, clip.current);
      edit(() => r);
      setSelected(new Set(ids));
    },
    selectAll: () => setSelected(new Set(recipe.nodes.map((n) => n.id))),
    fit: () => rf.fitView({ padding: 0.15, duration: 200 }),
  });

  const single = selected.size === 1 ? recipe.nodes.find((n) => selected.has(n.id)) ?? null : null;
  const onPreview = useCallback((id: string) => setPreviewNode((cur) => (cur === id ? null : id)), []);
  const zoneArtifacts = useMemo(() => artifacts.filter((a) => a.name.endsWith(".params.xml")).map((a) => a.name), [artifacts]);

  return (
    <div className={`app tab-${tab}`}>
      <Toolbar
        graphs={graphs}
        graphName={graphName}
        defaultName={recipe.name}
        dirty={dirty}
        canUndo={hist.past.length > 0}
        canRedo={hist.future.length > 0}
        canRun={recipe.nodes.length > 0}
        run={run}
        onOpen={(name) => void open(name)}
        onNew={() => {
          if (dirty && !window.confirm("Discard the unsaved changes of this recipe?")) return;
          setHist(history(emptyRecipe()));
          setGraphName(null);
          setSavedJson(JSON.stringify(emptyRecipe()));
        }}
        onSave={save}
        onDelete={remove}
        onUndo={() => setHist(undo)}
        onRedo={() => setHist(redo)}
        onRun={startRun}
        onCancel={() => void cancel()}
        saveAs={saveAs}
        setSaveAs={setSaveAs}
      />
      <div className="body">
        <aside className="left">
          <Palette specs={specs} onAdd={(t) => addAt(t)} />
        </aside>
        <main className="center">
          <Tabs tabs={TABS} active={tab} onChange={setTab} label="views" />
          <div className="tab-body">
            <div className={`pane ${tab === "graph" ? "" : "hidden"}`} {...tabPanelProps("graph")}>
              <GraphEditor
                recipe={recipe}
                catalog={catalog}
                statuses={run.nodes}
                selected={selected}
                previewNode={previewNode}
                onSelect={setSelected}
                onChange={edit}
                onPreview={onPreview}
                onAddAt={addAt}
                onMessage={message}
                active={tab === "graph"}
              />
            </div>
            {tab === "mask" && (
              <div className="pane" {...tabPanelProps("mask")}>
                <MaskView
                  key={graphName ?? "unsaved"}
                  recipe={recipe}
                  catalog={catalog}
                  graph={graphName}
                  layer={layer}
                  setLayer={setLayer}
                  previewNode={previewNode}
                  setPreviewNode={setPreviewNode}
                  onEdit={edit}
                  failure={failure}
                  onDismissFailure={() => setFailure(null)}
                  onMessage={message}
                />
              </div>
            )}
            {tab === "params" && (
              <div className="pane scroll" {...tabPanelProps("params")}>
                <ParamsEditor
                  graph={graphName}
                  runId={run.phase === "done" ? run.id : null}
                  runParamsArtifacts={zoneArtifacts}
                  runWarnings={run.warnings.filter((w) => w.node && recipe.nodes.some((n) => n.id === w.node && n.type === "zone"))}
                  parameters={processParams}
                  dirtyRecipe={dirty}
                  onMessage={message}
                />
              </div>
            )}
            {tab === "viewer" && (
              <div className="pane" {...tabPanelProps("viewer")}>
                <Viewer3D health={healthInfo} graph={graphName} runId={run.id} runPhase={run.phase} layer={layer} setLayer={setLayer} onMessage={message} />
              </div>
            )}
            {tab === "results" && (
              <div className="pane scroll" {...tabPanelProps("results")}>
                <Results recipe={recipe} run={run} artifacts={artifacts} />
              </div>
            )}
          </div>
        </main>
        <aside className="right">
          <div className="inspector-wrap">
            <Inspector
              recipe={recipe}
              catalog={catalog}
              node={single}
              selectedCount={selected.size}
              status={single ? run.nodes[single.id] : undefined}
              onEdit={typingEdit}
              onRenamed={(id) => setSelected(new Set([id]))}
              onUpload={upload}
              onMessage={message}
            />
          </div>
        </aside>
      </div>
      <footer className="status">
        <span>{recipe.nodes.length} nodes · {recipe.edges.length} edges</span>
        {run.error && <span className="error">{run.error.node} {run.error.layer != null ? `layer ${run.error.layer}` : ""} {run.error.section ?? ""}: {run.error.message}</span>}
        <span className="grow" />
        {messages.map((m) => (
          <span key={m.id} className="toast" data-testid="toast">
            {m.text}
          </span>
        ))}
      </footer>
    </div>
  );
}
