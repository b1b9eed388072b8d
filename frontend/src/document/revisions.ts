// The recipe's history (#25 Build 2): saved revisions listed newest first, and what one of them
// would change in the open recipe, in one line.
import type { Recipe } from "../api/types";

export interface RevisionRow {
  revision: number;
  /** Epoch seconds, as the server stores it. */
  time: number;
  user?: string | null;
}

/** Newest first (the server already answers so; a list from elsewhere is sorted the same). */
export const newestFirst = <T extends { revision: number }>(rows: readonly T[]): T[] => [...rows].sort((a, b) => b.revision - a.revision);

/** A revision's save time in the browser's local time zone, e.g. "25/11/2026, 23:14:05". */
export const whenOf = (time: number, locale?: string): string => new Date(time * 1000).toLocaleString(locale);

/** Who saved it: the token's name, or "—" when the server runs without authentication. */
export const whoOf = (user: string | null | undefined): string => (user ? user : "—");

const nodeKey = (r: Recipe) => new Map(r.nodes.map((n) => [n.id, JSON.stringify({ type: n.type, params: n.params })]));
const edgeKeys = (r: Recipe) => new Set(r.edges.map((e) => `${e.from}>${e.to}`));
/** `text` cut to `max` characters at a word, with "…" when cut. */
export function clip(text: string, max: number): string {
  const t = text.replace(/\s+/g, " ").trim();
  if (t.length <= max) return t;
  const cut = t.slice(0, max - 1);
  const sp = cut.lastIndexOf(" ");
  return `${(sp > max / 2 ? cut.slice(0, sp) : cut).replace(/[\s,.;:]+$/, "")}…`;
}
const plural = (n: number, one: string, many = `${one}s`) => `${n} ${n === 1 ? one : many}`;

/**
 * One line saying what revision `rev` is and how it differs from `current` (what is on screen):
 * the nodes with other settings, added or removed, then its node/edge count and description (cut).
 * E.g. "settings of layers differ (vs. the open recipe) · 7 nodes · 6 edges · “cross section demo”".
 */
export function revisionSummary(rev: Recipe, current: Recipe): string {
  const head = [plural(rev.nodes.length, "node"), plural(rev.edges.length, "edge")];
  if (rev.description) head.push(`“${clip(rev.description, 80)}”`);
  const a = nodeKey(rev);
  const b = nodeKey(current);
  const only = [...a.keys()].filter((id) => !b.has(id));
  const gone = [...b.keys()].filter((id) => !a.has(id));
  const changed = [...a.keys()].filter((id) => b.has(id) && a.get(id) !== b.get(id));
  const ea = edgeKeys(rev);
  const eb = edgeKeys(current);
  const edgesDiffer = ea.size !== eb.size || [...ea].some((e) => !eb.has(e));
  const diffs: string[] = [];
  if (changed.length) diffs.push(`settings of ${changed.join(", ")} differ`);
  if (only.length) diffs.push(`has ${only.join(", ")} (not in the open recipe)`);
  if (gone.length) diffs.push(`lacks ${gone.join(", ")}`);
  if (edgesDiffer) diffs.push("connections differ");
  if (!diffs.length && (rev.description ?? "") !== (current.description ?? "")) diffs.push("description differs");
  const lead = diffs.length ? `${diffs.join("; ")} (vs. the open recipe)` : "same graph as the open recipe";
  return `${lead} · ${head.join(" · ")}`;
}
