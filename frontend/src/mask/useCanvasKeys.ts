/** The canvas's keyboard alternatives (documented in frontend/README.md). */
import { useEffect } from "react";
import type { Pt } from "./geom";
import { dropVertex, nudge, nudgeStep } from "./canvasTools";
import { curveOf, maskKeys, stepSection, stepVertex } from "./canvasModel";
import type { Tool, ToolProps, useDraft, useMeasure, VertexSel } from "./useCanvasTools";

const ARROWS: Record<string, Pt> = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, 1], ArrowDown: [0, -1] };
const TOOL_KEYS: Record<string, Tool> = { v: "select", c: "curve", g: "guide", s: "split", m: "measure" };

export interface KeyState {
  draft: ReturnType<typeof useDraft>;
  meas: Pick<ReturnType<typeof useMeasure>, "clear">;
  vertexSel: VertexSel;
  setVertexSel: (v: VertexSel) => void;
  fit: () => void;
}

/** Apply a key to the picked vertex or the selected section; false when it is not one of theirs. */
function editKey(p: ToolProps, k: KeyState, e: KeyboardEvent): boolean {
  const sel = k.vertexSel;
  const del = e.key === "Delete" || e.key === "Backspace";
  if (ARROWS[e.key] && sel) {
    const curve = curveOf(p.mask, sel.key);
    const st = nudgeStep(p.grid, e.shiftKey);
    if (curve) p.edits.setCurve(sel.key, nudge(curve, sel.index, ARROWS[e.key][0] * st, ARROWS[e.key][1] * st));
    return !!curve;
  }
  if (del && sel && !k.draft.draft.length) {
    const curve = curveOf(p.mask, sel.key);
    const next = curve ? dropVertex(curve, sel.index) : null;
    if (next) {
      p.edits.setCurve(sel.key, next);
      k.setVertexSel({ key: sel.key, index: Math.min(sel.index, next.length - 1) });
    }
    return true;
  }
  if (del && p.selected && !k.draft.draft.length) {
    p.edits.removeSection(p.selected);
    p.setSelected(null);
    return true;
  }
  return false;
}

/** Apply a key that picks: a vertex ([ ]), a section ({ }), a layer (PageUp / PageDown), a tool. */
function pickKey(p: ToolProps, k: KeyState, e: KeyboardEvent): boolean {
  const keys = maskKeys(p.mask);
  if (e.key === "PageUp" || e.key === "PageDown") p.onLayerStep(e.key === "PageUp" ? 1 : -1);
  else if ((e.key === "]" || e.key === "[") && p.selected) {
    const curve = curveOf(p.mask, p.selected);
    if (!curve?.length) return false;
    const cur = k.vertexSel?.key === p.selected ? k.vertexSel.index : null;
    k.setVertexSel({ key: p.selected, index: stepVertex(curve.length, cur, e.key === "]" ? 1 : -1) });
    p.setTool("select");
  } else if ((e.key === "}" || e.key === "{") && keys.length) p.setSelected(stepSection(keys, p.selected, e.key === "}" ? 1 : -1));
  else if (Object.hasOwn(TOOL_KEYS, e.key)) p.setTool(TOOL_KEYS[e.key]);
  else if (e.key === "f") k.fit();
  else return false;
  return true;
}

/** Esc clears the draft and the measure, then the picked vertex, then the selection; Enter finishes a draft. */
function escapeKey(p: ToolProps, k: KeyState, e: KeyboardEvent): boolean {
  if (e.key === "Escape") {
    k.draft.clear();
    k.meas.clear();
    if (k.vertexSel) k.setVertexSel(null);
    else if (!k.draft.draft.length) p.setSelected(null);
  } else if (e.key === "Enter") k.draft.finish();
  else return false;
  return true;
}

/** The window's keydown while the canvas is shown (not while typing in a field, not with Ctrl / Meta / Alt). */
export function useCanvasKeys(p: ToolProps, k: KeyState) {
  useEffect(() => {
    const onKey = (e: KeyboardEvent) => {
      const t = e.target as HTMLElement;
      if (t && (t.tagName === "INPUT" || t.tagName === "TEXTAREA" || t.tagName === "SELECT")) return;
      if (e.ctrlKey || e.metaKey || e.altKey) return;
      if (escapeKey(p, k, e) || editKey(p, k, e) || pickKey(p, k, e)) e.preventDefault();
    };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  });
}
