// Opening a stored recipe (or a new one): the document, its parameter XML, its pinned files, the
// draft offered back, and its latest run's results; until it is shown, "run" waits (`opening`).
import { useCallback, useState } from "react";
import { useReactFlow } from "@xyflow/react";
import * as API from "../api/client";
import type { FileInfo, GraphInfo, Recipe } from "../api/types";
import { pinStored } from "../document/document";
import type { DocumentState } from "../document/useDocument";
import { emptyRecipe } from "../graph/recipe";
import type { RunView } from "../run/useRunView";
import type { Tab } from "./tabs";

/** Shown in the XML tab of a recipe stored without a parameter file. */
export const NO_XML_YET = "This graph has no parameter file yet: run it once to create the template.";

/** The recipe `name` as opened: the stored one over an empty recipe, its files pinned as stored. */
export const openedRecipe = (name: string, stored: Partial<Recipe>, files: readonly FileInfo[]): Recipe =>
  pinStored({ ...emptyRecipe(name), ...stored }, files);

export interface OpenDeps {
  doc: DocumentState;
  runs: RunView;
  setGraphs: (g: GraphInfo[]) => void;
  setTab: (t: Tab) => void;
  /** Everything else that belongs to the recipe shown before: cleared (selection, view, errors, draft offer). */
  onLoaded: (name: string | null, recipe: Recipe, xml: string | null) => void;
  setXmlLoadError: (e: string | null) => void;
  fail: (e: unknown) => void;
}

export function useOpen(o: OpenDeps) {
  const rf = useReactFlow();
  const [opening, setOpening] = useState<string | null>(null);
  const { load } = o.doc;
  const { clear, showLatestRun } = o.runs;
  const { onLoaded, setGraphs, setTab, setXmlLoadError, fail } = o;
  /** Show `recipe` as stored under `name` (null: a new recipe). */
  const show = useCallback((recipe: Recipe, name: string | null, xml: string | null) => {
    load(recipe, name, xml);
    clear(name);
    onLoaded(name, recipe, xml);
    setTimeout(() => rf.fitView({ padding: 0.15 }), 50);
  }, [load, clear, onLoaded, rf]);
  const open = useCallback(async (name: string, tabAfter?: Tab) => {
    setOpening(name);
    try {
      const [r, list] = await Promise.all([API.getGraph(name), API.listGraphs()]);
      setGraphs(list);
      // Only asked for when there is one: a 404 would be noise in the browser's console.
      const xml = list.find((g) => g.name === name)?.has_params ? await API.getParams(name) : null;
      const full = openedRecipe(name, r, await API.listFiles(name).catch(() => []));
      setXmlLoadError(xml === null ? NO_XML_YET : null);
      show(full, name, xml);
      if (tabAfter) setTab(tabAfter);
      await showLatestRun(name, { recipe: full, xml });
    } catch (e) {
      fail(e);
    } finally {
      setOpening(null);
    }
  }, [fail, show, showLatestRun, setGraphs, setTab, setXmlLoadError]);
  /** A new, empty recipe. */
  const openNew = useCallback(() => {
    setXmlLoadError(null);
    show(emptyRecipe(), null, null);
  }, [show, setXmlLoadError]);
  return { open, openNew, opening };
}
