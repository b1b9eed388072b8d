// What the user does across concerns: run, add a node, pick a problem, make a new mask from a
// layer, group into a frame, the keyboard shortcuts; and the panels they open (problems, history,
// node search).
import { useCallback, useRef, useState } from "react";
import { useReactFlow } from "@xyflow/react";
import type { Problem } from "../problems/problems";
import type { PreflightProblem } from "../preflight/preflight";
import { change } from "../document/document";
import { focusSection } from "../forms/sectionKeys";
import { addFrame, copySelection, paste, positionsOf, type Clip, type XY } from "../graph/recipe";
import { useShortcuts } from "../graph/useShortcuts";
import type { NewMaskEvent } from "../mask/MaskView";
import { newMaskPlan, placeNew, problemTarget } from "./actions";
import type { Editor } from "./useEditor";

const graphBox = () => document.querySelector("[data-testid=graph-editor]")?.getBoundingClientRect();

export function useEditorActions(ed: Editor) {
  const rf = useReactFlow();
  const [showProblems, setShowProblems] = useState<boolean | "preflight">(false); // "preflight": opened from its badge
  // The saved recipe's history dialog (#25 Build 2): an earlier revision opens as an unsaved edit.
  const [showHistory, setShowHistory] = useState(false);
  const [search, setSearch] = useState<{ x: number; y: number; at: XY } | null>(null);
  const clip = useRef<Clip | null>(null);
  const { doc, sel, view, runs, message } = ed;
  const { recipe, edit } = doc;
  const { selected, setSelected } = sel;
  const { catalog } = ed.cat;
  const { setTab, setLayer, tab } = view;

  const startRun = async () => {
    const refused = await runs.start(doc.doc, doc.graphName);
    if (refused?.node && recipe.nodes.some((n) => n.id === refused.node)) {
      setSelected(new Set([refused.node]));
      setShowProblems(true);
    }
  };
  const addAt = useCallback((type: string, at?: XY) => {
    const spec = catalog.get(type);
    if (!spec) return;
    const made = placeNew(catalog, recipe, selected, spec, at);
    edit(() => made.recipe);
    if (made.edge) message(`wired ${made.edge.from} → ${made.edge.to}`);
    setSelected(new Set([made.id]));
    setTab("graph");
  }, [catalog, recipe, selected, edit, message, setSelected, setTab]);
  const pickProblem = (pr: Problem) => {
    const to = problemTarget(pr, recipe);
    if (to.select) {
      setSelected(new Set([to.select]));
      const pos = positionsOf(recipe)[to.select];
      if (pos && tab === "graph") rf.setCenter(pos[0] + 100, pos[1] + 50, { zoom: rf.getZoom(), duration: 200 });
    }
    // its section: selected on the mask canvas and picked in the inspector's per-section forms
    if (pr.section) focusSection(pr.section);
    if (to.layer != null) setLayer(to.layer);
    if (to.tab) setTab(to.tab);
  };
  /** A preflight problem: its node selected, its layer and section shown on the mask canvas, its point marked. */
  const pickPreflight = (pr: PreflightProblem, draw = false) => {
    const to = problemTarget(pr, recipe, false);
    if (to.select) setSelected(new Set([to.select]));
    if (pr.section) focusSection(pr.section);
    if (to.layer != null) {
      const layer = to.layer;
      setLayer(layer);
      runs.setPfMark((m) => ({ layer, point: pr.point ?? null, section: pr.section ?? null, draw, message: pr.message, seq: (m?.seq ?? 0) + 1 }));
    }
    if (to.tab) setTab(to.tab);
  };
  /** New mask from layer N, carrying each continuing section's settings and XML values over. */
  const newMaskFrom = (e: NewMaskEvent): boolean => {
    const made = newMaskPlan(e, recipe, ed.xmlText);
    if (!made || !window.confirm(made.text)) return false;
    const { plan } = made;
    // recipe and XML in one undo step
    doc.setHist((h) => change(h, { recipe: plan.recipe, xml: plan.xml !== ed.xmlText ? plan.xml : h.present.xml }));
    message(made.summary);
    return true;
  };
  const frame = () => {
    const box = graphBox();
    const c = box ? rf.screenToFlowPosition({ x: box.left + 40, y: box.top + 40 }) : { x: 0, y: 0 };
    const { recipe: r } = addFrame(recipe, selected, selected.size ? `group of ${selected.size}` : "group", [Math.round(c.x), Math.round(c.y)]);
    edit(() => r);
    setTab("graph");
  };
  useShortcuts({
    graphActive: tab === "graph",
    save: () => void ed.saving.save(),
    undo: doc.undo,
    redo: doc.redo,
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
      const box = graphBox();
      if (!box) return;
      const x = box.left + box.width / 2, y = box.top + box.height / 3;
      const at = rf.screenToFlowPosition({ x, y });
      setSearch({ x, y, at: [Math.round(at.x), Math.round(at.y)] });
    },
  });
  return { startRun, addAt, pickProblem, pickPreflight, newMaskFrom, frame, showProblems, setShowProblems, showHistory, setShowHistory, search, setSearch };
}

export type EditorActions = ReturnType<typeof useEditorActions>;
