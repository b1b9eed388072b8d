/**
 * Folding the run's event stream (engine/events.py vocabulary) into per-node badges and the
 * run's progress. Pure: one event in, a new state out; the SSE hook and the tests share it.
 */
import type { RunError, RunEvent } from "../api/types";

export type NodeState = "running" | "cached" | "done" | "error";

export interface NodeStatus {
  state: NodeState;
  layer?: number | null;
  section?: string | null;
  message?: string | null;
  seconds?: number | null;
  /** layer nodes: their layers' compute time in any process (`seconds` is the run's wall time in the node) */
  computeSeconds?: number | null;
  progress?: number;
}

export interface RunState {
  id: string | null;
  phase: "idle" | "running" | "done" | "failed" | "cancelled";
  progress: number;
  nodes: Record<string, NodeStatus>;
  warnings: RunEvent[];
  error: RunError | null;
  lastSeq: number;
}

export const idleRun: RunState = { id: null, phase: "idle", progress: 0, nodes: {}, warnings: [], error: null, lastSeq: 0 };

export function startedRun(id: string): RunState {
  return { ...idleRun, id, phase: "running" };
}

export function reduceEvent(s: RunState, e: RunEvent): RunState {
  if (e.seq && e.seq <= s.lastSeq) return s; // replays after an SSE reconnect
  const next: RunState = { ...s, lastSeq: e.seq || s.lastSeq, progress: Math.max(s.progress, e.progress ?? 0) };
  const set = (id: string, st: NodeStatus) => (next.nodes = { ...s.nodes, [id]: st });
  switch (e.kind) {
    case "node_started":
      if (e.node) set(e.node, { state: "running", progress: 0, message: e.message });
      break;
    case "node_progress":
      if (e.node) set(e.node, { ...(s.nodes[e.node] ?? { state: "running" }), state: "running", layer: e.layer, message: e.message });
      break;
    case "node_cached":
      if (e.node) set(e.node, { state: "cached", seconds: e.seconds });
      break;
    case "node_finished":
      if (e.node) set(e.node, { state: e.cached ? "cached" : "done", seconds: e.seconds, computeSeconds: e.compute_seconds });
      break;
    case "node_error": {
      const err = e.error ?? { message: e.message ?? "error", node: e.node, layer: e.layer, section: e.section };
      if (e.node) set(e.node, { state: "error", layer: err.layer ?? e.layer, section: err.section ?? e.section, message: err.message ?? e.message });
      next.error = { ...err, node: err.node ?? e.node };
      break;
    }
    case "warning":
      next.warnings = [...s.warnings, e];
      break;
    case "run_finished":
      next.phase = "done";
      next.progress = 1;
      break;
    case "run_failed":
      next.phase = "failed";
      next.error = s.error ?? e.error ?? { message: e.message ?? "run failed", node: e.node, layer: e.layer, section: e.section };
      break;
    case "run_cancelled":
      next.phase = "cancelled";
      break;
  }
  return next;
}

export const terminal = (s: RunState) => s.phase === "done" || s.phase === "failed" || s.phase === "cancelled";

const secs = (t: number) => (t < 1 ? (t * 1000).toFixed(0) + " ms" : t.toFixed(1) + " s");

/**
 * Where a finished layer node's time went: its layers' compute time, summed over the processes
 * that computed them. In a parallel run a chain's first node waits for its followers' layers, so
 * its wall time says little about its own cost.
 */
export function computeText(st: NodeStatus): string | null {
  if (st.state !== "done" || st.computeSeconds == null) return null;
  return `layers computed in ${secs(st.computeSeconds)} (all processes); ${secs(st.seconds ?? 0)} of the run`;
}

/** Short badge text: "cached", "running 40%", "error · layer 5 · bs1/A". */
export function badgeText(st: NodeStatus): string {
  if (st.state === "error") return ["error", st.layer != null ? `layer ${st.layer}` : "", st.section ?? ""].filter(Boolean).join(" · ");
  if (st.state === "running") return st.layer != null ? `layer ${st.layer}` : "running";
  if (st.state === "done" && st.seconds != null) return `done ${secs(st.seconds)}`;
  return st.state;
}
