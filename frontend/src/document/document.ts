// One document per open recipe: the recipe and its parameter XML as the user sees them, in one
// history (undo/redo restore both together), one dirty state and one run request.
import type { Recipe } from "../api/types";
import { amend, commit, engineView, history, type History } from "../graph/recipe";

/** What is on screen: the recipe and the parameter XML text the user has (null: none yet). */
export interface Doc {
  recipe: Recipe;
  xml: string | null;
}

/** What was last saved (or opened): the recipe as JSON and the stored XML. */
export interface Saved {
  recipeJson: string;
  xml: string | null;
}

export const newDocument = (recipe: Recipe, xml: string | null): History<Doc> => history({ recipe, xml });
export const savedOf = (d: Doc): Saved => ({ recipeJson: JSON.stringify(d.recipe), xml: d.xml });

export const recipeDirty = (d: Doc, s: Saved) => JSON.stringify(d.recipe) !== s.recipeJson;
export const xmlDirty = (d: Doc, s: Saved) => d.xml !== null && d.xml !== s.xml;
export const isDirty = (d: Doc, s: Saved) => recipeDirty(d, s) || xmlDirty(d, s);

/** One change of the document: a new undo step, or (typing) folded into the last one. */
export function change(h: History<Doc>, next: Doc, typing = false): History<Doc> {
  if (next === h.present || (next.recipe === h.present.recipe && next.xml === h.present.xml)) return h;
  // an edit that leaves the same document (a field set to its value, e.g. a file name after an
  // upload) is no undo step: one undo must always change something
  if (next.xml === h.present.xml && JSON.stringify(next.recipe) === JSON.stringify(h.present.recipe)) return h;
  return typing && h.past.length > 0 ? amend(h, next) : commit(h, next);
}

export const withRecipe = (d: Doc, recipe: Recipe): Doc => (recipe === d.recipe ? d : { ...d, recipe });
export const withXml = (d: Doc, xml: string | null): Doc => (xml === d.xml ? d : { ...d, xml });

/**
 * The run request for exactly what is on screen: the recipe as displayed (unsaved edits included)
 * and the XML text the user has, saved or not, named or not. A saved graph lends its files.
 * Without XML of the user's own the server uses the graph's stored XML or its template.
 */
export function runRequest(d: Doc, graph: string | null) {
  return { graph, recipe: engineView(d.recipe), accept_preflight: false, ...(d.xml !== null ? { params_xml: d.xml } : {}) };
}

// ---- uploads as versioned content (#25 fault 5) ----------------------------------------------------
// The recipe pins each uploaded file to the sha256 of the content it runs with (`recipe.files`): a
// same-name upload the user confirms moves the pin (one undo step, the recipe unsaved), undo moves
// it back, and the run uses exactly the pinned content (the program header lists its sha256).

export type Pins = Record<string, string>;

/** The document with `name` pinned to content `sha256` (null: unpinned). */
export function withPin(d: Doc, name: string, sha256: string | null): Doc {
  const cur = d.recipe.files ?? {};
  if ((cur[name] ?? null) === sha256) return d;
  const next: Pins = { ...cur };
  if (sha256 === null) delete next[name];
  else next[name] = sha256;
  return withRecipe(d, { ...d.recipe, files: Object.keys(next).length ? next : undefined });
}

/** A recipe just opened: every stored file it does not pin yet pinned to what its name holds now
 * (what the recipe ran with until now), so that replacing the file later is one undoable change. */
export function pinStored(r: Recipe, stored: readonly { name: string; sha256?: string | null }[]): Recipe {
  const add = stored.filter((f) => f.sha256 && !(r.files && f.name in r.files));
  if (!add.length) return r;
  return { ...r, files: { ...(r.files ?? {}), ...Object.fromEntries(add.map((f) => [f.name, f.sha256!])) } };
}

/** "Keep both": the first free name `stem-2.ext`, `stem-3.ext`, … beside the taken ones. */
export function freeName(name: string, taken: readonly string[]): string {
  const dot = name.lastIndexOf(".");
  const [stem, ext] = dot > 0 ? [name.slice(0, dot), name.slice(dot)] : [name, ""];
  for (let i = 2; ; i++) {
    const n = `${stem}-${i}${ext}`;
    if (!taken.includes(n)) return n;
  }
}

/** sha256 (hex) of a file's bytes, as the server computes it. */
export async function sha256Hex(b: Blob): Promise<string> {
  const d = new Uint8Array(await crypto.subtle.digest("SHA-256", await b.arrayBuffer()));
  return [...d].map((x) => x.toString(16).padStart(2, "0")).join("");
}
