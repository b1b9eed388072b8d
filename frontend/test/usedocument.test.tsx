// @vitest-environment jsdom
// The document hook (#27: App.tsx split): undo steps of recipe edits and XML typing, load/save/delete.
import { describe, expect, it } from "vitest";
import type { Recipe } from "../src/api/types";
import { newDocument } from "../src/document/document";
import { editStep, TYPING_MS, useDocument, xmlStep, type LastEdit } from "../src/document/useDocument";
import { emptyRecipe, setNodeParams } from "../src/graph/recipe";
import { act, renderHook } from "./renderHook";

const base: Recipe = { ...emptyRecipe("r"), nodes: [{ id: "a", type: "slice", params: {} }, { id: "b", type: "slice", params: {} }] };
const setA = (r: Recipe, v: number) => setNodeParams(r, "a", { layer_height: v });
const setB = (r: Recipe, v: number) => setNodeParams(r, "b", { layer_height: v });

describe("editStep: one undo step per edit, typing folded", () => {
  it("typing the same field within TYPING_MS folds; after the pause, or another field, is a new step", () => {
    let h = newDocument(base, null);
    let last: LastEdit | null = null;
    const type = (next: Recipe, now: number) => {
      const r = editStep(h, next, { typing: true, now, last, foldUntil: 0 });
      h = r.hist;
      last = r.last;
    };
    type(setA(h.present.recipe, 1), 1000);
    type(setA(h.present.recipe, 1.5), 1000 + TYPING_MS - 1); // same field, in time: folded
    expect(h.past.length).toBe(1);
    type(setB(h.present.recipe, 2), 1000 + TYPING_MS); // another field: a new step
    expect(h.past.length).toBe(2);
    type(setB(h.present.recipe, 2.5), 1000 + 3 * TYPING_MS); // same field after the pause
    expect(h.past.length).toBe(3);
    expect(h.present.recipe.nodes.map((n) => n.params.layer_height)).toEqual([1.5, 2.5]);
  });

  it("an edit that is not typing is always a new step; an edit before foldUntil joins the last step", () => {
    let h = newDocument(base, null);
    h = editStep(h, setA(base, 1), { typing: false, now: 0, last: null, foldUntil: 0 }).hist;
    const r = editStep(h, setA(h.present.recipe, 2), { typing: false, now: 10, last: null, foldUntil: 0 });
    expect(r.hist.past.length).toBe(2);
    expect(r.last).toBeNull();
    const folded = editStep(h, setB(h.present.recipe, 3), { typing: false, now: 10, last: null, foldUntil: 11 });
    expect(folded.hist.past.length).toBe(1);
    expect(folded.hist.present.recipe.nodes[1].params.layer_height).toBe(3);
  });

  it("the same recipe back is no step and keeps the typing clock", () => {
    const h = newDocument(base, null);
    const last = { sig: "node:a", t: 5 };
    const r = editStep(h, base, { typing: true, now: 6, last, foldUntil: 0 });
    expect(r.hist).toBe(h);
    expect(r.last).toBe(last);
  });
});

describe("xmlStep: one undo step per pause in typing", () => {
  it("keystrokes within TYPING_MS share one step; a set (not typing) resets the clock", () => {
    let h = newDocument(base, null);
    let r = xmlStep(h, "<a/>", { typing: true, now: 100, lastT: 0 });
    h = r.hist;
    r = xmlStep(h, "<ab/>", { typing: true, now: 100 + TYPING_MS - 1, lastT: r.lastT });
    expect(r.hist.past.length).toBe(1);
    expect(r.hist.present.xml).toBe("<ab/>");
    const set = xmlStep(r.hist, null, { typing: false, now: 101, lastT: r.lastT });
    expect(set.hist.past.length).toBe(2);
    expect(set.lastT).toBe(0);
  });
});

describe("useDocument", () => {
  it("edits make the recipe dirty; undo/redo restore; load and markSaved make it clean; delete makes it unsaved", () => {
    const { result } = renderHook(() => useDocument(), undefined);
    expect(result.current.dirty.any).toBe(false);
    act(() => result.current.load(base, "r", "<x/>"));
    expect(result.current.graphName).toBe("r");
    expect(result.current.dirty).toEqual({ recipe: false, xml: false, any: false });
    act(() => result.current.edit((r) => setA(r, 2)));
    expect(result.current.dirty.recipe).toBe(true);
    expect(result.current.hist.past.length).toBe(1);
    act(() => result.current.undo());
    expect(result.current.dirty.any).toBe(false);
    act(() => result.current.redo());
    expect(result.current.recipe.nodes[0].params.layer_height).toBe(2);
    act(() => result.current.setXmlDraft("<y/>"));
    expect(result.current.dirty).toEqual({ recipe: true, xml: true, any: true });
    act(() => result.current.markSaved({ ...result.current.recipe, name: "s" }, "<y/>", "s"));
    expect(result.current.graphName).toBe("s");
    expect(result.current.dirty.any).toBe(false);
    expect(result.current.hist.past.length).toBe(2); // saving keeps the history
    act(() => result.current.markDeleted());
    expect(result.current.graphName).toBeNull();
    expect(result.current.dirty.recipe).toBe(true);
  });

  it("typingEdit folds keystrokes into one step; foldNextFor joins the next edit to the last step", () => {
    const { result } = renderHook(() => useDocument(), undefined);
    act(() => result.current.load(base, null, null));
    act(() => result.current.typingEdit((r) => setA(r, 1)));
    act(() => result.current.typingEdit((r) => setA(r, 12)));
    expect(result.current.hist.past.length).toBe(1);
    act(() => result.current.edit((r) => setB(r, 3)));
    act(() => void result.current.foldNextFor(10_000));
    act(() => result.current.edit((r) => setB(r, 4)));
    expect(result.current.hist.past.length).toBe(2);
    expect(result.current.recipe.nodes.map((n) => n.params.layer_height)).toEqual([12, 4]);
  });
});
