/**
 * The graph editor's state, one hook per concern: React Flow nodes rebuilt from the recipe (frames
 * below, nodes above), the wires coloured by port type, deletion as one edit (Delete key and React
 * Flow's remove changes), node / frame moves and selection, the connection rules, and drop /
 * double-click on the pane.
 */
import {
  applyNodeChanges, useReactFlow, type Edge, type EdgeChange, type Node, type NodeChange, type OnConnect,
} from "@xyflow/react";
import { useCallback, useEffect, useMemo, useRef, useState, type DragEvent, type MouseEvent } from "react";
import type { NodeSpec, Recipe, RecipeNode } from "../api/types";
import type { NodeStatus } from "../run/status";
import { isTyping } from "./useShortcuts";
import {
  connect, connectionError, connectionRefusal, edgeId, endpoint, framesOf, moveFrame, nodesInFrame, positionsOf, removeEdges, removeFrames, removeNodes, setPositions,
  updateFrame, type Catalog, type Frame, type XY,
} from "./recipe";

export interface WNodeData extends Record<string, unknown> {
  node: RecipeNode;
  spec?: NodeSpec;
  status?: NodeStatus;
  previewed: boolean;
  onPreview: (id: string) => void;
  problems?: { errors: number; warnings: number; text: string };
}
export type WNode = Node<WNodeData, "waam">;
export interface FrameData extends Record<string, unknown> {
  frame: Frame;
  onRename: (id: string) => void;
  onResized: (id: string, box: { x: number; y: number; w: number; h: number }) => void;
}
export type FNode = Node<FrameData, "frame">;
export type AnyNode = WNode | FNode;
/** Frame ids live beside node ids in the editor; a node id never contains ':'. */
export const FRAME = "frame:";
export const isFrame = (id: string) => id.startsWith(FRAME);

export type Refusal = { text: string; short: string } | null;
export type Wire = { source: string; sourceHandle: string | null; target: string; targetHandle: string | null };

type Edit = (edit: (r: Recipe) => Recipe) => void;

/** What the hooks read of the editor's props. */
export interface EditorInputs {
  recipe: Recipe;
  catalog: Catalog;
  statuses: Record<string, NodeStatus>;
  selected: ReadonlySet<string>;
  previewNode: string | null;
  problems: ReadonlyMap<string, { errors: number; warnings: number; text: string }>;
  onPreview: (id: string) => void;
  onChange: Edit;
}

/** Rename (prompt) and resize of a frame, each one edit. */
function useFrameEdits(recipe: Recipe, onChange: Edit) {
  const onRename = useCallback(
    (id: string) => {
      const f = framesOf(recipe).find((x) => x.id === id);
      const label = f && window.prompt("frame title", f.label);
      if (label) onChange((r) => updateFrame(r, id, { label }));
    },
    [recipe, onChange],
  );
  const onResized = useCallback((id: string, box: { x: number; y: number; w: number; h: number }) => onChange((r) => updateFrame(r, id, box)), [onChange]);
  return { onRename, onResized };
}

/** The editor's nodes: rebuilt from the recipe, keeping what the editor measured. */
export function useFlowNodes(p: EditorInputs) {
  const { recipe, catalog } = p;
  const [nodes, setNodes] = useState<AnyNode[]>([]);
  const { onRename, onResized } = useFrameEdits(recipe, p.onChange);
  useEffect(() => {
    const pos = positionsOf(recipe);
    setNodes((prev) => {
      const old = new Map(prev.map((n) => [n.id, n]));
      // Frames first (drawn below the nodes).
      const frames: FNode[] = framesOf(recipe).map((f) => ({
        ...((old.get(FRAME + f.id) as FNode | undefined) ?? {}),
        id: FRAME + f.id,
        type: "frame",
        position: { x: f.x, y: f.y },
        style: { width: f.w, height: f.h },
        width: f.w,
        height: f.h,
        zIndex: -1,
        dragHandle: ".wframe-head",
        data: { frame: f, onRename, onResized },
      }));
      return [...frames, ...recipe.nodes.map((n) => {
        const o = old.get(n.id);
        const [x, y] = pos[n.id];
        return {
          ...(o ?? {}),
          id: n.id,
          type: "waam",
          position: { x, y },
          selected: p.selected.has(n.id),
          data: {
            node: n, spec: catalog.get(n.type), status: p.statuses[n.id], previewed: p.previewNode === n.id, onPreview: p.onPreview, problems: p.problems.get(n.id),
          },
        } as WNode;
      })];
    });
  }, [recipe, catalog, p.statuses, p.selected, p.previewNode, p.onPreview, p.problems, onRename, onResized]);
  return [nodes, setNodes] as const;
}

