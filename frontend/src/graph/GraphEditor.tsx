import {
  Background, Controls, Handle, MiniMap, NodeResizer, Position, ReactFlow, applyNodeChanges, getBezierPath, useReactFlow,
  useConnection, type ConnectionLineComponentProps, type Edge, type EdgeChange, type Node, type NodeChange, type NodeProps, type OnConnect,
} from "@xyflow/react";
import { createContext, memo, useCallback, useContext, useEffect, useMemo, useRef, useState, type DragEvent, type MouseEvent } from "react";
import type { NodeSpec, Recipe, RecipeNode } from "../api/types";
import { badgeText, computeText, type NodeStatus } from "../run/status";
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
type WNode = Node<WNodeData, "waam">;
interface FrameData extends Record<string, unknown> {
  frame: Frame;
  onRename: (id: string) => void;
  onResized: (id: string, box: { x: number; y: number; w: number; h: number }) => void;
}
type FNode = Node<FrameData, "frame">;
type AnyNode = WNode | FNode;
/** Frame ids live beside node ids in the editor; a node id never contains ':'. */
const FRAME = "frame:";
const isFrame = (id: string) => id.startsWith(FRAME);

/** A frame (node group): drag its title to move it with the nodes inside; resize from its edges. */
const FrameNode = memo(function FrameNode({ data, selected }: NodeProps<FNode>) {
  const f = data.frame;
  return (
    <div className={`wframe ${selected ? "selected" : ""}`} data-frame-id={f.id}>
      <NodeResizer
        isVisible={selected}
        minWidth={160}
        minHeight={100}
        onResizeEnd={(_, b) => data.onResized(f.id, { x: Math.round(b.x), y: Math.round(b.y), w: Math.round(b.width), h: Math.round(b.height) })}
      />
      <div className="wframe-head" onDoubleClick={() => data.onRename(f.id)} title="drag to move the frame with its nodes; double-click to rename">
        {f.label}
      </div>
    </div>
  );
});

type Refusal = { text: string; short: string } | null;
type Wire = { source: string; sourceHandle: string | null; target: string; targetHandle: string | null };

/** The wire being dragged, as [side it starts from, node, port] (null when none is). */
function useDraggedWire(): [string, string, string] | null {
  // A string selector: nodes re-render when a drag starts or ends, not on every pointer move.
  const key = useConnection((c) => (c.inProgress && c.fromHandle?.id ? JSON.stringify([c.fromHandle.type, c.fromNode.id, c.fromHandle.id]) : null));
  return useMemo(() => (key ? (JSON.parse(key) as [string, string, string]) : null), [key]);
}

/** While a wire is dragged: why this node's handle (`side`, `port`) cannot take it, or null. */
function refusalOf(drag: [string, string, string] | null, nodeId: string, side: "source" | "target", port: string, why: (c: Wire) => Refusal): Refusal {
  if (!drag || drag[0] === side) return null; // a wire ends on a handle of the other side
  const [from, fromNode, fromPort] = drag;
  if (fromNode === nodeId && fromPort === port) return null;
  return why(from === "source" ? { source: fromNode, sourceHandle: fromPort, target: nodeId, targetHandle: port } : { source: nodeId, sourceHandle: port, target: fromNode, targetHandle: fromPort });
}

/** A refused handle's reason, on the handle: its title / description and a visible tag beside it. */
/** A port's handle; while a wire is dragged, a refused one carries the reason (ring, title, aria). */
function PortHandle({ type, name, color, r }: { type: "source" | "target"; name: string; color?: string; r: Refusal }) {
  const why = r ? `cannot connect: ${r.text}` : undefined;
  return (
    <Handle
      type={type}
      position={type === "target" ? Position.Left : Position.Right}
      id={name}
      style={{ background: color }}
      className={r ? "refused" : undefined}
      title={why}
      aria-description={why}
      data-reason={r?.text}
    />
  );
}

function RefusalTag({ r }: { r: Refusal }) {
  return r ? (
    <span className="port-refusal" data-testid="port-refusal" aria-hidden="true">
      ✕ {r.short}
    </span>
  ) : null;
}

