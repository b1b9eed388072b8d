/**
 * Graph logic on the recipe (the contract's `waamflow/1` JSON), independent of React and of the
 * node-editor library: connection validation (the one place), cycles, unique ids, copy/paste,
 * node positions and an automatic layout for recipes saved without positions.
 *
 * The recipe stays the single source of truth; the editor's nodes/edges are derived from it.
 */
import type { NodeSpec, PortSpec, Recipe, RecipeEdge, RecipeNode } from "../api/types";

export type XY = [number, number];

export const NODE_ID_RE = /^[A-Za-z][A-Za-z0-9_-]{0,63}$/;

export function endpoint(text: string): { node: string; port: string } {
  const i = text.indexOf(".");
  return { node: text.slice(0, i), port: text.slice(i + 1) };
}

export const edgeId = (e: RecipeEdge) => `${e.from}->${e.to}`;

export function emptyRecipe(name = "untitled"): Recipe {
  return { format: "waamflow/1", name, description: "", inputs: {}, nodes: [], edges: [] };
}

export type Catalog = Map<string, NodeSpec>;

export function catalogMap(specs: readonly NodeSpec[]): Catalog {
  return new Map(specs.map((s) => [s.type, s]));
}

function outPort(cat: Catalog, r: Recipe, nodeId: string, port: string): PortSpec | undefined {
  const n = r.nodes.find((x) => x.id === nodeId);
  return n ? cat.get(n.type)?.outputs.find((p) => p.name === port) : undefined;
}

function inPort(cat: Catalog, r: Recipe, nodeId: string, port: string): PortSpec | undefined {
  const n = r.nodes.find((x) => x.id === nodeId);
  return n ? cat.get(n.type)?.inputs.find((p) => p.name === port) : undefined;
}

/** Node ids reachable from `id` along edges (`down`) or against them (`up`), excluding `id`. */
function reachable(r: Recipe, id: string, dir: "down" | "up"): Set<string> {
  const out = new Set<string>();
  const stack = [id];
  while (stack.length) {
    const cur = stack.pop()!;
    for (const e of r.edges) {
      const f = endpoint(e.from).node, t = endpoint(e.to).node;
      const [here, next] = dir === "down" ? [f, t] : [t, f];
      if (here === cur && !out.has(next)) {
        out.add(next);
        stack.push(next);
      }
    }
  }
  return out;
}

/** Node ids downstream of `id` (excluding it). */
export const downstream = (r: Recipe, id: string): Set<string> => reachable(r, id, "down");

/** Node ids upstream of `id` (excluding it). */
export const ancestors = (r: Recipe, id: string): Set<string> => reachable(r, id, "up");

export interface Connection {
  source: string;
  sourceHandle: string | null;
  target: string;
  targetHandle: string | null;
}

/**
 * The one place that decides whether an output may feed an input (mirrors the engine's
 * `check_connection`): both ports exist, same port type, not a self-loop, no cycle.
 * Returns null when valid, else the reason.
 */
export function connectionError(cat: Catalog, r: Recipe, c: Connection): string | null {
  return connectionRefusal(cat, r, c)?.text ?? null;
}

/** Why a connection is refused: the full sentence, and a short form drawn on the refused handle. */
export function connectionRefusal(cat: Catalog, r: Recipe, c: Connection): { text: string; short: string } | null {
  if (!c.sourceHandle || !c.targetHandle) return { text: "connect a port to a port", short: "not a port" };
  if (c.source === c.target) return { text: "a node cannot feed itself", short: "same node" };
  const o = outPort(cat, r, c.source, c.sourceHandle);
  const i = inPort(cat, r, c.target, c.targetHandle);
  if (!o) return { text: `no output port '${c.sourceHandle}' on ${c.source}`, short: "no such port" };
  if (!i) return { text: `no input port '${c.targetHandle}' on ${c.target}`, short: "no such port" };
  if (o.type !== i.type) return { text: `type mismatch: ${o.type} → ${i.type}`, short: `type ${o.type} ≠ ${i.type}` };
  if (downstream(r, c.target).has(c.source)) return { text: "this edge would create a cycle", short: "would create a cycle" };
  return null;
}

