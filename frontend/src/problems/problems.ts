/**
 * Problems of the open recipe, from the last run (its warnings and error) and from a refused
 * request (a 422 naming node/field): one list for the node badges, the problems panel and the
 * toolbar count.
 */
import type { RunError, RunEvent } from "../api/types";

export interface Problem {
  key: string;
  severity: "error" | "warning";
  message: string;
  node: string | null;
  layer: number | null;
  section: string | null;
  field: string | null;
}

export function collectProblems(warnings: readonly RunEvent[], errors: readonly (RunError | null | undefined)[]): Problem[] {
  const out: Problem[] = [];
  const seen = new Set<string>();
  const push = (p: Omit<Problem, "key">) => {
    const key = `${p.severity}|${p.node}|${p.layer}|${p.section}|${p.message}`;
    if (seen.has(key)) return;
    seen.add(key);
    out.push({ ...p, key });
  };
  for (const e of errors)
    if (e)
      push({
        severity: "error", message: e.message, node: e.node ?? null, layer: e.layer ?? null, section: e.section ?? null,
        field: typeof (e as unknown as Record<string, unknown>).field === "string" ? ((e as unknown as Record<string, unknown>).field as string) : null,
      });
  for (const w of warnings)
    push({ severity: "warning", message: w.message ?? "warning", node: w.node ?? null, layer: w.layer ?? null, section: w.section ?? null, field: null });
  return out;
}

/** Per node: how many errors and warnings, and the messages for the badge's tooltip. */
export function problemsByNode(ps: readonly Problem[]): Map<string, { errors: number; warnings: number; text: string }> {
  const m = new Map<string, { errors: number; warnings: number; text: string }>();
  for (const p of ps) {
    if (!p.node) continue;
    const cur = m.get(p.node) ?? { errors: 0, warnings: 0, text: "" };
    if (p.severity === "error") cur.errors++;
    else cur.warnings++;
    const line = `${p.severity}${p.layer != null ? ` · layer ${p.layer}` : ""}${p.section ? ` · ${p.section}` : ""}: ${p.message}`;
    cur.text = cur.text ? `${cur.text}\n${line}` : line;
    m.set(p.node, cur);
  }
  return m;
}

/**
 * The problems that still describe what is on screen: those of the run (or refused run request)
 * made with the recipe and XML `ran`, as long as the document is still `now`. Once the graph or
 * the XML changes they are stale (a fixed field keeps no error badge); undoing back brings them
 * back. `ran` null: no run yet, nothing to compare.
 */
export function currentProblems(ps: Problem[], ran: { recipe: string; xml: string | null } | null, now: { recipe: string; xml: string | null }): Problem[] {
  return ran && (ran.recipe !== now.recipe || ran.xml !== now.xml) ? [] : ps;
}