/** One node: title, id, status badge, typed ports (handles keyed by port name, coloured by type). */
const WaamNode = memo(function WaamNode({ data, selected }: NodeProps<WNode>) {
  const { node, spec, status } = data;
  const rows = Math.max(spec?.inputs.length ?? 0, spec?.outputs.length ?? 0);
  const drag = useDraggedWire();
  const why = useContext(RefusalContext);
  const refusal = (side: "source" | "target", port: string) => refusalOf(drag, node.id, side, port, why);
  return (
    <div className={`wnode ${selected ? "selected" : ""} ${status ? "st-" + status.state : ""} ${spec ? "" : "unknown"}`} data-node-id={node.id}>
      <div className="wnode-head" title={spec?.description}>
        <span className="wnode-title">{node.label || spec?.title || node.type}</span>
        <button
          className={`eye ${data.previewed ? "on" : ""}`}
          title="show this node in the 3D view and on the mask canvas"
          onClick={(e) => {
            e.stopPropagation();
            data.onPreview(node.id);
          }}
        >
          ◉
        </button>
      </div>
      <div className="wnode-id">{node.id}</div>
      <div className="wnode-ports" style={{ minHeight: rows * 20 }}>
        <div className="ports-in">
          {spec?.inputs.map((p) => {
            const r = refusal("target", p.name);
            return (
              <div className={`port ${r ? "refused" : ""}`} key={p.name} title={r ? `cannot connect: ${r.text}` : `${p.type}${p.optional ? " (optional)" : ""}: ${p.description}`}>
                <PortHandle type="target" name={p.name} color={p.color} r={r} />
                <RefusalTag r={r} />
                <span>{p.name}</span>
              </div>
            );
          })}
        </div>
        <div className="ports-out">
          {spec?.outputs.map((p) => {
            const r = refusal("source", p.name);
            return (
              <div className={`port out ${r ? "refused" : ""}`} key={p.name} title={r ? `cannot connect: ${r.text}` : `${p.type}: ${p.description}`}>
                <span>{p.name}</span>
                <RefusalTag r={r} />
                <PortHandle type="source" name={p.name} color={p.color} r={r} />
              </div>
            );
          })}
        </div>
      </div>
      {status && (
        <div className={`badge b-${status.state}`} title={status.message ?? computeText(status) ?? undefined}>
          {badgeText(status)}
        </div>
      )}
      {data.problems && (
        <div
          className={`problem-badge ${data.problems.errors ? "errors" : "warnings"}`}
          title={data.problems.text}
          data-testid="problem-badge"
          aria-label={`${data.problems.errors} errors, ${data.problems.warnings} warnings: ${data.problems.text}`}
        >
          {data.problems.errors ? `✖ ${data.problems.errors}` : ""}
          {data.problems.warnings ? ` ⚠ ${data.problems.warnings}` : ""}
        </div>
      )}
      {!spec && <div className="badge b-error">unknown type</div>}
    </div>
  );
});

const nodeTypes = { waam: WaamNode, frame: FrameNode };

/** Why a wire cannot connect two handles, full and short (null when it can). */
const RefusalContext = createContext<(c: Wire) => Refusal>(() => null);

/** Why the wire being dragged cannot end at the handle under the pointer (null when it can). */
const ReasonContext = createContext<(c: { source: string; sourceHandle: string | null; target: string; targetHandle: string | null }) => string | null>(() => null);

/** The wire being dragged; over a handle it cannot connect to, it turns red and says why. */
function WireLine({ fromX, fromY, toX, toY, fromPosition, toPosition, fromNode, fromHandle, toNode, toHandle }: ConnectionLineComponentProps) {
  const reasonOf = useContext(ReasonContext);
  const [path] = getBezierPath({ sourceX: fromX, sourceY: fromY, sourcePosition: fromPosition, targetX: toX, targetY: toY, targetPosition: toPosition });
  let reason: string | null = null;
  if (toNode && toHandle) {
    const out = fromHandle.type === "source";
    reason = reasonOf(
      out
        ? { source: fromNode.id, sourceHandle: fromHandle.id ?? null, target: toNode.id, targetHandle: toHandle.id ?? null }
        : { source: toNode.id, sourceHandle: toHandle.id ?? null, target: fromNode.id, targetHandle: fromHandle.id ?? null },
    );
  }
  return (
    <g className={`wire-drag ${reason ? "invalid" : ""}`}>
      <path d={path} fill="none" stroke={reason ? "#c62828" : "#555"} strokeWidth={2} strokeDasharray={reason ? "6 4" : undefined} />
      {reason && (
        <g transform={`translate(${toX + 12}, ${toY - 14})`} data-testid="wire-reason" data-reason={reason}>
          <rect x={-4} y={-14} width={reason.length * 7 + 8} height={20} rx={4} fill="#fff" stroke="#c62828" />
          <text fontSize={12} fill="#b71c1c">
            {reason}
          </text>
        </g>
      )}
    </g>
  );
}

