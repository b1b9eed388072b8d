import { useReactFlow } from "@xyflow/react";
import { useCallback, useEffect, useMemo, useRef, useState } from "react";
import * as API from "./api/client";
import type { Artifact, GraphInfo, Health, NodeSpec, ProcessParameter, Recipe, RunError } from "./api/types";
import { Inspector } from "./components/Inspector";
import { Palette } from "./components/Palette";
import { Tabs, tabPanelProps } from "./components/Tabs";
import { Toolbar } from "./components/Toolbar";
import { ConflictDialog, conflictOf, overwriteWith, type Conflict } from "./components/ConflictDialog";
import { HistoryDialog } from "./components/HistoryDialog";
import { UploadDialog, type UploadAsk, type UploadChoice } from "./components/UploadDialog";
import { clearDraft, draftDiffers, parsePlace, placeSearch, readDraft, writeDraft, type Draft } from "./graph/drafts";
import { GraphEditor } from "./graph/GraphEditor";
import { NodeSearch } from "./graph/NodeSearch";
import { useShortcuts } from "./graph/useShortcuts";
import {
  addFrame, addNode, autoWire, setNodeParams, catalogMap, changeSignature, copySelection, emptyRecipe, freeSpot, paste, positionsOf, redo, undo,
  type Clip, type History, type XY,
} from "./graph/recipe";
import { carryOver, matchByOverlap, oldRegionsForCarry } from "./graph/carry";
import { governingMask, sectionKey, type MaskParams } from "./mask/edits";
import { MaskView, type NewMaskEvent } from "./mask/MaskView";
import { Results } from "./plots/Results";
import { useRun } from "./run/useRun";
import { collectProblems, currentProblems, problemsByNode, type Problem } from "./problems/problems";
import { ProblemsPanel } from "./problems/ProblemsPanel";
import { PreflightBadge } from "./preflight/PreflightBadge";
import {
  beadWidthOf, isStale, layerStarts, parsePreflight, preflightBadge, recipeSignature, type Preflight, type PreflightProblem, type RunInputs,
} from "./preflight/preflight";
import type { PreflightMark } from "./mask/MaskView";
import { focusSection } from "./forms/sectionKeys";
import { Viewer3D } from "./viewer/Viewer3D";
import { ParamsEditor } from "./xml/ParamsEditor";
import { freeName, pinStored, sha256Hex, withPin } from "./document/document";
import { change, isDirty, newDocument, recipeDirty as recipeIsDirty, runRequest, savedOf, withRecipe, withXml, xmlDirty as xmlIsDirty, type Doc, type Saved } from "./document/document";
import { boundsByName, saveBlocker } from "./xml/params";

type Tab = "graph" | "mask" | "params" | "results" | "viewer";
const TABS: [Tab, string][] = [["graph", "Graph"], ["mask", "Mask canvas"], ["params", "Parameters (XML)"], ["results", "Results & plots"], ["viewer", "3D view"]];
const asTab = (t: string | null): Tab => (TABS.some(([k]) => k === t) ? (t as Tab) : "graph");


