// The open recipe's document as React state: the recipe and its parameter XML in one history
// (undo/redo restore both), what was last saved, and the recipe's name. The undo-step rules
// (typing folds into one step, an upload's file name joins the upload's step) are the pure
// `editStep` / `xmlStep` below; the hook only keeps their clocks.
import { useCallback, useRef, useState } from "react";
import type { Recipe } from "../api/types";
import { changeSignature, emptyRecipe, redo, undo, type History } from "../graph/recipe";
import { change, isDirty, newDocument, recipeDirty, savedOf, withRecipe, withXml, xmlDirty, type Doc, type Saved } from "./document";

/** Edits of the same thing within this time (ms) while typing share one undo step. */
export const TYPING_MS = 800;

/** The last typed edit: what it changed (`changeSignature`) and when (ms, performance.now). */
export interface LastEdit {
  sig: string;
  t: number;
}

/**
 * One recipe edit on the history: a new undo step, or folded into the last one when it is typing
 * that changes the same thing within TYPING_MS, or when it comes before `foldUntil` (the file name
 * a form sets right after an upload). `last` is the typing clock after this edit.
 */
export function editStep(
  h: History<Doc>, next: Recipe, o: { typing: boolean; now: number; last: LastEdit | null; foldUntil: number },
): { hist: History<Doc>; last: LastEdit | null } {
  if (next === h.present.recipe) return { hist: h, last: o.last };
  const fold = o.now < o.foldUntil && h.past.length > 0;
  const sig = o.typing ? changeSignature(h.present.recipe, next) : null;
  const same = fold || (sig !== null && o.last?.sig === sig && o.now - o.last.t < TYPING_MS && h.past.length > 0);
  return { hist: change(h, withRecipe(h.present, next), same), last: sig !== null ? { sig, t: o.now } : null };
}

/** The XML editor's text becomes the document's: one undo step per pause in typing. `lastT`: the
 * previous typed change (0: none); returns the clock after this change. */
export function xmlStep(h: History<Doc>, text: string | null, o: { typing: boolean; now: number; lastT: number }) {
  const same = o.typing && o.now - o.lastT < TYPING_MS;
  return { hist: change(h, withXml(h.present, text), same), lastT: o.typing ? o.now : 0 };
}

export function useDocument() {
  const [hist, setHist] = useState<History<Doc>>(() => newDocument(emptyRecipe(), null));
  const [saved, setSaved] = useState<Saved>(() => savedOf({ recipe: emptyRecipe(), xml: null }));
  const [graphName, setGraphName] = useState<string | null>(null);
  const lastEdit = useRef<LastEdit | null>(null);
  // The file name a form sets right after an upload joins the upload's undo step (until this time).
  const foldNext = useRef(0);
  const lastXmlEdit = useRef(0);

  const edit = useCallback(
    (fn: (r: Recipe) => Recipe, typing = false) =>
      setHist((h) => {
        const r = editStep(h, fn(h.present.recipe), { typing, now: performance.now(), last: lastEdit.current, foldUntil: foldNext.current });
        foldNext.current = 0;
        lastEdit.current = r.last;
        return r.hist;
      }),
    [],
  );
  const typingEdit = useCallback((fn: (r: Recipe) => Recipe) => edit(fn, true), [edit]);
  const setXmlDraft = useCallback((text: string | null, typing = false) => {
    setHist((h) => {
      const r = xmlStep(h, text, { typing, now: performance.now(), lastT: lastXmlEdit.current });
      lastXmlEdit.current = r.lastT;
      return r.hist;
    });
  }, []);
  /** Changes within `ms` from now join the current undo step (the upload's file name). */
  const foldNextFor = useCallback((ms: number) => (foldNext.current = performance.now() + ms), []);
  /** A document (re)loaded from the store: a fresh history, saved as it is. */
  const load = useCallback((recipe: Recipe, name: string | null, xml: string | null) => {
    setHist(newDocument(recipe, xml));
    setSaved(savedOf({ recipe, xml }));
    setGraphName(name);
  }, []);
  /** The document stored under `name`: what is on screen becomes the saved state (history kept). */
  const markSaved = useCallback((recipe: Recipe, xml: string | null, name: string) => {
    setHist((h) => ({ ...h, present: { recipe, xml } }));
    setSaved(savedOf({ recipe, xml }));
    setGraphName(name);
  }, []);
  /** The stored recipe was deleted: the one on screen is a new, unsaved one. */
  const markDeleted = useCallback(() => {
    setGraphName(null);
    setSaved((s) => ({ ...s, recipeJson: "" }));
  }, []);

  const doc = hist.present;
  const dirty = { recipe: recipeDirty(doc, saved), xml: xmlDirty(doc, saved), any: isDirty(doc, saved) };
  return {
    hist, setHist, doc, recipe: doc.recipe, saved, graphName, dirty,
    edit, typingEdit, setXmlDraft, foldNextFor, load, markSaved, markDeleted,
    undo: useCallback(() => setHist(undo<Doc>), []),
    redo: useCallback(() => setHist(redo<Doc>), []),
  };
}

export type DocumentState = ReturnType<typeof useDocument>;
