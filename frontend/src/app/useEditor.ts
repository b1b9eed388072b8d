// The editor's state, by concern: messages, what the server offers (catalog), the recipe document,
// the view, the selection, the run and its findings, drafts, saving, uploads, opening, the URL.
// App.tsx only lays it out; each concern is its own hook with its own tests.
import { useCallback, useMemo } from "react";
import type { Recipe } from "../api/types";
import { useDocument } from "../document/useDocument";
import { useDraftOffer } from "../document/useDraftOffer";
import { useSave } from "../document/useSave";
import { useUpload } from "../document/useUpload";
import { recipeSignature } from "../preflight/preflight";
import { useRunFindings, useRunView } from "../run/useRunView";
import { isExampleGraph, useCatalog } from "./useCatalog";
import { useMessages } from "./useMessages";
import { useOpen } from "./useOpen";
import { usePlace } from "./usePlace";
import { useSelection } from "./useSelection";
import { useView } from "./useView";

export function useEditor() {
  const { messages, message, fail } = useMessages();
  const cat = useCatalog(fail);
  const doc = useDocument();
  const view = useView();
  const sel = useSelection(doc.recipe);
  const { setTab } = view;
  const toMask = useCallback(() => setTab("mask"), [setTab]);
  const runs = useRunView({ message, fail, toMask });
  const drafts = useDraftOffer(doc, view.tab, setTab, message);
  const isExample = isExampleGraph(cat.graphs, doc.graphName);
  const xmlText = doc.doc.xml ?? runs.runXml;
  const saving = useSave({ doc, xmlText, isExample, bounds: cat.bounds, message, fail, refreshGraphs: cat.refreshGraphs, setTab });
  const uploads = useUpload({ doc, isExample, saving, message, fail });

  const { setSelected } = sel;
  const { clear: clearView } = view;
  const { setXmlError, setXmlLoadError } = saving;
  const { offerFor } = drafts;
  const onLoaded = useCallback((name: string | null, recipe: Recipe, xml: string | null) => {
    setSelected(new Set());
    clearView();
    setXmlError(null);
    offerFor(name, recipe, xml);
  }, [setSelected, clearView, setXmlError, offerFor]);
  const opener = useOpen({ doc, runs, setGraphs: cat.setGraphs, setTab, onLoaded, setXmlLoadError, fail });
  usePlace(doc.graphName, view.tab, setTab, opener.open);

  // The recipe as the engine runs it, without its name (a save under a new name changes nothing).
  const recipeSig = useMemo(() => recipeSignature(doc.recipe), [doc.recipe]);
  const findings = useRunFindings(runs, { recipe: recipeSig, xml: doc.doc.xml }, view.layer);
  return { messages, message, fail, cat, doc, view, sel, runs, drafts, isExample, xmlText, saving, uploads, opener, findings };
}

export type Editor = ReturnType<typeof useEditor>;