export const isValidConnection = (cat: Catalog, r: Recipe, c: Connection) => connectionError(cat, r, c) === null;

/** Add an edge; an input takes one edge, so an existing edge into the same input is replaced. */
export function connect(r: Recipe, c: Connection): Recipe {
  const e: RecipeEdge = { from: `${c.source}.${c.sourceHandle}`, to: `${c.target}.${c.targetHandle}` };
  return { ...r, edges: [...r.edges.filter((x) => x.to !== e.to), e] };
}

/** Remove edges; the same recipe when none of them is there (so a node delete stays one undo step). */
export function removeEdges(r: Recipe, ids: ReadonlySet<string>): Recipe {
  const edges = r.edges.filter((e) => !ids.has(edgeId(e)));
  return edges.length === r.edges.length ? r : { ...r, edges };
}

/** Nominal size of a node on the canvas (flow units), for placement. */
export const NODE_BOX: XY = [200, 120];

/**
 * The free spot nearest to `want` for a node of size `box`: `want` itself when nothing overlaps
 * it, else the first free cell of a grid walked in rings around it (right and down first), so a
 * new node never lands on top of another.
 */
export function freeSpot(taken: readonly XY[], want: XY, box: XY = NODE_BOX, gap = 20): XY {
  const [w, h] = [box[0] + gap, box[1] + gap];
  const free = ([x, y]: XY) => taken.every(([tx, ty]) => Math.abs(tx - x) >= w || Math.abs(ty - y) >= h);
  if (free(want)) return want;
  for (let ring = 1; ring < 50; ring++) {
    const cells: XY[] = [];
    for (let i = -ring; i <= ring; i++)
      for (let j = -ring; j <= ring; j++) if (Math.max(Math.abs(i), Math.abs(j)) === ring) cells.push([want[0] + i * w, want[1] + j * h]);
    // right before left, down before up, near before far
    cells.sort((a, b) => Math.hypot(a[0] - want[0], a[1] - want[1]) - Math.hypot(b[0] - want[0], b[1] - want[1]) || b[0] - a[0] || b[1] - a[1]);
    const hit = cells.find(free);
    if (hit) return hit;
  }
  return [want[0], Math.max(...taken.map((t) => t[1])) + h];
}

/**
 * Wire `from`'s first output that an unconnected input of `to` accepts (same type, no cycle).
 * Returns the recipe unchanged when no port fits.
 */
export function autoWire(cat: Catalog, r: Recipe, from: string, to: string): { recipe: Recipe; edge: RecipeEdge | null } {
  const fs = cat.get(r.nodes.find((n) => n.id === from)?.type ?? "");
  const ts = cat.get(r.nodes.find((n) => n.id === to)?.type ?? "");
  if (!fs || !ts) return { recipe: r, edge: null };
  const wired = new Set(r.edges.filter((e) => endpoint(e.to).node === to).map((e) => endpoint(e.to).port));
  for (const o of fs.outputs)
    for (const i of ts.inputs) {
      if (wired.has(i.name)) continue;
      const c = { source: from, sourceHandle: o.name, target: to, targetHandle: i.name };
      if (connectionError(cat, r, c) === null) {
        const next = connect(r, c);
        return { recipe: next, edge: next.edges[next.edges.length - 1] };
      }
    }
  return { recipe: r, edge: null };
}

export function removeNodes(r: Recipe, ids: ReadonlySet<string>): Recipe {
  const positions = { ...(r.ui?.positions ?? {}) };
  for (const id of ids) delete positions[id];
  return {
    ...r,
    nodes: r.nodes.filter((n) => !ids.has(n.id)),
    edges: r.edges.filter((e) => !ids.has(endpoint(e.from).node) && !ids.has(endpoint(e.to).node)),
    ui: { ...(r.ui ?? {}), positions },
  };
}

