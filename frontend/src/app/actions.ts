// The editor's actions on the recipe that need no React: where a node added from the palette goes
// and what it is wired to, what a new mask from layer N carries over, and where a picked problem
// leads (its node, layer and tab).
import type { NodeSpec, Recipe, RecipeEdge } from "../api/types";
import { carryOver, matchByOverlap, oldRegionsForCarry, type CarryPlan } from "../graph/carry";
import { addNode, autoWire, freeSpot, positionsOf, setNodeParams, type Catalog, type XY } from "../graph/recipe";
import { governingMask, sectionKey, type MaskParams } from "../mask/edits";
import type { NewMaskEvent } from "../mask/MaskView";
import type { Tab } from "./tabs";

/** How far right of its anchor a node added without a drop point goes (flow units). */
export const ADD_STEP = 230;

/**
 * A node of `spec` added at `at`, else right of the selected node (else of the rightmost one);
 * either way on free space. With exactly one node selected it is wired from that node's first
 * compatible output, like ComfyUI/Grasshopper. A new node starts with empty params: the engine
 * applies the schema defaults and the form shows them as placeholders.
 */
export function placeNew(cat: Catalog, r: Recipe, selected: ReadonlySet<string>, spec: NodeSpec, at?: XY): { recipe: Recipe; id: string; edge: RecipeEdge | null } {
  const all = positionsOf(r);
  const anchorId = [...selected].find((id) => all[id]);
  let want = at;
  if (!want) {
    const right = anchorId ?? Object.keys(all).sort((a, b) => all[b][0] - all[a][0])[0];
    want = right ? [all[right][0] + ADD_STEP, all[right][1]] : [0, 0];
  }
  const { recipe, id } = addNode(r, spec, freeSpot(Object.values(all), want));
  const wired = selected.size === 1 && anchorId ? autoWire(cat, recipe, anchorId, id) : { recipe, edge: null };
  return { recipe: wired.recipe, id, edge: wired.edge };
}

/** A new mask from layer N: each continuing section's settings and XML values carried over from
 * the mask that governed the layer before; `text` is what the user confirms. Null: no new mask. */
export function newMaskPlan(e: NewMaskEvent, r: Recipe, xml: string | null): { plan: CarryPlan; text: string; summary: string } | null {
  const masks = e.params.masks ?? [];
  const made = masks.find((m) => m.id === e.newId);
  if (!made) return null;
  const before: MaskParams = { ...e.params, masks: masks.filter((m) => m.id !== e.newId) };
  const old = governingMask(before, e.layer);
  const oldKeys = old ? old.sections.map((x) => sectionKey(old.id, x.id)) : [];
  const oldRegions = old ? oldRegionsForCarry(old.id, old.sections, e.regions) : [];
  const next = made.sections.map((x) => ({ key: sectionKey(made.id, x.id), polygon: { exterior: x.curve, holes: [] } }));
  const above = masks.filter((m) => m.from_layer > e.layer).map((m) => m.from_layer);
  const plan = carryOver(setNodeParams(r, e.maskNode, e.params), {
    matches: matchByOverlap(oldRegions, next), oldKeys, oldRegions: oldRegions.map((x) => x.key), from: e.layer,
    to: above.length ? Math.min(...above) : null, xml,
  });
  const text = [
    `New mask ${made.id} from layer ${e.layer}.`,
    plan.carried.length ? `Carried over:\n  ${plan.carried.join("\n  ")}` : "Nothing to carry over.",
    plan.lost.length ? `Could NOT carry:\n  ${plan.lost.join("\n  ")}` : "Everything carried over.",
  ].join("\n\n");
  const summary = `mask ${made.id} from layer ${e.layer}: ${plan.carried.length} setting(s) carried${plan.lost.length ? `, ${plan.lost.length} not` : ""}`;
  return { plan, text, summary };
}

/** Where a picked problem leads: its node selected (when the recipe has it), its layer shown, and
 * the tab: the mask canvas for a layer (or a section, `sectionOnMask`: a run problem's section is
 * picked on the canvas), else the graph for a node. */
export function problemTarget(
  pr: { node?: string | null; layer?: number | null; section?: string | null }, r: Recipe, sectionOnMask = true,
): { select: string | null; layer: number | null; tab: Tab | null } {
  const select = pr.node && r.nodes.some((n) => n.id === pr.node) ? pr.node : null;
  const layer = pr.layer ?? null;
  const tab: Tab | null = layer != null || (sectionOnMask && pr.section) ? "mask" : pr.node ? "graph" : null;
  return { select, layer, tab };
}