export interface GraphEditorProps {
  recipe: Recipe;
  catalog: Catalog;
  statuses: Record<string, NodeStatus>;
  selected: ReadonlySet<string>;
  previewNode: string | null;
  onSelect: (ids: Set<string>) => void;
  /** Apply an edit to the recipe (one undo step). Updaters compose when called in one tick. */
  onChange: (edit: (r: Recipe) => Recipe) => void;
  onPreview: (id: string) => void;
  onAddAt: (type: string, at: XY) => void;
  onMessage: (m: string) => void;
  /** False while another tab is shown: the editor stays mounted but must not take Delete etc. */
  active: boolean;
  /** Problems of the last run per node (badges). */
  problems: ReadonlyMap<string, { errors: number; warnings: number; text: string }>;
  /** Open the node search at a screen point for a node at flow point `at`. */
  onSearch: (x: number, y: number, at: XY) => void;
}

export function GraphEditor(p: GraphEditorProps) {
  const { recipe, catalog } = p;
  const rf = useReactFlow();
  const [nodes, setNodes] = useState<AnyNode[]>([]);

  const onRenameFrame = useCallback(
    (id: string) => {
      const f = framesOf(p.recipe).find((x) => x.id === id);
      const label = f && window.prompt("frame title", f.label);
      if (label) p.onChange((r) => updateFrame(r, id, { label }));
    },
    [p],
  );
  const onResizedFrame = useCallback(
    (id: string, box: { x: number; y: number; w: number; h: number }) => p.onChange((r) => updateFrame(r, id, box)),
    [p],
  );

  // Rebuild editor nodes from the recipe, keeping what the editor measured.
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
        data: { frame: f, onRename: onRenameFrame, onResized: onResizedFrame },
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
  }, [recipe, catalog, p.statuses, p.selected, p.previewNode, p.onPreview, p.problems, onRenameFrame, onResizedFrame]);

  const edges: Edge[] = useMemo(
    () =>
      recipe.edges.map((e) => {
        const f = endpoint(e.from), t = endpoint(e.to);
        const src = recipe.nodes.find((n) => n.id === f.node);
        const color = src ? catalog.get(src.type)?.outputs.find((o) => o.name === f.port)?.color : undefined;
        return {
          id: edgeId(e), source: f.node, sourceHandle: f.port, target: t.node, targetHandle: t.port,
          style: { stroke: color ?? "#999", strokeWidth: 2 },
          animated: p.statuses[t.node]?.state === "running",
        };
      }),
    [recipe, catalog, p.statuses],
  );

  // One deletion (Delete key) reports its edges and its nodes in separate callbacks, one after the
  // other in the same task: gather them and apply one edit (one undo step).
  const pendingDelete = useRef<{ nodes: Set<string>; edges: Set<string> } | null>(null);
  const queueDelete = useCallback(
    (nodeIds: string[], edgeIds: string[]) => {
      if (!pendingDelete.current) {
        pendingDelete.current = { nodes: new Set(), edges: new Set() };
        queueMicrotask(() => {
          const d = pendingDelete.current!;
          pendingDelete.current = null;
          const nodeSet = new Set([...d.nodes].filter((id) => !isFrame(id)));
          const frameSet = new Set([...d.nodes].filter(isFrame).map((id) => id.slice(FRAME.length)));
          p.onChange((r) => removeFrames(nodeSet.size ? removeNodes(removeEdges(r, d.edges), nodeSet) : removeEdges(r, d.edges), frameSet));
        });
      }
      nodeIds.forEach((id) => pendingDelete.current!.nodes.add(id));
      edgeIds.forEach((id) => pendingDelete.current!.edges.add(id));
    },
    [p],
  );
  // Delete/Backspace removes the selection through React Flow's own deletion (so nodes, frames and
  // their edges arrive in onNodesChange/onEdgesChange and become one edit). React Flow's built-in
  // delete key is off: its pressed-key tracking stayed stuck after Ctrl+C/Ctrl+V, and Delete then
  // did nothing.
  useEffect(() => {
    if (!p.active) return;
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
  }, [p.active, rf]);

  const onNodesChange = useCallback(
    (changes: NodeChange<AnyNode>[]) => {
      // A frame being dragged carries the nodes inside it along (live; committed on drop).
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
      setNodes((ns) => applyNodeChanges([...changes, ...extra], ns));
      const moved: Record<string, XY> = {};
      let selectionChanged = false;
      const sel = new Set(p.selected);
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
      if (Object.keys(moved).length) p.onChange((r) => setPositions(r, moved));
      for (const [id, to] of frameMoves) p.onChange((r) => moveFrame(r, id, to));
      if (selectionChanged) p.onSelect(sel);
    },
    [p, recipe, queueDelete],
  );

  const onEdgesChange = useCallback(
    (changes: EdgeChange[]) => {
      const removed = changes.filter((c) => c.type === "remove").map((c) => c.id);
      if (removed.length) queueDelete([], removed);
    },
    [queueDelete],
  );

  const reasonOf = useCallback(
    (c: { source: string; sourceHandle: string | null; target: string; targetHandle: string | null }) => connectionError(catalog, recipe, c),
    [catalog, recipe],
  );
  const refusalFor = useCallback((c: Wire) => connectionRefusal(catalog, recipe, c), [catalog, recipe]);
  const valid = useCallback(
    (c: Edge | { source: string; target: string; sourceHandle?: string | null; targetHandle?: string | null }) =>
      connectionError(catalog, recipe, { source: c.source, target: c.target, sourceHandle: c.sourceHandle ?? null, targetHandle: c.targetHandle ?? null }) === null,
    [catalog, recipe],
  );

  const onConnect: OnConnect = useCallback(
    (c) => {
      const err = connectionError(catalog, recipe, c);
      if (err) p.onMessage(err);
      else p.onChange((r) => connect(r, c));
    },
    [catalog, recipe, p],
  );

  const onDrop = useCallback(
    (e: DragEvent) => {
      const type = e.dataTransfer.getData("application/waamflow-node");
      if (!type) return;
      e.preventDefault();
      const at = rf.screenToFlowPosition({ x: e.clientX, y: e.clientY });
      p.onAddAt(type, [Math.round(at.x), Math.round(at.y)]);
    },
    [rf, p],
  );

  // Double-click on empty canvas opens the node search there (instead of zooming).
  const onDoubleClick = useCallback(
    (e: MouseEvent) => {
      if (!(e.target as HTMLElement).classList.contains("react-flow__pane")) return;
      const at = rf.screenToFlowPosition({ x: e.clientX, y: e.clientY });
      p.onSearch(e.clientX, e.clientY, [Math.round(at.x), Math.round(at.y)]);
    },
    [rf, p],
  );

  return (
    <ReasonContext.Provider value={reasonOf}>
    <RefusalContext.Provider value={refusalFor}>
    <div className="graph-editor" onDragOver={(e) => e.preventDefault()} onDrop={onDrop} onDoubleClick={onDoubleClick} data-testid="graph-editor">
      <ReactFlow<AnyNode, Edge>
        nodes={nodes}
        edges={edges}
        nodeTypes={nodeTypes}
        onNodesChange={onNodesChange}
        onEdgesChange={onEdgesChange}
        onConnect={onConnect}
        isValidConnection={valid}
        connectionLineComponent={WireLine}
        zoomOnDoubleClick={false}
        elevateNodesOnSelect={false}
        deleteKeyCode={null}
        selectionKeyCode={p.active ? "Shift" : null}
        multiSelectionKeyCode={p.active ? ["Control", "Meta"] : null}
        fitView
        minZoom={0.1}
        maxZoom={3}
        proOptions={{ hideAttribution: true }}
      >
        <Background gap={20} />
        <Controls />
        <MiniMap pannable zoomable style={{ width: 140, height: 90 }} />
      </ReactFlow>
    </div>
    </RefusalContext.Provider>
    </ReasonContext.Provider>
  );
}