/** A fresh node id derived from `base` (a type id or an id being copied): base, base2, base3, … */
export function uniqueId(taken: ReadonlySet<string>, base: string): string {
  let stem = base.replace(/[^A-Za-z0-9_-]/g, "_").replace(/\d+$/, "") || "node";
  if (!/^[A-Za-z]/.test(stem)) stem = "n" + stem;
  stem = stem.slice(0, 56);
  if (!taken.has(stem)) return stem;
  for (let k = 2; ; k++) if (!taken.has(stem + k)) return stem + k;
}

/** Default parameter values from a JSON Schema's `default`s (top-level properties only). */
export function defaultParams(spec: NodeSpec): Record<string, unknown> {
  const props = (spec.params_schema?.properties ?? {}) as Record<string, { default?: unknown }>;
  const out: Record<string, unknown> = {};
  for (const [k, v] of Object.entries(props)) if (v && "default" in v && v.default !== undefined) out[k] = structuredClone(v.default);
  return out;
}

export function addNode(r: Recipe, spec: NodeSpec, at: XY): { recipe: Recipe; id: string } {
  const id = uniqueId(new Set(r.nodes.map((n) => n.id)), spec.type);
  const node: RecipeNode = { id, type: spec.type, params: {} };
  return { id, recipe: setPositions({ ...r, nodes: [...r.nodes, node] }, { [id]: at }) };
}

export function setPositions(r: Recipe, pos: Record<string, XY>): Recipe {
  return { ...r, ui: { ...(r.ui ?? {}), positions: { ...(r.ui?.positions ?? {}), ...pos } } };
}

export function setNodeParams(r: Recipe, id: string, params: Record<string, unknown>): Recipe {
  return { ...r, nodes: r.nodes.map((n) => (n.id === id ? { ...n, params } : n)) };
}

export function renameNode(r: Recipe, id: string, next: string): Recipe | string {
  if (id === next) return r;
  if (!NODE_ID_RE.test(next)) return "ids use letters, digits, '_' or '-' and start with a letter";
  if (r.nodes.some((n) => n.id === next)) return `id '${next}' is taken`;
  const re = (s: string) => {
    const e = endpoint(s);
    return e.node === id ? `${next}.${e.port}` : s;
  };
  const positions = { ...(r.ui?.positions ?? {}) };
  if (positions[id]) {
    positions[next] = positions[id];
    delete positions[id];
  }
  return {
    ...r,
    nodes: r.nodes.map((n) => (n.id === id ? { ...n, id: next } : n)),
    edges: r.edges.map((e) => ({ from: re(e.from), to: re(e.to) })),
    ui: { ...(r.ui ?? {}), positions },
  };
}

/**
 * Layered automatic layout: column = longest path from a source, row = order within the column.
 * Long chains wrap after `wrap` columns into bands below, so a pipeline stays readable on screen.
 */
export function autoLayout(r: Recipe, dx = 250, dy = 130, wrap = 4): Record<string, XY> {
  const depth = new Map<string, number>();
  const visit = (id: string, seen: Set<string>): number => {
    if (depth.has(id)) return depth.get(id)!;
    if (seen.has(id)) return 0;
    seen.add(id);
    const parents = r.edges.filter((e) => endpoint(e.to).node === id).map((e) => endpoint(e.from).node);
    const d = parents.length ? Math.max(...parents.map((p) => visit(p, seen) + 1)) : 0;
    depth.set(id, d);
    return d;
  };
  const rowOf = new Map<string, number>();
  const rows = new Map<number, number>();
  for (const n of r.nodes) {
    const d = visit(n.id, new Set());
    rowOf.set(n.id, rows.get(d) ?? 0);
    rows.set(d, (rows.get(d) ?? 0) + 1);
  }
  const band = (Math.max(1, ...rows.values()) + 0.6) * dy;
  const out: Record<string, XY> = {};
  for (const n of r.nodes) {
    const d = depth.get(n.id)!;
    out[n.id] = [(d % wrap) * dx, Math.floor(d / wrap) * band + rowOf.get(n.id)! * dy + (d % 2) * 30];
  }
  return out;
}

