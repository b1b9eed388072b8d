/** The node-graph editor (React Flow): typed nodes and wires, frames, refusal reasons while a wire
 * is dragged. The state is in useGraphEditor's hooks. */
import {
  Background, Controls, Handle, MiniMap, NodeResizer, Position, ReactFlow, getBezierPath, useConnection, type ConnectionLineComponentProps, type Edge, type NodeProps,
} from "@xyflow/react";
import { createContext, memo, useContext, useMemo } from "react";
import type { Recipe } from "../api/types";
import { badgeText, computeText, type NodeStatus } from "../run/status";
import type { Catalog, XY } from "./recipe";
import {
  useConnectionRules, useDeletion, useFlowEdges, useFlowNodes, useNodesChange, usePaneActions, type AnyNode, type FNode, type Refusal, type Wire, type WNode,
} from "./useGraphEditor";

export type { WNodeData } from "./useGraphEditor";

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
  const [nodes, setNodes] = useFlowNodes(p);
  const edges = useFlowEdges(p.recipe, p.catalog, p.statuses);
  const { queueDelete, onEdgesChange } = useDeletion(p.onChange, p.active);
  const onNodesChange = useNodesChange(p, setNodes, queueDelete);
  const { reasonOf, refusalFor, valid, onConnect } = useConnectionRules(p.catalog, p.recipe, p.onChange, p.onMessage);
  const { onDrop, onDoubleClick } = usePaneActions(p.onAddAt, p.onSearch);

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
