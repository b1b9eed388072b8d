// Every unsaved change is kept in the browser until saved or discarded (graph/drafts.ts), and a
// stored draft is offered back when its recipe opens. Only a draft this page wrote is removed when
// its edits are undone (another tab's or a crashed session's draft stays until the user answers).
import { useCallback, useEffect, useRef, useState } from "react";
import type { Recipe } from "../api/types";
import { asTab, type Tab } from "../app/tabs";
import { clearDraft, draftDiffers, parsePlace, readDraft, writeDraft, type Draft } from "../graph/drafts";
import { change, type Doc } from "./document";
import type { DocumentState } from "./useDocument";

/** What to do with the stored draft of the recipe on screen: nothing while an offer waits for the
 * user, write the unsaved state, or clear the draft this page wrote once nothing is unsaved. */
export function draftAction(o: { offer: boolean; dirty: boolean; key: string; wrote: string | null }): "wait" | "write" | "clear" | "none" {
  if (o.offer) return "wait";
  if (o.dirty) return "write";
  return o.wrote === o.key ? "clear" : "none";
}

/** The stored draft to offer when `doc` opens under `name`: only one that differs from it. */
export function draftToOffer(store: Storage, name: string | null, doc: Doc): Draft | null {
  const d = readDraft(store, name);
  return d && draftDiffers(d, doc.recipe, doc.xml) ? d : null;
}

export function useDraftOffer(d: DocumentState, tab: Tab, setTab: (t: Tab) => void, message: (t: string) => void) {
  const [offer, setOffer] = useState<Draft | null>(() => (parsePlace(location.search).graph ? null : readDraft(localStorage, null)));
  const wroteDraft = useRef<string | null>(null);
  const { graphName, recipe, doc } = d;
  const xmlDraft = d.dirty.xml ? doc.xml : null;
  const dirty = d.dirty.any;
  useEffect(() => {
    const key = graphName ?? "";
    const act = draftAction({ offer: !!offer, dirty, key, wrote: wroteDraft.current });
    if (act === "wait") return;
    if (act !== "write") {
      if (act === "clear") clearDraft(localStorage, graphName);
      wroteDraft.current = null;
      return;
    }
    const problem = writeDraft(localStorage, graphName, { recipe, xml: xmlDraft, tab, savedAt: Date.now() });
    wroteDraft.current = key;
    if (problem) message(problem);
  }, [dirty, recipe, xmlDraft, tab, graphName, offer, message]);

  const { setHist } = d;
  const restore = useCallback(() => {
    if (!offer) return;
    // One undo step back to the saved recipe.
    setHist((h) => change(h, { recipe: offer.recipe, xml: offer.xml ?? h.present.xml }));
    setTab(asTab(offer.tab));
    setOffer(null);
    message("restored the unsaved changes");
  }, [offer, setHist, setTab, message]);
  const discard = useCallback(() => {
    clearDraft(localStorage, graphName);
    setOffer(null);
  }, [graphName]);
  /** A recipe was opened: offer its stored draft if it holds something else. */
  const offerFor = useCallback((name: string | null, recipe: Recipe, xml: string | null) => setOffer(draftToOffer(localStorage, name, { recipe, xml })), []);
  return { offer, restore, discard, offerFor };
}