/** Positions for every node: saved ones, auto layout for the rest. */
export function positionsOf(r: Recipe): Record<string, XY> {
  const saved = r.ui?.positions ?? {};
  const missing = r.nodes.some((n) => !saved[n.id]);
  const auto = missing ? autoLayout(r) : {};
  return Object.fromEntries(r.nodes.map((n) => [n.id, (saved[n.id] as XY | undefined) ?? auto[n.id]]));
}

// ---- copy / paste ---------------------------------------------------------------------------------

export interface Clip {
  nodes: RecipeNode[];
  edges: RecipeEdge[];
  positions: Record<string, XY>;
}

/** Copy the selected nodes and the edges between them. */
export function copySelection(r: Recipe, ids: ReadonlySet<string>): Clip {
  const pos = positionsOf(r);
  return {
    nodes: r.nodes.filter((n) => ids.has(n.id)).map((n) => structuredClone(n)),
    edges: r.edges.filter((e) => ids.has(endpoint(e.from).node) && ids.has(endpoint(e.to).node)),
    positions: Object.fromEntries([...ids].filter((i) => pos[i]).map((i) => [i, pos[i]])),
  };
}

/** Paste a clip with fresh ids, offset by `offset` mm of canvas; returns the new ids. */
export function paste(r: Recipe, clip: Clip, offset: XY = [40, 40]): { recipe: Recipe; ids: string[] } {
  const taken = new Set(r.nodes.map((n) => n.id));
  const map = new Map<string, string>();
  for (const n of clip.nodes) {
    const id = uniqueId(taken, n.id);
    taken.add(id);
    map.set(n.id, id);
  }
  const nodes = clip.nodes.map((n) => ({ ...structuredClone(n), id: map.get(n.id)! }));
  const edges = clip.edges.map((e) => {
    const f = endpoint(e.from), t = endpoint(e.to);
    return { from: `${map.get(f.node)}.${f.port}`, to: `${map.get(t.node)}.${t.port}` };
  });
  const pos: Record<string, XY> = {};
  for (const [old, id] of map) {
    const p = clip.positions[old] ?? [0, 0];
    pos[id] = [p[0] + offset[0], p[1] + offset[1]];
  }
  return { recipe: setPositions({ ...r, nodes: [...r.nodes, ...nodes], edges: [...r.edges, ...edges] }, pos), ids: [...map.values()] };
}

// ---- undo / redo ------------------------------------------------------------------------------------

export interface History<T> {
  past: T[];
  present: T;
  future: T[];
}

export const LIMIT = 200;

export const history = <T>(present: T): History<T> => ({ past: [], present, future: [] });

export function commit<T>(h: History<T>, next: T): History<T> {
  if (next === h.present) return h;
  return { past: [...h.past, h.present].slice(-LIMIT), present: next, future: [] };
}

/** Replace the present without a new undo step (typing into one field is one step). */
export function amend<T>(h: History<T>, next: T): History<T> {
  return next === h.present ? h : { ...h, present: next, future: [] };
}

export function undo<T>(h: History<T>): History<T> {
  if (!h.past.length) return h;
  return { past: h.past.slice(0, -1), present: h.past[h.past.length - 1], future: [h.present, ...h.future] };
}

export function redo<T>(h: History<T>): History<T> {
  if (!h.future.length) return h;
  return { past: [...h.past, h.present], present: h.future[0], future: h.future.slice(1) };
}

/** Recipe without editor-only state, for comparing what the engine would see. */
export function engineView(r: Recipe): Omit<Recipe, "ui"> {
  const { ui: _ui, ...rest } = r;
  return rest;
}

/** Names of recipe inputs referenced as "$name" anywhere in node params. */
export function referencedInputs(r: Recipe): Set<string> {
  const out = new Set<string>();
  const walk = (v: unknown) => {
    if (typeof v === "string" && v.startsWith("$")) out.add(v.slice(1));
    else if (Array.isArray(v)) v.forEach(walk);
    else if (v && typeof v === "object") Object.values(v).forEach(walk);
  };
  r.nodes.forEach((n) => walk(n.params));
  return out;
}

/**
 * What an edit changed, coarsely: the node ids whose params/label changed, or the top-level
 * fields. Two successive edits with the same signature (typing into one field) can share one
 * undo step. Structural edits (nodes or edges added/removed) get a unique signature.
 */
