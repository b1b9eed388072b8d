/**
 * The section keys ("bs1/A") of the layer last previewed on the mask canvas (or of the latest run),
 * offered by per-section maps in parameter forms. A tiny external store: the mask canvas publishes,
 * forms subscribe (useSyncExternalStore), nothing else needs to pass them around.
 */
import { useSyncExternalStore } from "react";

let keys: readonly string[] = [];
const listeners = new Set<() => void>();

export function publishSectionKeys(next: readonly string[]): void {
  const uniq = [...new Set(next)];
  if (uniq.length === keys.length && uniq.every((k, i) => k === keys[i])) return;
  keys = uniq;
  listeners.forEach((l) => l());
}

export function useSectionKeys(): readonly string[] {
  return useSyncExternalStore(
    (l) => (listeners.add(l), () => listeners.delete(l)),
    () => keys,
    () => keys,
  );
}

/** Keys for a section picker: the known sections first (in layer order), then keys only present in the value. */
export function sectionChoices(known: readonly string[], present: readonly string[]): string[] {
  return [...new Set([...known, ...[...present].sort()])];
}

/**
 * The section the user asked to look at (a problem clicked in the problems panel): the mask canvas
 * selects it and per-section maps in the inspector pick it. `seq` makes a repeated click count.
 */
export interface SectionFocus { key: string; seq: number }
let focus: SectionFocus | null = null;
const focusListeners = new Set<() => void>();

export function focusSection(key: string): void {
  focus = { key, seq: (focus?.seq ?? 0) + 1 };
  focusListeners.forEach((l) => l());
}

export function useSectionFocus(): SectionFocus | null {
  return useSyncExternalStore(
    (l) => (focusListeners.add(l), () => focusListeners.delete(l)),
    () => focus,
    () => focus,
  );
}