/** The recipe's wires, coloured by the source port's type, animated into a running node. */
export function useFlowEdges(recipe: Recipe, catalog: Catalog, statuses: Record<string, NodeStatus>): Edge[] {
  return useMemo(
    () =>
      recipe.edges.map((e) => {
        const f = endpoint(e.from), t = endpoint(e.to);
        const src = recipe.nodes.find((n) => n.id === f.node);
        const color = src ? catalog.get(src.type)?.outputs.find((o) => o.name === f.port)?.color : undefined;
        return {
          id: edgeId(e), source: f.node, sourceHandle: f.port, target: t.node, targetHandle: t.port,
          style: { stroke: color ?? "#999", strokeWidth: 2 },
          animated: statuses[t.node]?.state === "running",
        };
      }),
    [recipe, catalog, statuses],
  );
}

/**
 * Deletion as one edit (one undo step). One deletion reports its edges and its nodes in separate
 * callbacks, one after the other in the same task: they are gathered and applied once. Delete /
 * Backspace removes the selection through React Flow's own deletion (so nodes, frames and their
 * edges arrive in onNodesChange / onEdgesChange). React Flow's built-in delete key is off: its
 * pressed-key tracking stayed stuck after Ctrl+C / Ctrl+V, and Delete then did nothing.
 */
