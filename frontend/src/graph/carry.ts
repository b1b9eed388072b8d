/**
 * "New mask from layer N" carries over what the user set for the sections whose region continues:
 * each new section is matched to the old section whose region on layer N it overlaps most; the
 * per-section entries of every node (`sections[key]`: strategy, zone lengths and split points;
 * `guides[key]`) and the XML values of the layers the new mask governs move to the new key. What
 * has no continuation is listed, so the user sees it before confirming.
 */
import type { Recipe } from "../api/types";
import { bbox, pointInPolygon, type PolygonJson } from "../mask/geom";

export interface Region {
  key: string;
  polygon: PolygonJson;
}

/** Area of `a` ∩ `b` (mm²), sampled on an n×n grid over `a`'s bounding box. */
export function overlapArea(a: PolygonJson, b: PolygonJson, n = 64): number {
  const box = bbox(a.exterior);
  const bb = bbox(b.exterior);
  if (!box || !bb || box.maxX < bb.minX || bb.maxX < box.minX || box.maxY < bb.minY || bb.maxY < box.minY) return 0;
  const dx = (box.maxX - box.minX) / n, dy = (box.maxY - box.minY) / n;
  let hits = 0;
  for (let i = 0; i < n; i++)
    for (let j = 0; j < n; j++) {
      const p = [box.minX + (i + 0.5) * dx, box.minY + (j + 0.5) * dy];
      if (pointInPolygon(p, a) && pointInPolygon(p, b)) hits++;
    }
  return hits * dx * dy;
}

/** For each new section, the old section it overlaps most on the layer (none when no overlap). */
export function matchByOverlap(old: readonly Region[], next: readonly Region[]): Map<string, string> {
  const out = new Map<string, string>();
  for (const n of next) {
    let best: string | null = null, bestArea = 0;
    for (const o of old) {
      const a = overlapArea(o.polygon, n.polygon);
      if (a > bestArea) [best, bestArea] = [o.key, a];
    }
    if (best) out.set(n.key, best);
  }
  return out;
}

/**
 * The old mask's section regions on the layer for matching: the preview's regions where the layer
 * has them, else the section's own curve. After a run failed on that layer (a curve yielding no
 * region or several) the preview has no regions at all, yet the new mask starts there: its
 * sections still overlap the old curves, so they carry over like in the normal case.
 */
export function oldRegionsForCarry(
  maskId: string, sections: readonly { id: string; curve: number[][] }[], regions: readonly Region[],
): Region[] {
  return sections.map((s) => {
    const key = `${maskId}/${s.id}`;
    return regions.find((r) => r.key === key) ?? { key, polygon: { exterior: s.curve, holes: [] } };
  });
}

export interface CarryPlan {
  recipe: Recipe;
  xml: string | null;
  /** What moved, e.g. "strategy · sections: bs1/B → bs2/B", "XML: bs1/A → bs2/A on 4 layer(s)". */
  carried: string[];
  /** What could not move, with the reason. */
  lost: string[];
}

const esc = (s: string) => s.replace(/[.*+?^${}()|[\]\\/]/g, "\\$&");

/**
 * Apply the matches (`new key → old key`) to the recipe's keyed per-section params and to the XML
 * draft for layers `from` ≤ index < `to` (`to` null: all above). `oldKeys` are the sections of the
 * mask that governed layer `from`, `oldRegions` their regions there.
 */
export function carryOver(
  r: Recipe, o: { matches: ReadonlyMap<string, string>; oldKeys: readonly string[]; oldRegions: readonly string[]; from: number; to: number | null; xml: string | null },
): CarryPlan {
  const carried: string[] = [];
  const lost: string[] = [];
  const pairs = [...o.matches].map(([nk, ok]) => [ok, nk] as const);
  const nodes = r.nodes.map((n) => {
    let params = n.params;
    for (const field of ["sections", "guides"] as const) {
      const map = params[field] as Record<string, unknown> | undefined;
      if (!map || typeof map !== "object" || Array.isArray(map)) continue;
      const next = { ...map };
      for (const [ok, nk] of pairs)
        if (ok in map && !(nk in map)) {
          next[nk] = structuredClone(map[ok]);
          carried.push(`${n.id} · ${field}: ${ok} → ${nk}`);
        }
      if (Object.keys(next).length !== Object.keys(map).length) params = { ...params, [field]: next };
    }
    return params === n.params ? n : { ...n, params };
  });
  let xml = o.xml;
  if (xml !== null)
    for (const [ok, nk] of pairs) {
      let layers = 0;
      xml = xml.replace(/<layer\b[^>]*\bindex="(\d+)"[^>]*>[\s\S]*?<\/layer>/g, (block, idx: string) => {
        const k = Number(idx);
        if (k < o.from || (o.to !== null && k >= o.to)) return block;
        const re = new RegExp(`(<section\\b[^>]*\\bid=")${esc(ok)}(")`);
        if (!re.test(block) || new RegExp(`<section\\b[^>]*\\bid="${esc(nk)}"`).test(block)) return block;
        layers++;
        return block.replace(re, `$1${nk}$2`);
      });
      if (layers) carried.push(`XML values: ${ok} → ${nk} on ${layers} layer(s)`);
    }
  const matchedOld = new Set(o.matches.values());
  for (const k of o.oldKeys) {
    if (!o.oldRegions.includes(k)) lost.push(`${k}: no region on layer ${o.from}`);
    else if (!matchedOld.has(k)) lost.push(`${k}: no new section overlaps its region on layer ${o.from}`);
  }
  return { recipe: nodes.some((n, i) => n !== r.nodes[i]) ? { ...r, nodes } : r, xml, carried, lost };
}
