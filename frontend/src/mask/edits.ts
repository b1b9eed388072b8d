/**
 * Edits the mask canvas makes, as pure functions on the contract's params:
 *   mask:     {"masks": [{"id", "from_layer", "sections": [{"id", "curve": [[x,y],...]}]}]}
 *   guide:    {"guides": {"<mask>/<section>": [[x,y],...]}}
 *   strategy: {"default": {...}, "sections": {"<key>": {"pattern": ...}}}
 *   zone:     {"default": {...}, "sections": {"<key>": {"start_length", "end_length", "split_points"}}}
 * Lengths in mm, points in layer mm.
 */
import { ancestors } from "../graph/recipe";
import type { Recipe, RecipeNode } from "../api/types";

export interface MaskSection {
  id: string;
  curve: number[][];
  [k: string]: unknown;
}
export interface Mask {
  id: string;
  from_layer: number;
  sections: MaskSection[];
  [k: string]: unknown;
}
export interface MaskParams {
  masks?: Mask[];
  [k: string]: unknown;
}

export const sectionKey = (maskId: string, sectionId: string) => `${maskId}/${sectionId}`;

export function splitKey(key: string): { mask: string; section: string } {
  const i = key.indexOf("/");
  return { mask: key.slice(0, i), section: key.slice(i + 1) };
}

/** Masks sorted by their first layer. */
export function sortedMasks(p: MaskParams): Mask[] {
  return [...(p.masks ?? [])].sort((a, b) => a.from_layer - b.from_layer);
}

/** Layer range [from, to] (inclusive) each mask governs; `to` is null while the layer count is unknown. */
export function maskRanges(p: MaskParams, layerCount: number | null): { id: string; from: number; to: number | null }[] {
  const ms = sortedMasks(p);
  return ms.map((m, i) => ({
    id: m.id,
    from: m.from_layer,
    to: i + 1 < ms.length ? ms[i + 1].from_layer - 1 : layerCount !== null ? layerCount - 1 : null,
  }));
}

/** The mask governing layer `index` (the last one starting at or below it), if any. */
export function governingMask(p: MaskParams, index: number): Mask | undefined {
  let found: Mask | undefined;
  for (const m of sortedMasks(p)) if (m.from_layer <= index) found = m;
  return found;
}

function nextId(taken: Set<string>, stem: string, letters: boolean): string {
  if (letters) {
    for (let i = 0; ; i++) {
      let s = "", n = i;
      do {
        s = String.fromCharCode(65 + (n % 26)) + s;
        n = Math.floor(n / 26) - 1;
      } while (n >= 0);
      if (!taken.has(s)) return s;
    }
  }
  for (let k = 1; ; k++) if (!taken.has(`${stem}${k}`)) return `${stem}${k}`;
}

/** Add a closed curve as a new section to the mask governing `layer` (creating mask `bs1` from
 * layer 0 when there is none). Returns the new params and the section key. */
export function addSection(p: MaskParams, layer: number, curve: number[][]): { params: MaskParams; key: string } {
  const masks = [...(p.masks ?? [])];
  let m = governingMask(p, layer);
  if (!m) {
    m = { id: nextId(new Set(masks.map((x) => x.id)), "bs", false), from_layer: 0, sections: [] };
    masks.push(m);
  }
  const sid = nextId(new Set(m.sections.map((s) => s.id)), "", true);
  const target = m;
  const updated: Mask = { ...target, sections: [...target.sections, { id: sid, curve }] };
  return { params: { ...p, masks: masks.map((x) => (x === target ? updated : x)) }, key: sectionKey(target.id, sid) };
}

export function setCurve(p: MaskParams, key: string, curve: number[][]): MaskParams {
  const { mask, section } = splitKey(key);
  return {
    ...p,
    masks: (p.masks ?? []).map((m) =>
      m.id !== mask ? m : { ...m, sections: m.sections.map((s) => (s.id === section ? { ...s, curve } : s)) },
    ),
  };
}

/** Remove a section; a mask left without sections is removed too (a mask needs at least one). */
export function removeSection(p: MaskParams, key: string): MaskParams {
  const { mask, section } = splitKey(key);
  return {
    ...p,
    masks: (p.masks ?? [])
      .map((m) => (m.id !== mask ? m : { ...m, sections: m.sections.filter((s) => s.id !== section) }))
      .filter((m) => m.sections.length > 0),
  };
}

export function findSection(p: MaskParams, key: string): MaskSection | undefined {
  const { mask, section } = splitKey(key);
  return p.masks?.find((m) => m.id === mask)?.sections.find((s) => s.id === section);
}

