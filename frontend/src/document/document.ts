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
