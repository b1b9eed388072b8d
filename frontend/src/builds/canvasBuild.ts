/**
 * Which build's as-built deviation the 2D canvas overlays (set on the builds page, read by
 * `DeviationOverlay` inside the mask canvas). Kept for the tab's session.
 */
import { useSyncExternalStore } from "react";

const KEY = "waamflow.canvasBuild";
const listeners = new Set<() => void>();
let current: string | null = (() => {
  try {
    return sessionStorage.getItem(KEY);
  } catch {
    return null;
  }
})();

export function setCanvasBuild(id: string | null): void {
  current = id;
  try {
    if (id) sessionStorage.setItem(KEY, id);
    else sessionStorage.removeItem(KEY);
  } catch {
    /* storage off: kept in memory */
  }
  listeners.forEach((l) => l());
}

export const canvasBuild = () => current;

export function useCanvasBuild(): string | null {
  return useSyncExternalStore(
    (l) => {
      listeners.add(l);
      return () => listeners.delete(l);
    },
    () => current,
    () => null,
  );
}