export function changeSignature(a: Recipe, b: Recipe): string {
  if (a.nodes.length !== b.nodes.length || a.edges !== b.edges) return `structure:${Math.random()}`;
  const parts: string[] = [];
  for (let i = 0; i < a.nodes.length; i++) {
    if (a.nodes[i].id !== b.nodes[i].id) return `structure:${Math.random()}`;
    if (a.nodes[i] !== b.nodes[i]) parts.push(`node:${a.nodes[i].id}`);
  }
  for (const k of ["name", "description", "inputs", "ui"] as const) if (a[k] !== b[k]) parts.push(k);
  return parts.join("|");
}

// ---- frames (node groups) ----------------------------------------------------------------------------

/** A frame around a group of nodes, saved in the recipe's `ui.frames`; moving it moves its nodes. */
export interface Frame {
  id: string;
  label: string;
  x: number;
  y: number;
  w: number;
  h: number;
}

export const framesOf = (r: Recipe): Frame[] => (Array.isArray(r.ui?.frames) ? (r.ui!.frames as Frame[]) : []);

const withFrames = (r: Recipe, frames: Frame[]): Recipe => ({ ...r, ui: { ...(r.ui ?? {}), frames } });

/** Nodes whose box lies inside the frame (by their top-left corner and nominal size). */
export function nodesInFrame(r: Recipe, f: Frame): string[] {
  const pos = positionsOf(r);
  return r.nodes
    .filter((n) => {
      const [x, y] = pos[n.id];
      return x >= f.x && y >= f.y && x + NODE_BOX[0] / 2 <= f.x + f.w && y + NODE_BOX[1] / 2 <= f.y + f.h;
    })
    .map((n) => n.id);
}

/** A new frame around `ids` (padding for the title), or at `at` when no node is given. */
export function addFrame(r: Recipe, ids: ReadonlySet<string>, label: string, at: XY = [0, 0]): { recipe: Recipe; id: string } {
  const pos = positionsOf(r);
  const ps = [...ids].filter((i) => pos[i]).map((i) => pos[i]);
  const pad = 30;
  const box = ps.length
    ? { x: Math.min(...ps.map((p) => p[0])) - pad, y: Math.min(...ps.map((p) => p[1])) - pad - 20, w: 0, h: 0 }
    : { x: at[0], y: at[1], w: 420, h: 260 };
  if (ps.length) {
    box.w = Math.max(...ps.map((p) => p[0])) + NODE_BOX[0] + pad - box.x;
    box.h = Math.max(...ps.map((p) => p[1])) + NODE_BOX[1] + pad - box.y;
  }
  const taken = new Set(framesOf(r).map((f) => f.id));
  let k = 1;
  while (taken.has(`f${k}`)) k++;
  const id = `f${k}`;
  return { id, recipe: withFrames(r, [...framesOf(r), { id, label, ...box }]) };
}

/** Move a frame to `to`; the nodes inside it (where it was) move by the same amount. */
export function moveFrame(r: Recipe, id: string, to: XY): Recipe {
  const f = framesOf(r).find((x) => x.id === id);
  if (!f) return r;
  const [dx, dy] = [to[0] - f.x, to[1] - f.y];
  if (!dx && !dy) return r;
  const pos = positionsOf(r);
  const moved = Object.fromEntries(nodesInFrame(r, f).map((n) => [n, [pos[n][0] + dx, pos[n][1] + dy] as XY]));
  return withFrames(setPositions(r, moved), framesOf(r).map((x) => (x.id === id ? { ...x, x: to[0], y: to[1] } : x)));
}

export function updateFrame(r: Recipe, id: string, patch: Partial<Omit<Frame, "id">>): Recipe {
  return withFrames(r, framesOf(r).map((x) => (x.id === id ? { ...x, ...patch } : x)));
}

export function removeFrames(r: Recipe, ids: ReadonlySet<string>): Recipe {
  const frames = framesOf(r);
  const kept = frames.filter((f) => !ids.has(f.id));
  return kept.length === frames.length ? r : withFrames(r, kept);
}
