/**
 * Unsaved work that survives a reload: one local draft per recipe (the recipe as edited, the
 * parameter-XML draft and the open tab) in the browser's storage, and the URL that names the open
 * recipe and tab (`/?graph=NAME&tab=mask`).
 */
import type { Recipe } from "../api/types";

export interface Draft {
  recipe: Recipe;
  /** The parameter XML draft, or null when the saved file is unchanged. */
  xml: string | null;
  tab: string;
  /** When the draft was written (ms since the epoch). */
  savedAt: number;
}

const PREFIX = "waamflow:draft:";

/** Storage key of a recipe's draft; the unsaved new recipe has its own. */
export const draftKey = (graph: string | null) => PREFIX + (graph ?? "");

export function writeDraft(store: Storage, graph: string | null, d: Draft): string | null {
  try {
    store.setItem(draftKey(graph), JSON.stringify(d));
    return null;
  } catch (e) {
    return `the local draft could not be kept (${(e as Error).message}): save to keep your changes`;
  }
}

/** The stored draft of `graph`, or null (none, or not a draft: e.g. written by another version). */
export function readDraft(store: Storage, graph: string | null): Draft | null {
  const raw = store.getItem(draftKey(graph));
  if (!raw) return null;
  try {
    const d = JSON.parse(raw) as Partial<Draft>;
    const r = d.recipe as Partial<Recipe> | undefined;
    if (!r || !Array.isArray(r.nodes) || !Array.isArray(r.edges) || typeof d.savedAt !== "number") return null;
    return { recipe: d.recipe as Recipe, xml: typeof d.xml === "string" ? d.xml : null, tab: typeof d.tab === "string" ? d.tab : "graph", savedAt: d.savedAt };
  } catch {
    return null;
  }
}

export function clearDraft(store: Storage, graph: string | null) {
  store.removeItem(draftKey(graph));
}

/** Whether a stored draft holds something the saved state does not. */
export function draftDiffers(d: Draft, saved: Recipe, savedXml: string | null): boolean {
  return JSON.stringify(d.recipe) !== JSON.stringify(saved) || (d.xml !== null && d.xml !== savedXml);
}

export interface Place {
  graph: string | null;
  tab: string | null;
}

export function parsePlace(search: string): Place {
  const q = new URLSearchParams(search);
  return { graph: q.get("graph") || null, tab: q.get("tab") || null };
}

/** The query string for a place (`?graph=NAME&tab=mask`; the graph tab is the default). */
export function placeSearch(p: Place): string {
  const q = new URLSearchParams();
  if (p.graph) q.set("graph", p.graph);
  if (p.tab && p.tab !== "graph") q.set("tab", p.tab);
  const s = q.toString();
  return s ? `?${s}` : "";
}