export function useDeletion(onChange: Edit, active: boolean) {
  const rf = useReactFlow();
  const pending = useRef<{ nodes: Set<string>; edges: Set<string> } | null>(null);
  const queueDelete = useCallback(
    (nodeIds: string[], edgeIds: string[]) => {
      if (!pending.current) {
        pending.current = { nodes: new Set(), edges: new Set() };
        queueMicrotask(() => {
          const d = pending.current!;
          pending.current = null;
          const nodeSet = new Set([...d.nodes].filter((id) => !isFrame(id)));
          const frameSet = new Set([...d.nodes].filter(isFrame).map((id) => id.slice(FRAME.length)));
          onChange((r) => removeFrames(nodeSet.size ? removeNodes(removeEdges(r, d.edges), nodeSet) : removeEdges(r, d.edges), frameSet));
        });
      }
      nodeIds.forEach((id) => pending.current!.nodes.add(id));
      edgeIds.forEach((id) => pending.current!.edges.add(id));
    },
    [onChange],
  );
  useEffect(() => {
    if (!active) return;
    const onKey = (e: KeyboardEvent) => {
      if ((e.key !== "Delete" && e.key !== "Backspace") || e.ctrlKey || e.metaKey || e.altKey || isTyping(e.target)) return;
      const nodes = rf.getNodes().filter((n) => n.selected);
      const edges = rf.getEdges().filter((x) => x.selected);
      if (!nodes.length && !edges.length) return;
      e.preventDefault();
      void rf.deleteElements({ nodes, edges });
    };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, [active, rf]);
  const onEdgesChange = useCallback(
    (changes: EdgeChange[]) => {
      const removed = changes.filter((c) => c.type === "remove").map((c) => c.id);
      if (removed.length) queueDelete([], removed);
    },
    [queueDelete],
  );
  return { queueDelete, onEdgesChange };
}

/** A frame being dragged carries the nodes inside it along (live); its drop is returned to commit. */
function frameDrags(recipe: Recipe, changes: NodeChange<AnyNode>[]) {
  const extra: NodeChange<AnyNode>[] = [];
  const frameMoves: [string, XY][] = [];
  for (const c of changes) {
    if (c.type !== "position" || !c.position || !isFrame(c.id)) continue;
    const f = framesOf(recipe).find((x) => FRAME + x.id === c.id);
    if (!f) continue;
    const [dx, dy] = [c.position.x - f.x, c.position.y - f.y];
    const pos = positionsOf(recipe);
    for (const n of nodesInFrame(recipe, f)) extra.push({ type: "position", id: n, position: { x: pos[n][0] + dx, y: pos[n][1] + dy } });
    if (c.dragging === false) frameMoves.push([f.id, [Math.round(c.position.x), Math.round(c.position.y)]]);
  }
  return { extra, frameMoves };
}

/** React Flow's node changes: applied live; drops, selection and removals become recipe edits. */
export function useNodesChange(
  p: { recipe: Recipe; selected: ReadonlySet<string>; onChange: Edit; onSelect: (ids: Set<string>) => void },
  setNodes: (f: (ns: AnyNode[]) => AnyNode[]) => void,
  queueDelete: (nodeIds: string[], edgeIds: string[]) => void,
) {
  const { recipe, selected, onChange, onSelect } = p;
  return useCallback(
    (changes: NodeChange<AnyNode>[]) => {
      const { extra, frameMoves } = frameDrags(recipe, changes);
      setNodes((ns) => applyNodeChanges([...changes, ...extra], ns));
      const moved: Record<string, XY> = {};
      let selectionChanged = false;
      const sel = new Set(selected);
      for (const c of changes) {
        if (c.type === "position" && c.position && c.dragging === false && !isFrame(c.id)) moved[c.id] = [Math.round(c.position.x), Math.round(c.position.y)];
        if (c.type === "select" && !isFrame(c.id)) {
          selectionChanged = true;
          if (c.selected) sel.add(c.id);
          else sel.delete(c.id);
        }
      }
      const removed = changes.filter((c) => c.type === "remove").map((c) => c.id);
      if (removed.length) queueDelete(removed, []);
      if (Object.keys(moved).length) onChange((r) => setPositions(r, moved));
      for (const [id, to] of frameMoves) onChange((r) => moveFrame(r, id, to));
      if (selectionChanged) onSelect(sel);
    },
    [recipe, selected, onChange, onSelect, setNodes, queueDelete],
  );
}

/** Which wires may connect (the catalog's port types), why not, and a connection as an edit. */
export function useConnectionRules(catalog: Catalog, recipe: Recipe, onChange: Edit, onMessage: (m: string) => void) {
  const reasonOf = useCallback((c: Wire) => connectionError(catalog, recipe, c), [catalog, recipe]);
  const refusalFor = useCallback((c: Wire) => connectionRefusal(catalog, recipe, c), [catalog, recipe]);
  const valid = useCallback(
    (c: Edge | { source: string; target: string; sourceHandle?: string | null; targetHandle?: string | null }) =>
      connectionError(catalog, recipe, { source: c.source, target: c.target, sourceHandle: c.sourceHandle ?? null, targetHandle: c.targetHandle ?? null }) === null,
    [catalog, recipe],
  );
  const onConnect: OnConnect = useCallback(
    (c) => {
      const err = connectionError(catalog, recipe, c);
      if (err) onMessage(err);
      else onChange((r) => connect(r, c));
    },
    [catalog, recipe, onChange, onMessage],
  );
  return { reasonOf, refusalFor, valid, onConnect };
}

/** A palette item dropped on the pane adds that node there; a double click on the empty pane opens the node search there (instead of zooming). */
export function usePaneActions(onAddAt: (type: string, at: XY) => void, onSearch: (x: number, y: number, at: XY) => void) {
  const rf = useReactFlow();
  const onDrop = useCallback(
    (e: DragEvent) => {
      const type = e.dataTransfer.getData("application/waamflow-node");
      if (!type) return;
      e.preventDefault();
      const at = rf.screenToFlowPosition({ x: e.clientX, y: e.clientY });
      onAddAt(type, [Math.round(at.x), Math.round(at.y)]);
    },
    [rf, onAddAt],
  );
  const onDoubleClick = useCallback(
    (e: MouseEvent) => {
      if (!(e.target as HTMLElement).classList.contains("react-flow__pane")) return;
      const at = rf.screenToFlowPosition({ x: e.clientX, y: e.clientY });
      onSearch(e.clientX, e.clientY, [Math.round(at.x), Math.round(at.y)]);
    },
    [rf, onSearch],
  );
  return { onDrop, onDoubleClick };
}