export function App() {
  const [specs, setSpecs] = useState<NodeSpec[]>([]);
  const [processParams, setProcessParams] = useState<ProcessParameter[]>([]);
  const catalog = useMemo(() => catalogMap(specs), [specs]);
  const [graphs, setGraphs] = useState<GraphInfo[]>([]);
  const [healthInfo, setHealth] = useState<Health | null>(null);
  // The open recipe's document: recipe + parameter XML, one history (undo/redo restore both).
  const [hist, setHist] = useState<History<Doc>>(() => newDocument(emptyRecipe(), null));
  const doc = hist.present;
  const recipe = doc.recipe;
  const [graphName, setGraphName] = useState<string | null>(null);
  const [saved, setSaved] = useState<Saved>(() => savedOf({ recipe: emptyRecipe(), xml: null }));
  const savedXml = saved.xml;
  const [selected, setSelected] = useState<Set<string>>(new Set());
  const [tab, setTab] = useState<Tab>("graph");
  const [layer, setLayer] = useState(0);
  const [previewNode, setPreviewNode] = useState<string | null>(null);
  const [artifacts, setArtifacts] = useState<Artifact[]>([]);
  const [failure, setFailure] = useState<RunError | null>(null);
  const [messages, setMessages] = useState<{ id: number; text: string }[]>([]);
  const [saveAs, setSaveAs] = useState<string | null>(null);
  // The last run's merged parameter XML: shown in the editor only while the user has no XML of
  // their own (a template to start from); it never replaces the user's text.
  const [runXml, setRunXml] = useState<string | null>(null);
  const [xmlLoadError, setXmlLoadError] = useState<string | null>(null);
  const [xmlError, setXmlError] = useState<(RunError & Record<string, unknown>) | null>(null);
  // A stored draft offered back when its recipe opens.
  const [offer, setOffer] = useState<Draft | null>(() => (parsePlace(location.search).graph ? null : readDraft(localStorage, null)));
  // Files picked before the recipe had a name of its own: uploaded right after the save.
  const pendingFiles = useRef<File[]>([]);
  const [search, setSearch] = useState<{ x: number; y: number; at: XY } | null>(null);
  const [requestError, setRequestError] = useState<RunError | null>(null);
  const [showProblems, setShowProblems] = useState(false);
  // The last run's preflight report, and the recipe and XML it was run with: once either changes
  // the report no longer describes what is on screen (the badge greys out until the next run).
  const [preflight, setPreflight] = useState<Preflight | null>(null);
  const [preflightOf, setPreflightOf] = useState<RunInputs | null>(null);
  const [pfMark, setPfMark] = useState<PreflightMark | null>(null);
  const clip = useRef<Clip | null>(null);
  const rf = useReactFlow();

  const xmlText = doc.xml ?? runXml;
  const xmlDirty = xmlIsDirty(doc, saved);
  const recipeDirty = recipeIsDirty(doc, saved);
  const dirty = isDirty(doc, saved);
  const xmlDraft = xmlDirty ? doc.xml : null;
  /** The XML editor's text becomes the document's (one undo step per pause in typing). */
  const lastXmlEdit = useRef(0);
  const setXmlDraft = useCallback((text: string | null, typing = false) => {
    const now = performance.now();
    const same = typing && now - lastXmlEdit.current < 800;
    lastXmlEdit.current = typing ? now : 0;
    setHist((h) => change(h, withXml(h.present, text), same));
  }, []);
  // The recipe as the engine runs it, without its name (a save under a new name changes nothing).
  const recipeSig = useMemo(() => recipeSignature(recipe), [recipe]);
  const isExample = !!graphName && graphs.some((g) => g.name === graphName && g.example);

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
  // The file name a form sets right after an upload joins the upload's undo step (until this time).
  const foldNext = useRef(0);
  const edit = useCallback(
    (fn: (r: Recipe) => Recipe, typing = false) =>
      setHist((h) => {
        const next = fn(h.present.recipe);
        const now = performance.now();
        const fold = now < foldNext.current && h.past.length > 0;
        foldNext.current = 0;
        if (next === h.present.recipe) return h;
        const sig = typing ? changeSignature(h.present.recipe, next) : null;
        const same = fold || (sig !== null && lastEdit.current?.sig === sig && now - lastEdit.current.t < 800 && h.past.length > 0);
        lastEdit.current = sig !== null ? { sig, t: now } : null;
        return change(h, withRecipe(h.present, next), same);
      }),
    [],
  );
  const typingEdit = useCallback((fn: (r: Recipe) => Recipe) => edit(fn, true), [edit]);

  // The run the GUI shows: one started here, or the latest run of a recipe just opened (replayed
  // from the store, #25 fault 8: quietly, no toast and no jump to the mask tab).
  const shownRun = useRef<{ id: string; replay: boolean } | null>(null);
  const lastOpened = useRef<string | null>(null); // the recipe opened last (null: a new one)
  const { run, follow, cancel, reset } = useRun(async (s) => {
    if (!s.id || shownRun.current?.id !== s.id) return; // another recipe was opened meanwhile
    const quiet = shownRun.current.replay;
    try {
      const arts = await API.listArtifacts(s.id);
      setArtifacts(arts);
      // The run's merged parameter XML (new zones filled from the template) never replaces the
      // user's text nor marks the recipe unsaved: it is kept aside, shown while the user has no XML.
      const merged = arts.find((a) => a.name.endsWith(".params.xml"));
      if (s.phase === "done" && merged) setRunXml(await API.artifactText(s.id, merged.name));
      // Read whenever the run wrote one (a failing preflight may end the run as failed).
      if (arts.some((a) => a.name === "preflight.json")) setPreflight(parsePreflight(await API.artifactText(s.id, "preflight.json")));
    } catch (e) {
      fail(e);
    }
    if (s.phase === "failed" && s.error) {
      setFailure(s.error);
      if (quiet) return;
      if (s.error.layer != null) setTab("mask");
      message(`run failed: ${s.error.message}`);
    } else if (s.phase === "done" && !quiet) message("run finished");
  });

  // ---- loading ----------------------------------------------------------------------------------
  const refreshGraphs = useCallback(() => API.listGraphs().then(setGraphs).catch(fail), [fail]);
  useEffect(() => {
    API.nodes().then(setSpecs).catch(fail);
    API.processParameters().then(setProcessParams).catch(fail);
    API.health().then(setHealth).catch(fail);
    void refreshGraphs();
  }, [fail, refreshGraphs]);

  // ---- drafts: every unsaved change is kept in the browser until saved or discarded -------------
  // Only a draft this page wrote is removed when its edits are undone (another tab's or a crashed
  // session's draft stays until the user answers the offer).
  const wroteDraft = useRef<string | null>(null);
  useEffect(() => {
    if (offer) return; // the stored draft waits for the user's answer
    const key = graphName ?? "";
    if (!dirty) {
      if (wroteDraft.current === key) clearDraft(localStorage, graphName);
      wroteDraft.current = null;
      return;
    }
    const problem = writeDraft(localStorage, graphName, { recipe, xml: xmlDirty ? xmlDraft : null, tab, savedAt: Date.now() });
    wroteDraft.current = key;
    if (problem) message(problem);
  }, [dirty, recipe, xmlDraft, xmlDirty, tab, graphName, offer, message]);

  const reset_ = useCallback(
    (full: Recipe, name: string | null, xml: string | null) => {
      setHist(newDocument(full, xml));
      setSaved(savedOf({ recipe: full, xml }));
      setGraphName(name);
      setRunXml(null);
      setXmlError(null);
      setSelected(new Set());
      setPreviewNode(null);
      setFailure(null);
      setRequestError(null);
      setArtifacts([]);
      setPreflight(null);
      setPreflightOf(null);
      setPfMark(null);
      setLayer(0);
      shownRun.current = null;
      lastOpened.current = name;
      reset();
      const d = readDraft(localStorage, name);
      setOffer(d && draftDiffers(d, full, xml) ? d : null);
      setTimeout(() => rf.fitView({ padding: 0.15 }), 50);
    },
    [rf, reset],
  );

  /** Reopened recipe: its latest run's results, plots, problems and preflight (#25 fault 8). They
   * count as current when that run used the recipe and XML as saved (the server compares). */
  const showLatestRun = useCallback(
    async (name: string, full: Recipe, xml: string | null) => {
      const [last] = await API.runsOf(name, 1);
      if (!last || lastOpened.current !== name) return; // another recipe opened meanwhile
      const current = last.same_as_saved !== false;
      setPreflightOf({ recipe: current ? recipeSignature(full) : "(not the saved recipe)", xml });
      shownRun.current = { id: last.id, replay: true };
      follow(last.id);
    },
    [follow],
  );

  // The recipe being fetched after a pick in the toolbar: until it is shown, "run" would run the
  // one still on screen, so it waits.
  const [opening, setOpening] = useState<string | null>(null);
  const open = useCallback(
    async (name: string, tabAfter?: Tab) => {
      setOpening(name);
      try {
        const [r, list] = await Promise.all([API.getGraph(name), API.listGraphs()]);
        setGraphs(list);
        // Only asked for when there is one: a 404 would be noise in the browser's console.
        const xml = list.find((g) => g.name === name)?.has_params ? await API.getParams(name) : null;
        const stored = await API.listFiles(name).catch(() => []);
        const full: Recipe = pinStored({ ...emptyRecipe(name), ...r }, stored);
        setXmlLoadError(xml === null ? "This graph has no parameter file yet: run it once to create the template." : null);
        reset_(full, name, xml);
        if (tabAfter) setTab(tabAfter);
        await showLatestRun(name, full, xml);
      } catch (e) {
        fail(e);
      } finally {
        setOpening(null);
      }
    },
    [fail, reset_, showLatestRun],
  );

  const restoreOffer = () => {
    if (!offer) return;
    // One undo step back to the saved recipe.
    setHist((h) => change(h, { recipe: offer.recipe, xml: offer.xml ?? h.present.xml }));
    setTab(asTab(offer.tab));
    setOffer(null);
    message("restored the unsaved changes");
  };
  const discardOffer = () => {
    clearDraft(localStorage, graphName);
    setOffer(null);
  };

  // ---- the URL names the open recipe and tab; back/forward move between them ----------------------
  const navigating = useRef(false);
  // The listener set up once reads the current `open` (it changes with the recipe list).
  const openRef = useRef(open);
  openRef.current = open;
  useEffect(() => {
    const open = openRef.current;
    const place = parsePlace(location.search);
    if (place.graph) {
      navigating.current = true;
      void open(place.graph, asTab(place.tab)).finally(() => (navigating.current = false));
    } else if (place.tab) setTab(asTab(place.tab));
    const onPop = () => {
      const p = parsePlace(location.search);
      navigating.current = true;
      const done = () => {
        setTab(asTab(p.tab));
        navigating.current = false;
      };
      if (p.graph && p.graph !== graphRef.current) void openRef.current(p.graph, asTab(p.tab)).finally(done);
      else done();
    };
    window.addEventListener("popstate", onPop);
    return () => window.removeEventListener("popstate", onPop);
  }, []);
  const graphRef = useRef(graphName);
  graphRef.current = graphName;
  useEffect(() => {
    if (navigating.current) return;
    const want = placeSearch({ graph: graphName, tab });
    if (want !== location.search) window.history.pushState(null, "", want || location.pathname);
  }, [graphName, tab]);

  const bounds = useMemo(() => boundsByName(processParams), [processParams]);
  // A save refused because someone saved since this recipe was opened (409): the user decides.
  const [conflict, setConflict] = useState<Conflict | null>(null);
  // The saved recipe's history dialog (#25 Build 2): an earlier revision opens as an unsaved edit.
  const [showHistory, setShowHistory] = useState(false);

  const save = useCallback(
    async (name: string | null = graphName) => {
      if (!name || (isExample && name === graphName)) {
        // Shipped examples are read-only: saving one means saving a copy under a new name.
        setSaveAs(name ? `${name}-copy` : recipe.name || "untitled");
        if (isExample) message(`${graphName} is a shipped example (read-only): save as a new name`);
        return false;
      }
      const xml = xmlText;
      const blocked = xml !== null && (xmlDirty || name !== graphName) ? saveBlocker(xml, bounds) : null;
      if (blocked) {
        setXmlError({ message: blocked });
        message(blocked);
        setTab("params");
        return false;
      }
      try {
        const toSave = { ...recipe, name };
        // Recipe first, then its XML; the local draft is kept until both are stored, so a failure
        // in between loses nothing (the draft is offered back on the next open).
        const res = await API.putGraph(name, toSave);
        if (xml !== null && (xmlDirty || name !== graphName)) await API.putParams(name, xml);
        // "save as": the pinned uploads go along, the exact content each pin names
        if (graphName && name !== graphName)
          for (const [fname, sha] of Object.entries(toSave.files ?? {})) await API.putFile(name, fname, await API.getFile(graphName, fname, sha));
        for (const f of pendingFiles.current.splice(0)) {
          await API.putFile(name, f.name, f);
          message(`uploaded ${f.name}`);
        }
        clearDraft(localStorage, graphName);
        clearDraft(localStorage, name);
        setHist((h) => ({ ...h, present: { recipe: toSave, xml } }));
        setSaved(savedOf({ recipe: toSave, xml }));
        setXmlError(null);
        setXmlLoadError(null);
        setGraphName(name);
        if (res.problems.length) message(`saved; not runnable yet: ${String(res.problems[0].message)}`);
        else message(`saved ${name}`);
        void refreshGraphs();
        return true;
      } catch (e) {
        const c = conflictOf(e);
        if (c) {
          setConflict(c);
          return false;
        }
        if (e instanceof API.ApiError) setXmlError(e.detail.layer != null ? e.detail : null);
        fail(e);
        return false;
      }
    },
    [graphName, isExample, recipe, xmlText, xmlDirty, bounds, message, fail, refreshGraphs],
  );

  const remove = async () => {
    if (!graphName || isExample || !window.confirm(`Delete graph ${graphName}?`)) return;
    try {
      await API.deleteGraph(graphName);
      message(`deleted ${graphName}`);
      clearDraft(localStorage, graphName);
      setGraphName(null);
      setSaved((s) => ({ ...s, recipeJson: "" }));
      void refreshGraphs();
    } catch (e) {
      fail(e);
    }
  };

  const startRun = async () => {
    setFailure(null);
    setRequestError(null);
    setArtifacts([]);
    setPreflight(null);
    setPfMark(null);
    setPreflightOf({ recipe: recipeSig, xml: doc.xml });
    reset(); // the progress bar starts from zero for the new run
    try {
      // The recipe runs exactly as displayed (unsaved edits included) with the XML as shown in the
      // editor (a draft: never stored by the run); a saved graph lends it its uploaded files.
      const { id } = await API.startRun(runRequest(doc, graphName));
      shownRun.current = { id, replay: false };
      follow(id);
    } catch (e) {
      if (e instanceof API.ApiError) {
        if (e.detail.node || e.detail.layer != null) setFailure(e.detail);
        setRequestError(e.detail);
        if (e.detail.node && recipe.nodes.some((n) => n.id === e.detail.node)) {
          setSelected(new Set([e.detail.node]));
          setShowProblems(true);
        }
      }
      fail(e);
    }
  };

  const addAt = useCallback(
    (type: string, at?: XY) => {
      const spec = catalog.get(type);
      if (!spec) return;
      const all = positionsOf(recipe);
      const anchorId = [...selected].find((id) => all[id]);
      // Without a drop point: right of the selected node (else of the rightmost one); either way
      // on free space, never on top of another node.
      let want = at;
      if (!want) {
        const right = anchorId ?? Object.keys(all).sort((a, b) => all[b][0] - all[a][0])[0];
        want = right ? [all[right][0] + 230, all[right][1]] : [0, 0];
      }
      const pos = freeSpot(Object.values(all), want);
      // A new node starts with empty params: the engine applies the schema defaults and the form
      // shows them as placeholders, so the recipe only records what the user changed.
      const { recipe: r, id } = addNode(recipe, spec, pos);
      // Wired from the selected node's first compatible output, like ComfyUI/Grasshopper.
      const wired = selected.size === 1 && anchorId ? autoWire(catalog, r, anchorId, id) : { recipe: r, edge: null };
      edit(() => wired.recipe);
      if (wired.edge) message(`wired ${wired.edge.from} → ${wired.edge.to}`);
      setSelected(new Set([id]));
      setTab("graph");
    },
    [catalog, recipe, selected, edit, message],
  );

  const upload = useCallback(
    async (file: File): Promise<string | null> => {
      if (!graphName || isExample) {
        // Files belong to a saved graph: keep the file here, ask for a name, upload on save.
        pendingFiles.current = [...pendingFiles.current.filter((f) => f.name !== file.name), file];
        setSaveAs(graphName ? `${graphName}-copy` : recipe.name || "untitled");
        message(`save the recipe under a name of its own: ${file.name} is uploaded right after`);
        return file.name;
      }
      try {
        // A name the recipe's files already have: the user decides (never replaced at once).
        const [stored, sha] = await Promise.all([API.listFiles(graphName), sha256Hex(file)]);
        const have = stored.find((f) => f.name === file.name);
        let name = file.name;
        if (have?.sha256 && have.sha256 !== sha) {
          const other = freeName(file.name, stored.map((f) => f.name));
          const choice = await new Promise<UploadChoice>((resolve) =>
            setUploadAsk({ ask: { name, size: file.size, have: { size: have.size, updated: have.updated, sha256: have.sha256! }, other }, resolve }));
          setUploadAsk(null);
          if (choice === "cancel") {
            message(`${file.name} not uploaded: the recipe keeps the stored one`);
            return null;
          }
          if (choice === "both") name = other;
        }
        const digest = (await API.putFile(graphName, name, file)) ?? sha;
        // the recipe now runs with this content: one undo step (undo pins the previous content again)
        setHist((h) => change(h, withPin(h.present, name, digest)));
        foldNext.current = performance.now() + 1500; // "keep both": the new name is set in the same step
        message(`uploaded ${name}${have && name === file.name && have.sha256 !== digest ? " (replaced: undo brings the old one back)" : ""}`);
        return name;
      } catch (e) {
        fail(e);
        return null;
      }
    },
    [graphName, isExample, recipe.name, message, fail],
  );
  const [uploadAsk, setUploadAsk] = useState<{ ask: UploadAsk; resolve: (c: UploadChoice) => void } | null>(null);

  useShortcuts({
    graphActive: tab === "graph",
    save: () => void save(),
    undo: () => setHist(undo<Doc>),
    redo: () => setHist(redo<Doc>),
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
    search: () => {
      const box = document.querySelector("[data-testid=graph-editor]")?.getBoundingClientRect();
      if (!box) return;
      const x = box.left + box.width / 2, y = box.top + box.height / 3;
      const at = rf.screenToFlowPosition({ x, y });
      setSearch({ x, y, at: [Math.round(at.x), Math.round(at.y)] });
    },
  });

  // Badges, count and list describe the run of the recipe and XML on screen: stale once either changes.
  const problems = useMemo(
    () => currentProblems(collectProblems(run.warnings, [requestError, run.error]), preflightOf, { recipe: recipeSig, xml: doc.xml }),
    [run.warnings, run.error, requestError, preflightOf, recipeSig, doc.xml],
  );
  const nodeProblems = useMemo(() => problemsByNode(problems), [problems]);
  const pickProblem = (pr: Problem) => {
    if (pr.node && recipe.nodes.some((n) => n.id === pr.node)) {
      setSelected(new Set([pr.node]));
      const pos = positionsOf(recipe)[pr.node];
      if (pos && tab === "graph") rf.setCenter(pos[0] + 100, pos[1] + 50, { zoom: rf.getZoom(), duration: 200 });
    }
    // its section: selected on the mask canvas and picked in the inspector's per-section forms
    if (pr.section) focusSection(pr.section);
    if (pr.layer != null || pr.section) {
      if (pr.layer != null) setLayer(pr.layer);
      setTab("mask");
    } else if (pr.node) setTab("graph");
  };

  /** New mask from layer N, carrying each continuing section's settings and XML values over. */
  const newMaskFrom = (e: NewMaskEvent): boolean => {
    const masks = e.params.masks ?? [];
    const made = masks.find((m) => m.id === e.newId);
    if (!made) return false;
    const before: MaskParams = { ...e.params, masks: masks.filter((m) => m.id !== e.newId) };
    const old = governingMask(before, e.layer);
    const oldKeys = old ? old.sections.map((x) => sectionKey(old.id, x.id)) : [];
    const oldRegions = old ? oldRegionsForCarry(old.id, old.sections, e.regions) : [];
    const next = made.sections.map((x) => ({ key: sectionKey(made.id, x.id), polygon: { exterior: x.curve, holes: [] } }));
    const above = masks.filter((m) => m.from_layer > e.layer).map((m) => m.from_layer);
    const plan = carryOver(setNodeParams(recipe, e.maskNode, e.params), {
      matches: matchByOverlap(oldRegions, next), oldKeys, oldRegions: oldRegions.map((x) => x.key), from: e.layer,
      to: above.length ? Math.min(...above) : null, xml: xmlText,
    });
    const text = [
      `New mask ${made.id} from layer ${e.layer}.`,
      plan.carried.length ? `Carried over:\n  ${plan.carried.join("\n  ")}` : "Nothing to carry over.",
      plan.lost.length ? `Could NOT carry:\n  ${plan.lost.join("\n  ")}` : "Everything carried over.",
    ].join("\n\n");
    if (!window.confirm(text)) return false;
    // recipe and XML in one undo step
    setHist((h) => change(h, { recipe: plan.recipe, xml: plan.xml !== xmlText ? plan.xml : h.present.xml }));
    message(`mask ${made.id} from layer ${e.layer}: ${plan.carried.length} setting(s) carried${plan.lost.length ? `, ${plan.lost.length} not` : ""}`);
    return true;
  };

  /** A preflight problem: its node selected, its layer and section shown on the mask canvas, its point marked. */
  const pickPreflight = (pr: PreflightProblem, draw = false) => {
    if (pr.node && recipe.nodes.some((n) => n.id === pr.node)) setSelected(new Set([pr.node]));
    if (pr.section) focusSection(pr.section);
    if (pr.layer != null) {
      setLayer(pr.layer);
      setPfMark((m) => ({ layer: pr.layer!, point: pr.point ?? null, section: pr.section ?? null, draw, message: pr.message, seq: (m?.seq ?? 0) + 1 }));
      setTab("mask");
    } else if (pr.node) setTab("graph");
  };

  const single = selected.size === 1 ? recipe.nodes.find((n) => selected.has(n.id)) ?? null : null;
  const onPreview = useCallback((id: string) => setPreviewNode((cur) => (cur === id ? null : id)), []);
  const preflightStale = isStale(preflight, preflightOf, { recipe: recipeSig, xml: doc.xml });
  const badge = preflightBadge({ phase: run.phase, report: preflight, stale: preflightStale });
  const canvasStarts = useMemo(() => (preflight && !preflightStale ? { ...layerStarts(preflight, layer), radius: beadWidthOf(preflight) } : null), [preflight, preflightStale, layer]);
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
        canRun={recipe.nodes.length > 0 && opening === null}
        opening={opening}
        run={run}
        isExample={isExample}
        problemCount={problems.length}
        errorCount={problems.filter((x) => x.severity === "error").length}
        onProblems={() => setShowProblems((v) => !v)}
        preflight={<PreflightBadge view={badge} onOpen={() => setShowProblems(true)} />}
        onFrame={() => {
          const box = document.querySelector("[data-testid=graph-editor]")?.getBoundingClientRect();
          const c = box ? rf.screenToFlowPosition({ x: box.left + 40, y: box.top + 40 }) : { x: 0, y: 0 };
          const { recipe: r } = addFrame(recipe, selected, selected.size ? `group of ${selected.size}` : "group", [Math.round(c.x), Math.round(c.y)]);
          edit(() => r);
          setTab("graph");
        }}
        onOpen={(name) => void open(name)}
        onNew={() => {
          setXmlLoadError(null);
          reset_(emptyRecipe(), null, null);
        }}
        onSave={save}
        onDelete={remove}
        onHistory={() => setShowHistory(true)}
        onUndo={() => setHist(undo<Doc>)}
        onRedo={() => setHist(redo<Doc>)}
        onRun={startRun}
        onCancel={() => void cancel()}
        saveAs={saveAs}
        setSaveAs={setSaveAs}
      />
      {offer && (
        <div className="draft-offer" role="alertdialog" aria-label="unsaved changes" data-testid="draft-offer">
          restore unsaved changes from {new Date(offer.savedAt).toLocaleString()}?
          <button onClick={restoreOffer} data-testid="draft-restore">restore</button>
          <button onClick={discardOffer} data-testid="draft-discard">discard</button>
        </div>
      )}
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
                problems={nodeProblems}
                onSearch={(x, y, at) => setSearch({ x, y, at })}
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
                  onNewMask={newMaskFrom}
                  starts={canvasStarts}
                  mark={pfMark}
                  onMarkDone={() => setPfMark((m) => (m ? { ...m, draw: false } : m))}
                />
              </div>
            )}
            {tab === "params" && (
              <div className="pane scroll" {...tabPanelProps("params")}>
                <ParamsEditor
                  graph={graphName}
                  text={xmlText}
                  unsaved={xmlDirty}
                  loadError={xmlText === null ? xmlLoadError : null}
                  onChange={(t) => setXmlDraft(t, true)}
                  onSave={() => void save()}
                  onDiscard={() => {
                    if (window.confirm("Drop the unsaved parameter XML?")) setXmlDraft(savedXml);
                  }}
                  serverError={xmlError}
                  runId={run.phase === "done" ? run.id : null}
                  runParamsArtifacts={zoneArtifacts}
                  runWarnings={run.warnings.filter((w) => w.node && recipe.nodes.some((n) => n.id === w.node && n.type === "zone"))}
                  parameters={processParams}
                  dirtyRecipe={recipeDirty}
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
      {showProblems && (
        <ProblemsPanel
          problems={problems}
          onPick={pickProblem}
          onClose={() => setShowProblems(false)}
          preflight={preflight}
          preflightStale={preflightStale}
          onPickPreflight={(pr) => pickPreflight(pr)}
          onMaskHere={(pr) => pickPreflight(pr, true)}
        />
      )}
      {conflict && (
        <ConflictDialog
          conflict={conflict}
          onReload={() => {
            setConflict(null);
            clearDraft(localStorage, conflict.name);
            void open(conflict.name);
          }}
          onOverwrite={() => {
            overwriteWith(conflict);
            setConflict(null);
            void save(conflict.name);
          }}
          onSaveAs={() => {
            setConflict(null);
            setSaveAs(`${conflict.name}-copy`);
          }}
          onCancel={() => setConflict(null)}
        />
      )}
      {showHistory && graphName && !isExample && (
        <HistoryDialog
          name={graphName}
          current={recipe}
          onClose={() => {
            setShowHistory(false);
            document.querySelector<HTMLElement>("[data-testid=history]")?.focus();
          }}
          onOpen={(r, rev) => {
            // One undo step on top of what is on screen; the loaded revision (If-Match) stays the
            // current one, so "save" stores it as a new revision, never over someone's save.
            setHist((h) => change(h, withRecipe(h.present, { ...r, name: graphName, files: r.files ?? h.present.recipe.files })));
            setShowHistory(false);
            message(`revision ${rev} opened as an unsaved change: save to make it the newest revision, or undo`);
          }}
        />
      )}
      {uploadAsk && <UploadDialog ask={uploadAsk.ask} onChoose={uploadAsk.resolve} />}
      {search && (
        <NodeSearch
          specs={specs}
          at={{ x: search.x, y: search.y }}
          onClose={() => setSearch(null)}
          onPick={(type) => {
            addAt(type, search.at);
            setSearch(null);
          }}
        />
      )}
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
