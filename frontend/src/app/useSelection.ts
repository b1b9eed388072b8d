// The selected nodes of the open recipe: kept to nodes that exist (after delete, undo, open).
import { useEffect, useState } from "react";
import type { Recipe } from "../api/types";

/** `sel` without the ids `recipe` no longer has (the same set when nothing is dropped). */
export function pruneSelection(sel: ReadonlySet<string>, recipe: Recipe): ReadonlySet<string> {
  const ids = new Set(recipe.nodes.map((n) => n.id));
  return [...sel].every((id) => ids.has(id)) ? sel : new Set([...sel].filter((id) => ids.has(id)));
}

/** The one selected node, when exactly one is selected. */
export const singleSelected = (sel: ReadonlySet<string>, recipe: Recipe) =>
  sel.size === 1 ? recipe.nodes.find((n) => sel.has(n.id)) ?? null : null;

export function useSelection(recipe: Recipe) {
  const [selected, setSelected] = useState<Set<string>>(new Set());
  useEffect(() => setSelected((sel) => pruneSelection(sel, recipe) as Set<string>), [recipe]);
  return { selected, setSelected, single: singleSelected(selected, recipe), select: (ids: Iterable<string>) => setSelected(new Set(ids)) };
}