/**
 * A new mask starting at `layer`, prefilled with the sections of the mask that governed it (the
 * "new mask from this layer" action after a run failed there). Section ids are kept so the user
 * only redraws what changed. Fails if a mask already starts at that layer.
 */
export function newMaskFromLayer(p: MaskParams, layer: number): { params: MaskParams; id: string } | { error: string } {
  if ((p.masks ?? []).some((m) => m.from_layer === layer)) return { error: `a mask already starts at layer ${layer}` };
  const prev = governingMask(p, layer);
  const id = nextId(new Set((p.masks ?? []).map((m) => m.id)), "bs", false);
  const sections = prev ? prev.sections.map((s) => structuredClone(s)) : [];
  return { params: { ...p, masks: [...(p.masks ?? []), { id, from_layer: layer, sections }] }, id };
}

export function removeMask(p: MaskParams, id: string): MaskParams {
  return { ...p, masks: (p.masks ?? []).filter((m) => m.id !== id) };
}

export function setMaskFrom(p: MaskParams, id: string, from: number): MaskParams {
  return { ...p, masks: (p.masks ?? []).map((m) => (m.id === id ? { ...m, from_layer: Math.max(0, Math.round(from)) } : m)) };
}

// ---- per-section params of guide / strategy / zone ------------------------------------------------

export interface GuideParams {
  guides?: Record<string, number[][]>;
  [k: string]: unknown;
}

export function setGuide(p: GuideParams, key: string, guide: number[][] | null): GuideParams {
  const guides = { ...(p.guides ?? {}) };
  if (guide) guides[key] = guide;
  else delete guides[key];
  return { ...p, guides };
}

export interface KeyedParams {
  default?: Record<string, unknown>;
  sections?: Record<string, Record<string, unknown>>;
  [k: string]: unknown;
}

/**
 * Merge `patch` into `sections[key]`; keys set to undefined are removed; an empty entry is dropped.
 * A section entry replaces the default as a whole (zone/strategy params), so a new entry starts
 * as a copy of the default.
 */
export function patchSection(p: KeyedParams, key: string, patch: Record<string, unknown>): KeyedParams {
  const entry = { ...(p.sections?.[key] ?? structuredClone(p.default ?? {})), ...patch };
  for (const k of Object.keys(entry)) if (entry[k] === undefined) delete entry[k];
  const sections = { ...(p.sections ?? {}) };
  if (Object.keys(entry).length) sections[key] = entry;
  else delete sections[key];
  return { ...p, sections };
}

/** The effective value of `name` for a section: its own entry, else the default. */
export function sectionValue(p: KeyedParams, key: string, name: string): unknown {
  return p.sections?.[key]?.[name] ?? p.default?.[name];
}

/** Drop per-section entries of a removed section from guide/strategy/zone params. */
export function forgetKey<T extends { sections?: Record<string, unknown>; guides?: Record<string, unknown> }>(p: T, key: string): T {
  const out = { ...p };
  if (p.sections && key in p.sections) {
    const s = { ...p.sections };
    delete s[key];
    out.sections = s;
  }
  if (p.guides && key in p.guides) {
    const g = { ...p.guides };
    delete g[key];
    out.guides = g;
  }
  return out;
}

// ---- which nodes the canvas edits --------------------------------------------------------------------

export interface CanvasNodes {
  preview?: RecipeNode;
  slice?: RecipeNode;
  mask?: RecipeNode;
  guide?: RecipeNode;
  strategy?: RecipeNode;
  zone?: RecipeNode;
}

const PREVIEW_ORDER = ["zone", "strategy", "guide", "mask"];

/**
 * The nodes the canvas works on for a preview node: the node itself and the nearest upstream
 * node of each type (mask, guide, strategy, zone, slice). With no choice, the first of
 * zone → strategy → guide → mask present in the recipe is used (none: no preview node; the
 * caller then picks the most downstream node with planar output).
 */
export function canvasNodes(r: Recipe, previewId?: string): CanvasNodes {
  let preview = previewId ? r.nodes.find((n) => n.id === previewId) : undefined;
  if (!preview) {
    for (const t of PREVIEW_ORDER) {
      preview = r.nodes.find((n) => n.type === t);
      if (preview) break;
    }
  }
  if (!preview) return {};
  const up = ancestors(r, preview.id);
  const pick = (type: string) =>
    preview!.type === type ? preview : r.nodes.find((n) => n.type === type && up.has(n.id));
  return { preview, slice: pick("slice"), mask: pick("mask"), guide: pick("guide"), strategy: pick("strategy"), zone: pick("zone") };
}
