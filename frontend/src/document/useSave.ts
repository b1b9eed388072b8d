// Saving, "save as" and deleting the open recipe: the recipe, then its parameter XML, then its
// files; a save refused by a newer save elsewhere (409) becomes the conflict dialog; the local
// draft is kept until everything is stored.
import { useCallback, useRef, useState } from "react";
import * as API from "../api/client";
import type { RunError } from "../api/types";
import type { Tab } from "../app/tabs";
import { conflictOf, type Conflict } from "../components/ConflictDialog";
import { clearDraft } from "../graph/drafts";
import { saveBlocker, type Bounds } from "../xml/params";
import type { DocumentState } from "./useDocument";

/** A save that must first ask for a name: no name yet, or a shipped (read-only) example saved
 * under its own name. Returns the proposed name and what to tell the user, else null. */
export function saveAsInstead(name: string | null, o: { graphName: string | null; isExample: boolean; recipeName: string }): { proposal: string; message: string | null } | null {
  if (name && !(o.isExample && name === o.graphName)) return null;
  return {
    proposal: name ? `${name}-copy` : o.recipeName || "untitled",
    message: o.isExample ? `${o.graphName} is a shipped example (read-only): save as a new name` : null,
  };
}

/** Whether a save under `name` stores the XML text: there is one, and it is unsaved or goes to a new name. */
export const storesXml = (xml: string | null, o: { xmlDirty: boolean; name: string; graphName: string | null }) =>
  xml !== null && (o.xmlDirty || o.name !== o.graphName);

export interface SaveDeps {
  doc: DocumentState;
  /** The XML the editor shows (the user's, else the last run's template). */
  xmlText: string | null;
  isExample: boolean;
  bounds: Record<string, Bounds>;
  message: (t: string) => void;
  fail: (e: unknown) => void;
  refreshGraphs: () => void;
  setTab: (t: Tab) => void;
}

export function useSave(o: SaveDeps) {
  const [saveAs, setSaveAs] = useState<string | null>(null);
  const [xmlError, setXmlError] = useState<(RunError & Record<string, unknown>) | null>(null);
  const [xmlLoadError, setXmlLoadError] = useState<string | null>(null);
  // A save refused because someone saved since this recipe was opened (409): the user decides.
  const [conflict, setConflict] = useState<Conflict | null>(null);
  // Files picked before the recipe had a name of its own: uploaded right after the save.
  const pendingFiles = useRef<File[]>([]);
  const { graphName, recipe, dirty, markSaved, markDeleted } = o.doc;
  const { xmlText, isExample, bounds, message, fail, refreshGraphs, setTab } = o;

  const save = useCallback(
    async (name: string | null = graphName) => {
      const ask = saveAsInstead(name, { graphName, isExample, recipeName: recipe.name });
      if (ask || !name) {
        setSaveAs(ask?.proposal ?? "untitled");
        if (ask?.message) message(ask.message);
        return false;
      }
      const xml = xmlText;
      const withXml = storesXml(xml, { xmlDirty: dirty.xml, name, graphName });
      const blocked = withXml ? saveBlocker(xml!, bounds) : null;
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
        if (withXml) await API.putParams(name, xml!);
        // "save as": the pinned uploads go along, the exact content each pin names
        if (graphName && name !== graphName)
          for (const [fname, sha] of Object.entries(toSave.files ?? {})) await API.putFile(name, fname, await API.getFile(graphName, fname, sha));
        for (const f of pendingFiles.current.splice(0)) {
          await API.putFile(name, f.name, f);
          message(`uploaded ${f.name}`);
        }
        clearDraft(localStorage, graphName);
        clearDraft(localStorage, name);
        markSaved(toSave, xml, name);
        setXmlError(null);
        setXmlLoadError(null);
        message(res.problems.length ? `saved; not runnable yet: ${String(res.problems[0].message)}` : `saved ${name}`);
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
    [graphName, isExample, recipe, xmlText, dirty.xml, bounds, message, fail, refreshGraphs, setTab, markSaved],
  );

  const remove = useCallback(async () => {
    if (!graphName || isExample || !window.confirm(`Delete graph ${graphName}?`)) return;
    try {
      await API.deleteGraph(graphName);
      message(`deleted ${graphName}`);
      clearDraft(localStorage, graphName);
      markDeleted();
      void refreshGraphs();
    } catch (e) {
      fail(e);
    }
  }, [graphName, isExample, message, fail, refreshGraphs, markDeleted]);

  return { save, remove, saveAs, setSaveAs, xmlError, setXmlError, xmlLoadError, setXmlLoadError, conflict, setConflict, pendingFiles };
}

export type SaveState = ReturnType<typeof useSave>;
