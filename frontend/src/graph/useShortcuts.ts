import { useEffect, useRef } from "react";

export interface Shortcuts {
  /** Copy/paste/select-all/fit act on the graph only while its tab is shown. */
  graphActive: boolean;
  save: () => void;
  undo: () => void;
  redo: () => void;
  copy: () => void;
  paste: () => void;
  selectAll: () => void;
  fit: () => void;
  /** Open the node search (`/`). */
  search: () => void;
}

export const isTyping = (t: EventTarget | null) => {
  const el = t as HTMLElement | null;
  return !!el && (el.tagName === "INPUT" || el.tagName === "TEXTAREA" || el.tagName === "SELECT" || el.isContentEditable);
};

/**
 * The editor's keyboard habits: Ctrl+S save (everywhere), Ctrl+Z / Ctrl+Y / Ctrl+Shift+Z undo/redo,
 * and on the graph Ctrl+C / Ctrl+V / Ctrl+A, F (fit view) and / (node search). Keys typed into a field are left alone.
 * Delete (GraphEditor, through React Flow's deleteElements) and Shift+drag box select are the node editor's.
 */
export function useShortcuts(actions: Shortcuts) {
  const ref = useRef(actions);
  ref.current = actions;
  useEffect(() => {
    const onKey = (e: KeyboardEvent) => {
      const a = ref.current;
      const mod = e.ctrlKey || e.metaKey;
      const key = e.key.toLowerCase();
      if (mod && key === "s") {
        e.preventDefault();
        a.save();
        return;
      }
      if (isTyping(e.target)) return;
      if (mod && key === "z" && !e.shiftKey) a.undo();
      else if (mod && (key === "y" || (key === "z" && e.shiftKey))) a.redo();
      else if (!a.graphActive) return;
      else if (mod && key === "c") a.copy();
      else if (mod && key === "v") a.paste();
      else if (mod && key === "a") a.selectAll();
      else if (!mod && key === "f") a.fit();
      else if (!mod && e.key === "/") a.search();
      else return;
      e.preventDefault();
    };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, []);
}
